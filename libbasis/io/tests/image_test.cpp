// Images in memory: capture images to grids and back, refusal of what is not a capture image,
// and tone mapping.
#include <gtest/gtest.h>

#include <cmath>

#include "basis/core/file_error.h"
#include "basis/io/image.h"

namespace basis {
namespace {

TEST(ImageGrid, RoundTripsTexelForTexel) {
  Grid grid(8, 3);
  for (std::size_t i = 0; i < grid.texels.size(); ++i)
    grid.texels[i] = float(i % 97) * 0.25f;
  const Image image = grid_to_image(grid);
  ASSERT_EQ(image.width, 8);
  ASSERT_EQ(image.height, 8);
  // Texel (x, y) sits at column x, row y.
  EXPECT_EQ(image.at(5, 2, 1), grid.at(0, 1, 5, 2));
  EXPECT_EQ(image_to_grid(image, "x.exr").texels, grid.texels);
}

TEST(ImageGrid, GreyStandsForAllThreeChannels) {
  Image grey(4, 4, 1);
  grey.at(1, 3, 0) = 2.5f;
  const Grid grid = image_to_grid(grey, "grey.exr");
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(grid.at(0, c, 1, 3), 2.5f);
  Grid one(4, 1);
  one.at(0, 0, 2, 1) = 7;
  const Image image = grid_to_image(one);
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(image.at(2, 1, c), 7.0f);
}

TEST(ImageGrid, RefusesWhatIsNotACaptureImageNamingIt) {
  auto message = [](const Image& image) {
    try {
      image_to_grid(image, "bad.exr");
    } catch (const FileError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(message(Image(8, 4, 3)),
            "bad.exr: a capture image is square with a power-of-two side from 2 to 512, got 8 x 4");
  EXPECT_NE(message(Image(12, 12, 3)).find("power-of-two"), std::string::npos);
  EXPECT_NE(message(Image(1024, 1024, 3)).find("512"), std::string::npos);
  Image nan(4, 4, 3);
  nan.at(0, 0, 0) = std::nanf("");
  nan.at(1, 0, 2) = -1;
  nan.at(2, 0, 1) = INFINITY;
  EXPECT_EQ(message(nan), "bad.exr: 3 texel values are NaN, infinite or negative");
}

TEST(ToneMap, IsMonotonicAndStaysInTheUnitInterval) {
  float last = -1;
  for (float v : {0.0f, 1e-4f, 0.01f, 0.5f, 1.0f, 4.0f, 100.0f, 1e6f}) {
    const float t = tone_map(v, 1.0f);
    EXPECT_GE(t, 0.0f);
    EXPECT_LE(t, 1.0f);
    EXPECT_GT(t, last) << v;
    last = t;
  }
  EXPECT_EQ(tone_map(-3.0f, 1.0f), 0.0f);  // negative values are black
  EXPECT_EQ(tone_map(1.0f, 0.0f), 0.0f);   // no exposure without an average
  // At the average a value maps to key / (1 + key) before the sRGB curve: 1/3 for the default.
  const double linear = 1.0 / 3;
  EXPECT_NEAR(tone_map(2.0f, 2.0f), 1.055 * std::pow(linear, 1 / 2.4) - 0.055, 1e-6);
}

}  // namespace
}  // namespace basis
