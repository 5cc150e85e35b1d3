// Image files through OpenImageIO: any format it reads (EXR, HDR, PNG, ...) in, EXR or PNG out.
// Kept in its own library (basis_image_file) so that the rest links no image library.
#pragma once

#include <string>
#include <vector>

#include "basis/core/file_error.h"
#include "basis/io/image.h"

namespace basis {

// Largest image accepted, in pixels (checked before allocating).
inline constexpr long long kMaxImagePixels = 1LL << 28;

// Reads the first subimage as float; throws FileError("PATH: problem") on any failure,
// including sizes over kMaxImagePixels.
Image read_image(const std::string& path);

// Writes atomically; the format follows the extension (.exr stores floats, .png and others
// 8-bit values clamped to [0,1]). Throws FileError.
void write_image(const std::string& path, const Image& image);

// An image and the path it is written to.
struct NamedImage {
  std::string path;
  const Image* image = nullptr;
};

// Writes several images as one output (a render's EXR and its PNG): each to a temporary file
// beside its destination, then all renamed into place, so that when any cannot be written none
// is put in place and the files they would replace stay as they were (only a failure of the
// final renames themselves could leave some in place). Destinations that exist and are not
// regular files (devices, pipes) are written directly, as write_image does. Throws FileError
// naming the path.
void write_images(const std::vector<NamedImage>& images);

}  // namespace basis
