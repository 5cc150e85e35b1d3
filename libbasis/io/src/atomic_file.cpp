#include "basis/io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

namespace basis {

namespace {

std::string describe_errno(const std::string& path, const std::string& action) {
  return path + ": cannot " + action + ": " + std::strerror(errno);
}

// Kind of what is at `path` now: 0 none, 1 regular file, 2 directory, 3 something else.
int destination_kind(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return 0;
  if (S_ISREG(st.st_mode)) return 1;
  if (S_ISDIR(st.st_mode)) return 2;
  return 3;
}

void write_all(int fd, std::span<const std::byte> data, const std::string& path) {
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw FileError(describe_errno(path, "write"));
    }
    done += std::size_t(n);
  }
}

// Creates a temporary file next to `path`; returns its name and open descriptor.
std::pair<std::string, int> make_temporary(const std::string& path) {
  const std::filesystem::path target(path);
  std::filesystem::path dir = target.parent_path();
  if (dir.empty()) dir = ".";
  std::string base = ".";  // hidden temporary next to the target
  base += target.filename().string();
  base += ".tmp-XXXXXX";
  const std::string name = (dir / base).string();
  std::vector<char> buffer(name.begin(), name.end());
  buffer.push_back('\0');
  const int fd = ::mkstemp(buffer.data());
  if (fd < 0) throw FileError(describe_errno(path, "create a file in " + dir.string()));
  return {std::string(buffer.data()), fd};
}

void check_destination(const std::string& path) {
  if (path.empty()) throw FileError("output path is empty");
  if (destination_kind(path) == 2) throw FileError(path + ": is a directory");
}

}  // namespace

void write_file_atomically(const std::string& path, std::span<const std::byte> data) {
  check_destination(path);
  if (destination_kind(path) == 3) {  // a device or pipe: no rename possible, write through
    const int fd = ::open(path.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd < 0) throw FileError(describe_errno(path, "open for writing"));
    try {
      write_all(fd, data, path);
    } catch (...) {
      ::close(fd);
      throw;
    }
    if (::close(fd) != 0) throw FileError(describe_errno(path, "write"));
    return;
  }
  auto [temp, fd] = make_temporary(path);
  try {
    write_all(fd, data, path);
    if (::fsync(fd) != 0) throw FileError(describe_errno(path, "write"));
    if (::close(fd) != 0) {
      fd = -1;
      throw FileError(describe_errno(path, "write"));
    }
    fd = -1;
    ::chmod(temp.c_str(), 0644);  // mkstemp creates 0600; outputs are ordinary files
    if (::rename(temp.c_str(), path.c_str()) != 0) throw FileError(describe_errno(path, "replace"));
  } catch (...) {
    if (fd >= 0) ::close(fd);
    ::unlink(temp.c_str());
    throw;
  }
}

void write_file_atomically(const std::string& path,
                           const std::function<void(const std::string& temp_path)>& write) {
  check_destination(path);
  if (destination_kind(path) == 3) {
    write(path);
    return;
  }
  auto [temp, fd] = make_temporary(path);
  ::close(fd);
  try {
    write(temp);
    ::chmod(temp.c_str(), 0644);
    if (::rename(temp.c_str(), path.c_str()) != 0) throw FileError(describe_errno(path, "replace"));
  } catch (...) {
    ::unlink(temp.c_str());
    throw;
  }
}

}  // namespace basis
