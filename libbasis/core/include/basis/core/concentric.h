// Concentric map between the unit square and the unit disk (Shirley & Chiu 1997, "A Low
// Distortion Map Between Disk and Square"): continuous, area-preserving up to the factor pi.
#pragma once

#include "basis/core/vector.h"

namespace basis {

// Maps (u, v) in [0,1]^2 to the unit disk; square area maps to disk area times pi.
// Corner (0,0) maps to (-1/sqrt2, -1/sqrt2), the centre (0.5,0.5) to the origin.
Vec2 square_to_uniform_disk_concentric(const Vec2& uv);

// Inverse of square_to_uniform_disk_concentric: a point of the unit disk to (u, v) in [0,1]^2.
Vec2 uniform_disk_to_square_concentric(const Vec2& xy);

// Density of the concentric disk sample with respect to disk area: 1/pi everywhere.
double square_to_uniform_disk_concentric_pdf();

}  // namespace basis
