// Atomic file output: data go to a temporary file in the destination folder, which is renamed
// over the target only when complete, so readers see the old file or the whole new one.
#pragma once

#include <cstddef>
#include <functional>
#include <span>
#include <string>
#include <string_view>

#include "basis/core/file_error.h"

namespace basis {

// A file written in pieces and published whole: the pieces go to a temporary file in the
// destination's folder, which commit() renames over `path`. The temporary is unnamed where the
// file system allows (O_TMPFILE), so that a process killed outright (SIGKILL) leaves nothing;
// elsewhere it is a hidden file, removed when the writer is destroyed without a commit. A
// destination that exists and is not a regular file (a device, a pipe) is written directly; a
// symbolic link to an existing file is written through (its target replaced, the link kept).
// Every failure is a FileError naming `path` (the link's target, through a link).
class AtomicFileWriter {
 public:
  explicit AtomicFileWriter(std::string path);
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  ~AtomicFileWriter();

  void write(std::span<const std::byte> data);
  void write(std::string_view text) { write(std::as_bytes(std::span(text.data(), text.size()))); }
  // Flushes the data to disk and puts the file in place.
  void commit();

 private:
  std::string path_;
  std::string temp_path_;  // empty for an unnamed temporary or a direct write
  int fd_ = -1;
  bool unnamed_ = false;
  bool direct_ = false;
};

// Where writing `path` goes: through a symbolic link to an existing file, that file (the link
// stays a link); otherwise `path` itself.
std::string through_links(const std::string& path);

// Writes `data` to `path` atomically. A destination that exists and is not a regular file (a
// device such as /dev/null, a pipe) is written directly. Throws FileError; on failure no
// temporary file is left behind and an existing file at `path` is untouched.
void write_file_atomically(const std::string& path, std::span<const std::byte> data);

// Same, for writers that need a path of their own: `write` is called with the temporary path,
// which is renamed to `path` when `write` returns. If it throws, the temporary is removed and
// the exception propagates.
void write_file_atomically(const std::string& path,
                           const std::function<void(const std::string& temp_path)>& write);

}  // namespace basis
