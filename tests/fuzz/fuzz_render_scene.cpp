// libFuzzer target: render scene files (JSON) are parsed and checked; whatever parses must give
// finite camera rays.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "basis/core/file_error.h"
#include "basis/render/scene_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const basis::SceneFile scene = basis::parse_scene_file(text, "scene.json", "/nonexistent");
    const basis::Camera& c = scene.camera;
    for (const double x : {0.0, 0.5 * c.width, double(c.width)})
      for (const double y : {0.0, 0.5 * c.height, double(c.height)})
        if (!c.ray(x, y).direction.allFinite()) std::abort();
  } catch (const basis::FileError&) {
  }
  return 0;
}
