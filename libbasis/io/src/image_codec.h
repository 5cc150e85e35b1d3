// What the image codec module (libbasis_image_codec.so, built on OpenImageIO) gives the rest of
// libbasis. The module is loaded on the first image read or written (image_file.cpp), so that
// programs that never touch an image do not load OpenImageIO's 260 shared libraries at start.
// Both sides are built together; kAbiVersion and the project version guard against a stray copy.
#pragma once

#include <string>
#include <vector>

namespace basis::image_codec {

inline constexpr int kAbiVersion = 1;

struct Functions {
  int abi_version;
  const char* project_version;
  // Reads the first subimage of `path` as float pixels (row by row, channels interleaved);
  // refuses images of more than max_pixels pixels before allocating. Returns "" or the problem,
  // on one line.
  std::string (*read)(const std::string& path, long long max_pixels, int& width, int& height,
                      int& channels, std::vector<float>& pixels);
  // Writes the pixels to temp_path in the format `path`'s extension names: .exr and .hdr store
  // floats, other formats 8-bit values clamped to [0,1]. Returns "" or the problem, on one line.
  std::string (*write)(const std::string& path, const std::string& temp_path, int width, int height,
                       int channels, const float* pixels);
};

// The name of the function the module exports, which returns its Functions.
inline constexpr const char* kEntryPoint = "basis_image_codec_functions";

}  // namespace basis::image_codec
