// Loads a .qt BRDF table and a capture set and prints the reflected radiance at every capture
// towards the normal, one line per capture: what a renderer linking libbasis would do. With
// --image FILE, reads an image instead and prints its width, height and channels.
#include <cstdio>
#include <exception>
#include <string>

#include "basis/format/qt_file.h"
#include "basis/io/image_file.h"
#include "basis/lighting/shading.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: consumer TABLE.qt CAPTURES.qt | consumer --image FILE\n");
    return 2;
  }
  try {
    if (std::string(argv[1]) == "--image") {
      const basis::Image image = basis::read_image(argv[2]);
      std::printf("%d %d %d\n", image.width, image.height, image.channels);
      return 0;
    }
    const basis::QtFile table = basis::QtFile::load(argv[1]);
    const basis::QtFile captures = basis::QtFile::load(argv[2]);
    basis::ShadingOptions options;
    for (std::size_t k = 0; k < captures.captures().size(); ++k) {
      const basis::Convolution c =
          basis::shade(table.brdf_table(), captures.captures(), k, options);
      std::printf("%zu %.7g %.7g %.7g\n", k, c.value[0], c.value[1], c.value[2]);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 1;
  }
  return 0;
}
