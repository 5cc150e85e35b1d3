#include "basis/core/file_error.h"

#include <filesystem>
#include <system_error>

namespace basis {

namespace {

std::string without_nul_bytes(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text)
    if (c == '\0')
      out += "\\0";
    else
      out += c;
  return out;
}

}  // namespace

FileError::FileError(const std::string& message) : std::runtime_error(without_nul_bytes(message)) {}

void check_regular_file(const std::string& path, const std::string& what) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (error) throw FileError(path + ": " + error.message());
  if (std::filesystem::is_directory(status))
    throw FileError(path + ": is a directory" + (what.empty() ? "" : ", not " + what));
  if (!std::filesystem::is_regular_file(status)) throw FileError(path + ": is not a regular file");
}

}  // namespace basis
