// Small text files (specs, scenes) read whole, from a regular file or from a pipe.
#pragma once

#include <cstddef>
#include <string>

#include "basis/core/file_error.h"

namespace basis {

// The whole of `path`: a regular file, or a pipe (/dev/stdin, a FIFO) read to its end. A FIFO
// that no process writes reads as empty rather than waiting for a writer. Throws FileError
// naming `path`: a folder ("is a directory, not " + `what`), a device, more than `max_bytes`
// ("larger than LIMIT, not " + `what`), or an I/O error.
std::string read_text_file(const std::string& path, std::size_t max_bytes, const std::string& what);

}  // namespace basis
