#include "basis/core/file_error.h"

#include <filesystem>
#include <system_error>

namespace basis {

void check_regular_file(const std::string& path, const std::string& what) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (error) throw FileError(path + ": " + error.message());
  if (std::filesystem::is_directory(status))
    throw FileError(path + ": is a directory" + (what.empty() ? "" : ", not " + what));
  if (!std::filesystem::is_regular_file(status)) throw FileError(path + ": is not a regular file");
}

}  // namespace basis
