// Shading capture points with a BRDF table (DESIGN sections 1 and 5): reflected radiance at
// every capture of a set for an outgoing direction, optionally for a tilted surface normal.
#pragma once

#include <optional>

#include "basis/brdf_table.h"
#include "basis/capture_set.h"
#include "basis/frame.h"

namespace basis {

struct ShadingOptions {
  // Outgoing direction in the shading frame (the capture's frame unless `normal` is given);
  // must have wo.z >= 0.
  Vec3 wo{0, 0, 1};
  // Shade as if the surface normal were this unit vector (world coordinates) instead of the
  // capture's: the shading frame is the capture's frame rotated by the smallest rotation taking
  // its normal to this one, and the tilt is compensated as `tilt_mode` says.
  std::optional<Vec3> normal;
  TiltCompensation tilt_mode = TiltCompensation::compensated;
};

// The frame of capture k (tangent, bitangent = normal x tangent, normal).
Frame capture_frame(const CaptureSetView& captures, std::size_t k);

// The tilt of a surface of normal `normal` (world) against capture k's frame.
Tilt capture_tilt(const CaptureSetView& captures, std::size_t k, const Vec3& normal);

// Reflected radiance (pi included) at capture k, with the certified bound of the lookup.
Convolution shade(const BrdfTableView& table, const CaptureSetView& captures, std::size_t k,
                  const ShadingOptions& options);

}  // namespace basis
