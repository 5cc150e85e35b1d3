// Real spherical harmonics, the basis of radiance caching: evaluation, projection of hemisphere
// texel grids, convolution as a dot product, and exact rotation. A baseline for qtbench.
#pragma once

#include <array>
#include <span>
#include <vector>

#include "basis/core/color.h"
#include "basis/core/grid.h"
#include "basis/core/vector.h"

namespace basis {

// Orders up to this are supported.
inline constexpr int kMaxShOrder = 32;

// Number of coefficients of order L (bands 0 .. L-1): L^2.
inline int sh_count(int order) {
  return order * order;
}
// Index of Y_l^m in coefficient arrays: l (l + 1) + m.
inline int sh_index(int l, int m) {
  return l * (l + 1) + m;
}

// Values of every real spherical harmonic of order L (orthonormal over the sphere) at unit w.
void sh_evaluate(int order, const Vec3& w, std::span<double> out);

// Coefficients (per channel, channel-major: c * L^2 + i) of a function given as texel averages
// over the cosine-weighted concentric map of the upper hemisphere and zero below, by quadrature
// over the texels: f_i = sum_t f_t Y_i(w_t) dw_t, with dw_t = pi / (N^2 cos(theta_t)).
// With `times_cosine` the function is multiplied by cos(theta) first (a BRDF slice becomes a
// transfer function), so that the dot product of a transfer and a radiance gives the integral
// of f L cos over the hemisphere.
std::vector<double> sh_project(const Grid& grid, int order, bool times_cosine);

// Dot product of two coefficient vectors of `channels` channels (a grey side broadcasts);
// std::invalid_argument when a vector is shorter than its channels times order^2.
Color sh_dot(std::span<const double> a, int channels_a, std::span<const double> b, int channels_b,
             int order);

// Rotation matrix of order L: coefficients of g(w) = f(R^-1 w) are M * (coefficients of f).
// Block-diagonal by band; computed exactly by Gauss-Legendre x uniform quadrature (the
// integrands are polynomials of bounded degree). Row-major L^2 x L^2.
std::vector<double> sh_rotation(int order, const Eigen::Matrix3d& rotation);

// Applies a rotation matrix to per-channel coefficients.
std::vector<double> sh_rotate(std::span<const double> coefficients, int channels, int order,
                              std::span<const double> rotation);

}  // namespace basis
