// Capture sets: hemisphere captures of incident radiance at surface points, one quadtree per
// point over the cosine-weighted concentric map of the point's local frame.
#pragma once

#include <cstddef>
#include <cstdint>
#include <numbers>
#include <span>
#include <vector>

#include "basis/core/color.h"
#include "basis/core/frame.h"
#include "basis/core/tree_set.h"
#include "basis/core/vector.h"

namespace basis {

// A light much smaller than a capture's texels (a sun), kept apart from the capture's tree:
// its unit direction in the capture's local frame (z > 0) and its energy, the integral of its
// radiance over the solid angle it covers, per channel. It adds f(direction, wo) energy
// direction.z to the radiance reflected towards wo.
struct DirectionalLight {
  Vec3 direction;
  Color energy;
};

// What lights kept apart add to the mean of a capture's texels, as if splatted into them (a
// texel holds radiance times cos(theta) / pi of the cosine-weighted map's measure): the sum of
// energy x direction.z / pi, per channel.
inline Color mean_of_lights(std::span<const DirectionalLight> lights) {
  Color mean{0, 0, 0};
  for (const DirectionalLight& light : lights)
    for (std::size_t c = 0; c < 3; ++c)
      mean[c] += light.energy[c] * light.direction.z() / std::numbers::pi;
  return mean;
}

// Capture k: position, unit normal and unit tangent (bitangent = normal x tangent) in world
// coordinates, tree k of `trees`, and lights [light_offsets[k], light_offsets[k + 1]) of
// `lights` (light_offsets is empty when no capture keeps lights apart).
struct CaptureSetView {
  std::span<const Vec3> positions;
  std::span<const Vec3> normals;
  std::span<const Vec3> tangents;
  TreeSetView trees;
  std::span<const DirectionalLight> lights;
  std::span<const std::uint32_t> light_offsets;

  std::size_t size() const { return positions.size(); }
  // The local frame of capture k: tangent, bitangent = normal x tangent, normal.
  Frame frame(std::size_t k) const {
    return {tangents[k], normals[k].cross(tangents[k]), normals[k]};
  }
  std::span<const DirectionalLight> lights_of(std::size_t k) const {
    if (light_offsets.empty()) return {};
    return lights.subspan(light_offsets[k], light_offsets[k + 1] - light_offsets[k]);
  }
  // Captures [first, first + count) (within the set), with their trees and lights.
  CaptureSetView slice(std::size_t first, std::size_t count) const {
    return {positions.subspan(first, count),
            normals.subspan(first, count),
            tangents.subspan(first, count),
            trees.slice(first, count),
            lights,
            light_offsets.empty() ? light_offsets : light_offsets.subspan(first, count + 1)};
  }
};

struct CaptureSet {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;
  std::vector<Vec3> tangents;
  TreeSet trees;
  std::vector<DirectionalLight> lights;
  std::vector<std::uint32_t> light_offsets;

  CaptureSetView view() const {
    return {positions, normals, tangents, trees.view(), lights, light_offsets};
  }
};

}  // namespace basis
