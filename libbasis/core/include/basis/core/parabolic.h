// Parabolic map of the hemisphere (Heidrich & Seidel 1999, "Realistic, hardware-accelerated
// shading and lighting"): (s, t) = (x, y) / (1 + z), the unit disk, r = tan(theta / 2).
#pragma once

#include "basis/core/vector.h"

namespace basis {

// Direction with z >= 0 to its parabolic coordinates (s, t) in the unit disk.
Vec2 hemisphere_to_parabolic(const Vec3& w);

// Parabolic coordinates to a unit direction. Points outside the unit disk are clamped radially
// to the rim, which maps to the horizon (z = 0).
Vec3 parabolic_to_hemisphere(const Vec2& st);

// Jacobian of parabolic_to_hemisphere: solid angle per unit (s, t) area, 4 / (1 + r^2)^2.
double parabolic_to_hemisphere_jacobian(const Vec2& st);

}  // namespace basis
