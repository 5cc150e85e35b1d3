// Environment maps for tests: real probes from the shared data folder when present, and a
// synthetic sky with a small sun generated here (always available).
#pragma once

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <optional>
#include <string>

#include "basis/io/image.h"
#include "basis/io/image_file.h"
#include "basis/lighting/environment.h"

namespace basis::testing {

// The folder of real probes next to the project (../shared/data/probes), if present.
inline std::optional<std::filesystem::path> probe_folder() {
  for (std::filesystem::path p = std::filesystem::current_path(); !p.empty(); p = p.parent_path()) {
    const auto candidate = p / ".." / "shared" / "data" / "probes";
    if (std::filesystem::is_directory(candidate)) return std::filesystem::canonical(candidate);
    if (p == p.root_path()) break;
  }
  const std::filesystem::path source(BASIS_SOURCE_DIR);
  const auto candidate = source / ".." / "shared" / "data" / "probes";
  if (std::filesystem::is_directory(candidate)) return std::filesystem::canonical(candidate);
  return std::nullopt;
}

// A real probe by name (grace, uffizi, pisa, ennis, wells), or nothing with a notice.
inline std::optional<Image> real_probe(const std::string& name) {
  const auto folder = probe_folder();
  if (!folder || !std::filesystem::exists(*folder / (name + ".hdr"))) {
    std::printf("[  NOTE    ] shared probe %s.hdr is absent: only the synthetic map is used\n",
                name.c_str());
    return std::nullopt;
  }
  return read_image((*folder / (name + ".hdr")).string());
}

// A 256 x 128 lat-long sky: blue gradient above, dim ground below, and a sun of about
// 0.5 degrees (one pixel) of radiance `sun` at 35 degrees elevation.
inline Image synthetic_sky(float sun = 2e4f) {
  const int w = 256, h = 128;
  Image image(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double theta = std::numbers::pi * (y + 0.5) / h;
      const double up = std::cos(theta);
      const float sky[3] = {0.4f, 0.55f, 0.9f};
      for (int c = 0; c < 3; ++c)
        image.at(x, y, c) = up > 0 ? sky[c] * float(0.6 + 0.8 * (1 - up)) : 0.15f + 0.05f * c;
    }
  const int sun_row = int(h * (90.0 - 35.0) / 180.0), sun_column = w / 5;
  image.at(sun_column, sun_row, 0) = sun;
  image.at(sun_column, sun_row, 1) = sun * 0.95f;
  image.at(sun_column, sun_row, 2) = sun * 0.85f;
  return image;
}

}  // namespace basis::testing
