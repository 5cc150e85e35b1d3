// The capture inputs' checksum: equal for equal content whatever the map is called, different
// for any change a capture would see (a texel of the map, a vertex, a triangle, an emitter, the
// scene's presence), against the inputs themselves.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "basis/io/checksum.h"
#include "basis/lighting/capture_inputs.h"

namespace basis {
namespace {

Image sky() {
  Image image(16, 8, 3);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x)
      for (int c = 0; c < 3; ++c)
        image.at(x, y, c) = 0.25f * float(1 + (x + 3 * y + c) % 5);
  return image;
}

TriangleMesh wall() {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};
  mesh.triangles = {{0, 1, 2}, {1, 3, 2}};
  mesh.emission = {{0, 0, 0}, {0, 0, 0}};
  return mesh;
}

TEST(CaptureInputs, ChecksumFollowsWhatACaptureSees) {
  const Environment map(sky(), 0, "a.exr");
  const TriangleMesh mesh = wall();
  const std::string reference = capture_inputs_checksum(map, &mesh);
  EXPECT_TRUE(is_checksum_text(reference));
  // The same content under another name, and read again: the same checksum.
  EXPECT_EQ(capture_inputs_checksum(Environment(sky(), 0, "elsewhere/b.hdr"), &mesh), reference);
  // Any change a capture would see: another one.
  std::vector<std::string> changed;
  Image texel = sky();
  texel.at(5, 3, 1) += 0.125f;
  changed.push_back(capture_inputs_checksum(Environment(texel, 0, "a.exr"), &mesh));
  TriangleMesh moved = wall();
  moved.vertices[3][2] = 1.5f;
  changed.push_back(capture_inputs_checksum(map, &moved));
  TriangleMesh rewound = wall();
  rewound.triangles[1] = {1, 2, 3};
  changed.push_back(capture_inputs_checksum(map, &rewound));
  TriangleMesh lamp = wall();
  lamp.emission[0] = {5, 5, 5};
  changed.push_back(capture_inputs_checksum(map, &lamp));
  changed.push_back(capture_inputs_checksum(map, nullptr));
  TriangleMesh fewer = wall();
  fewer.triangles.pop_back();
  fewer.emission.pop_back();
  changed.push_back(capture_inputs_checksum(map, &fewer));
  changed.push_back(capture_inputs_checksum(Environment::constant({1, 2, 3}), &mesh));
  for (std::size_t i = 0; i < changed.size(); ++i) {
    EXPECT_NE(changed[i], reference) << i;
    for (std::size_t j = 0; j < i; ++j)
      EXPECT_NE(changed[i], changed[j]) << i << " " << j;
  }
}

}  // namespace
}  // namespace basis
