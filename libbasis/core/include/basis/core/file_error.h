// The error every reader and writer throws: one line that names the file and the problem.
#pragma once

#include <stdexcept>
#include <string>

namespace basis {

class FileError : public std::runtime_error {
 public:
  // NUL bytes in the message (a file's text quoted in it) are written as \0, so that what()
  // does not end at the first.
  explicit FileError(const std::string& message);
};

// Throws FileError naming `path` unless it is a regular file (links followed), before a reader
// opens it: "is a directory" (", not " + `what` when given) for a folder, "is not a regular
// file" for a FIFO, socket or device (a reader would wait on it, or never reach its end), and
// the system's message when it is missing or cannot be examined.
void check_regular_file(const std::string& path, const std::string& what = "");

}  // namespace basis
