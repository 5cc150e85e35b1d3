// Square <-> hemisphere maps built on the concentric disk: cosine-weighted (Malley's method)
// and uniform equal-area (Lambert azimuthal). Directions are in the local frame, z = normal.
#pragma once

#include <array>

#include "basis/core/vector.h"

namespace basis {

// Cosine-weighted: (u,v) in [0,1]^2 -> disk -> z = sqrt(1 - r^2). Density cos(theta)/pi per
// steradian, so the integral over the hemisphere of A*B*cos(theta) equals pi times the
// integral of A*B over the unit square.
Vec3 square_to_cosine_hemisphere(const Vec2& uv);
// Inverse of square_to_cosine_hemisphere for a direction with z >= 0 (z < 0 is clamped to 0).
Vec2 cosine_hemisphere_to_square(const Vec3& w);
// Density of square_to_cosine_hemisphere with respect to solid angle: cos(theta) / pi.
double square_to_cosine_hemisphere_pdf(const Vec3& w);
// Texel (x, y) of an n x n grid over the cosine-weighted map that holds direction w (z >= 0).
std::array<int, 2> cosine_hemisphere_texel(const Vec3& w, int n);

// Uniform: (u,v) in [0,1]^2 -> disk -> z = 1 - r^2. Density 1/(2 pi) per steradian, so the
// integral over the hemisphere of A equals 2 pi times the integral of A over the unit square.
Vec3 square_to_uniform_hemisphere(const Vec2& uv);
// Inverse of square_to_uniform_hemisphere for a direction with z >= 0.
Vec2 uniform_hemisphere_to_square(const Vec3& w);
// Density of square_to_uniform_hemisphere with respect to solid angle: 1 / (2 pi).
double square_to_uniform_hemisphere_pdf();

// The unit half vector (wi + wo) / |wi + wo| of unit directions that are not opposite. Scaled
// before normalising: near the horizon, with wi and wo almost opposite, |wi + wo|^2 underflows.
Vec3 half_vector(const Vec3& wi, const Vec3& wo);

}  // namespace basis
