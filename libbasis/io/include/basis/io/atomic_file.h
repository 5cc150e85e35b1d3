// Atomic file output: data go to a temporary file in the destination folder, which is renamed
// over the target only when complete, so readers see the old file or the whole new one.
#pragma once

#include <cstddef>
#include <functional>
#include <span>
#include <string>

#include "basis/core/file_error.h"

namespace basis {

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
