// The error every reader and writer throws: one line that names the file and the problem.
#pragma once

#include <stdexcept>

namespace basis {

class FileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace basis
