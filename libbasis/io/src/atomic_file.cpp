#include "basis/io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <tuple>
#include <utility>
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

// The start of a hidden temporary's name beside `target`, before a suffix of up to
// `suffix_bytes`: "." and the target's name when the whole leaves room (a file name holds at
// most 255 bytes on Linux), else ".basis".
std::string hidden_prefix(const std::filesystem::path& target, std::size_t suffix_bytes) {
  const std::string name = target.filename().string();
  return "." + (1 + name.size() + suffix_bytes <= 255 ? name : std::string("basis"));
}

// Creates a temporary file next to `path`; returns its name and open descriptor.
std::pair<std::string, int> make_temporary(const std::string& path) {
  const std::filesystem::path target(path);
  std::filesystem::path dir = target.parent_path();
  if (dir.empty()) dir = ".";
  const std::string base = hidden_prefix(target, 11) + ".tmp-XXXXXX";
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

std::string through_links(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_symlink(path, error)) return path;
  const std::filesystem::path target = std::filesystem::canonical(path, error);
  return error ? path : target.string();
}

AtomicFileWriter::AtomicFileWriter(std::string path) : path_(through_links(path)) {
  check_destination(path_);
  if (destination_kind(path_) == 3) {  // a device or pipe: no rename possible, write through
    fd_ = ::open(path_.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd_ < 0) throw FileError(describe_errno(path_, "open for writing"));
    direct_ = true;
    return;
  }
  std::filesystem::path dir = std::filesystem::path(path_).parent_path();
  if (dir.empty()) dir = ".";
  fd_ = ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0644);
  if (fd_ >= 0) {
    unnamed_ = true;
    ::fchmod(fd_, 0644);  // whatever the umask: outputs are ordinary files
    return;
  }
  // File systems without unnamed temporaries refuse with one of these; others are real errors.
  if (errno != EOPNOTSUPP && errno != EISDIR && errno != EINVAL)
    throw FileError(describe_errno(path_, "create a file in " + dir.string()));
  std::tie(temp_path_, fd_) = make_temporary(path_);
  ::fchmod(fd_, 0644);  // mkstemp creates 0600
}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) ::close(fd_);
  if (!temp_path_.empty()) ::unlink(temp_path_.c_str());
}

void AtomicFileWriter::write(std::span<const std::byte> data) {
  if (fd_ < 0) throw FileError(path_ + ": written after it was committed");
  write_all(fd_, data, path_);
}

void AtomicFileWriter::commit() {
  if (fd_ < 0) throw FileError(path_ + ": committed twice");
  if (direct_) {
    const int fd = std::exchange(fd_, -1);
    if (::close(fd) != 0) throw FileError(describe_errno(path_, "write"));
    return;
  }
  if (::fsync(fd_) != 0) throw FileError(describe_errno(path_, "write"));
  if (unnamed_) {
    // Give the unnamed file a hidden name beside the target, then rename it over the target:
    // a name that exists for the moment between the two calls only.
    const std::filesystem::path target(path_);
    std::filesystem::path dir = target.parent_path();
    if (dir.empty()) dir = ".";
    const std::string proc = "/proc/self/fd/" + std::to_string(fd_);
    for (int attempt = 0; temp_path_.empty(); ++attempt) {
      const std::string base = hidden_prefix(target, 32) + ".tmp-" + std::to_string(::getpid()) +
                               "-" + std::to_string(attempt);
      const std::string name = (dir / base).string();
      if (::linkat(AT_FDCWD, proc.c_str(), AT_FDCWD, name.c_str(), AT_SYMLINK_FOLLOW) == 0)
        temp_path_ = name;
      else if (errno != EEXIST || attempt > 100)
        throw FileError(describe_errno(path_, "create a file in " + dir.string()));
    }
  }
  const int fd = std::exchange(fd_, -1);
  if (::close(fd) != 0) throw FileError(describe_errno(path_, "write"));
  if (::rename(temp_path_.c_str(), path_.c_str()) != 0)
    throw FileError(describe_errno(path_, "replace"));
  temp_path_.clear();
}

void write_file_atomically(const std::string& path, std::span<const std::byte> data) {
  AtomicFileWriter writer(path);
  writer.write(data);
  writer.commit();
}

void write_file_atomically(const std::string& destination,
                           const std::function<void(const std::string& temp_path)>& write) {
  const std::string path = through_links(destination);
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
