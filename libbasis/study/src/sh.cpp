#include "basis/study/sh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "basis/core/gauss_legendre.h"
#include "basis/core/hemisphere.h"

namespace basis {

void sh_evaluate(int order, const Vec3& w, std::span<double> out) {
  if (order < 1 || order > kMaxShOrder || int(out.size()) < sh_count(order))
    throw std::invalid_argument("spherical harmonics: bad order or output size");
  const double z = std::clamp(w.z(), -1.0, 1.0);
  const double phi = std::atan2(w.y(), w.x());
  const double s = std::sqrt(std::max(0.0, 1 - z * z));
  // Associated Legendre P_l^m(z) (Condon-Shortley phase omitted) by the standard recurrences.
  std::array<double, kMaxShOrder * kMaxShOrder> p;  // P_l^m at l * order + m
  auto P = [&](int l, int m) -> double& { return p[std::size_t(l) * order + m]; };
  P(0, 0) = 1;
  for (int m = 1; m < order; ++m)
    P(m, m) = P(m - 1, m - 1) * (2 * m - 1) * s;
  for (int m = 0; m + 1 < order; ++m)
    P(m + 1, m) = (2 * m + 1) * z * P(m, m);
  for (int m = 0; m < order; ++m)
    for (int l = m + 2; l < order; ++l)
      P(l, m) = ((2 * l - 1) * z * P(l - 1, m) - (l + m - 1) * P(l - 2, m)) / (l - m);
  // cos(m phi), sin(m phi) by the angle-addition recurrence.
  std::array<double, kMaxShOrder> cosines, sines;
  cosines[0] = 1;
  sines[0] = 0;
  const double c1 = std::cos(phi), s1 = std::sin(phi);
  for (int m = 1; m < order; ++m) {
    cosines[m] = cosines[m - 1] * c1 - sines[m - 1] * s1;
    sines[m] = sines[m - 1] * c1 + cosines[m - 1] * s1;
  }
  for (int l = 0; l < order; ++l) {
    // K_l^m = sqrt((2l + 1) / (4 pi) (l - m)! / (l + m)!), from m = 0 upwards.
    double k = std::sqrt((2 * l + 1) / (4 * std::numbers::pi));
    out[sh_index(l, 0)] = k * P(l, 0);
    for (int m = 1; m <= l; ++m) {
      k /= std::sqrt(double(l + m) * (l - m + 1));
      out[sh_index(l, m)] = std::sqrt(2.0) * k * cosines[m] * P(l, m);
      out[sh_index(l, -m)] = std::sqrt(2.0) * k * sines[m] * P(l, m);
    }
  }
}

std::vector<double> sh_project(const Grid& grid, int order, bool times_cosine) {
  const int n = grid.resolution, count = sh_count(order);
  std::vector<double> coefficients(std::size_t(grid.channels) * count, 0.0);
  std::vector<double> y(count);
  const double texel_area = 1.0 / (double(n) * n);
  for (int ty = 0; ty < n; ++ty)
    for (int tx = 0; tx < n; ++tx) {
      const Vec3 w = square_to_cosine_hemisphere({(tx + 0.5) / n, (ty + 0.5) / n});
      // d(omega) = pi du dv / cos(theta); the cosine cancels for transfer functions.
      const double weight = times_cosine ? std::numbers::pi * texel_area
                                         : std::numbers::pi * texel_area / std::max(w.z(), 1e-6);
      sh_evaluate(order, w, y);
      for (int c = 0; c < grid.channels; ++c) {
        const double f = grid.at(0, c, tx, ty) * weight;
        for (int i = 0; i < count; ++i)
          coefficients[std::size_t(c) * count + i] += f * y[i];
      }
    }
  return coefficients;
}

Color sh_dot(std::span<const double> a, int channels_a, std::span<const double> b, int channels_b,
             int order) {
  const int count = sh_count(order);
  if (a.size() < std::size_t(channels_a) * count || b.size() < std::size_t(channels_b) * count)
    throw std::invalid_argument("spherical harmonics of order " + std::to_string(order) +
                                " need channels x " + std::to_string(count) + " coefficients");
  Color out{};
  for (int c = 0; c < 3; ++c) {
    const double* pa = a.data() + std::size_t(channels_a == 1 ? 0 : c) * count;
    const double* pb = b.data() + std::size_t(channels_b == 1 ? 0 : c) * count;
    double sum = 0;
    for (int i = 0; i < count; ++i)
      sum += pa[i] * pb[i];
    out[c] = sum;
  }
  return out;
}

std::vector<double> sh_rotation(int order, const Eigen::Matrix3d& rotation) {
  const int count = sh_count(order);
  std::vector<double> m(std::size_t(count) * count, 0.0);
  // Gauss-Legendre nodes in z (exact for polynomials of degree 2 order - 1 in z) and a uniform
  // rule in phi (exact for trigonometric polynomials of degree below 2 order + 1).
  const int nz = order + 1, nphi = 2 * order + 2;
  const std::vector<QuadratureNode> rule = gauss_legendre(nz);
  std::vector<double> y(count), yr(count);
  const Eigen::Matrix3d inverse = rotation.transpose();
  for (int i = 0; i < nz; ++i)
    for (int j = 0; j < nphi; ++j) {
      const double z = rule[i].x, s = std::sqrt(std::max(0.0, 1 - z * z));
      const double phi = 2 * std::numbers::pi * (j + 0.5) / nphi;
      const Vec3 w(s * std::cos(phi), s * std::sin(phi), z);
      const double weight = rule[i].weight * 2 * std::numbers::pi / nphi;
      sh_evaluate(order, w, y);
      sh_evaluate(order, inverse * w, yr);
      for (int l = 0; l < order; ++l)  // band blocks only
        for (int a = l * l; a < (l + 1) * (l + 1); ++a)
          for (int b = l * l; b < (l + 1) * (l + 1); ++b)
            m[std::size_t(a) * count + b] += weight * y[a] * yr[b];
    }
  return m;
}

std::vector<double> sh_rotate(std::span<const double> coefficients, int channels, int order,
                              std::span<const double> rotation) {
  const int count = sh_count(order);
  std::vector<double> out(coefficients.size(), 0.0);
  for (int c = 0; c < channels; ++c)
    for (int l = 0; l < order; ++l)
      for (int a = l * l; a < (l + 1) * (l + 1); ++a) {
        double sum = 0;
        for (int b = l * l; b < (l + 1) * (l + 1); ++b)
          sum += rotation[std::size_t(a) * count + b] * coefficients[std::size_t(c) * count + b];
        out[std::size_t(c) * count + a] = sum;
      }
  return out;
}

}  // namespace basis
