#include "basis/io/text_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "basis/core/file_error.h"

namespace basis {

namespace {

std::string size_text(std::size_t bytes) {
  return bytes >= (std::size_t(1) << 20) ? std::to_string(bytes >> 20) + " MiB"
                                         : std::to_string(bytes) + " bytes";
}

}  // namespace

std::string read_text_file(const std::string& path, std::size_t max_bytes,
                           const std::string& what) {
  // Without blocking, so that opening a FIFO does not wait for a writer; reads block again.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw FileError(path + ": " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw FileError(path + ": " + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) throw FileError(path + ": is a directory, not " + what);
  if (!S_ISREG(st.st_mode) && !S_ISFIFO(st.st_mode))
    throw FileError(path + ": is not a regular file or a pipe");
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0 || ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0)
    throw FileError(path + ": " + std::strerror(errno));
  std::string text;
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw FileError(path + ": cannot read: " + std::strerror(errno));
    }
    if (n == 0) break;
    text.append(buffer, std::size_t(n));
    if (text.size() > max_bytes)
      throw FileError(path + ": larger than " + size_text(max_bytes) + ", not " + what);
  }
  return text;
}

}  // namespace basis
