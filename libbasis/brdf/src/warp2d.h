// Warp2D (private to the RGL reader): a bilinear function on [0,1]^2 over an nx x ny grid (x the
// contiguous axis), blended linearly across up to three parameter grids; optionally a
// normalised density with trapezoid-rule CDFs that samples rows (marginal) then columns
// (conditional), and inverts that. The warps of the RGL tensor files (Dupuy & Jakob 2018).
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "basis/core/vector.h"

namespace basis::rgl {

// Parameter grids a warp blends across, at most.
constexpr std::size_t kMaxParams = 3;

class Warp2D {
 public:
  struct Point {
    Vec2 pos;
    double pdf;
  };

  Warp2D() = default;
  // values: [P0]..[P(D-1)][ny][nx] row-major; grids: the D increasing parameter grids;
  // density: normalise and build CDFs (for sampling) rather than keep the raw interpolant.
  Warp2D(const std::vector<double>& values, std::size_t nx, std::size_t ny,
         std::vector<std::vector<double>> grids, bool density);

  // The interpolated value at pos (a density in the unit square when built as one).
  double eval(const Vec2& pos, std::span<const double> params) const;

  // Warps a uniform point u of the unit square to this density; returns the point and its
  // density in the unit square. Only for tables built as densities.
  Point sample(const Vec2& u_in, std::span<const double> params) const;

  // The exact inverse of sample: the uniform point that lands on pos, and the density at pos.
  Point invert(const Vec2& pos, std::span<const double> params) const;

 private:
  // The parameter slices around a parameter point and their multilinear weights.
  struct Blend {
    std::array<std::size_t, std::size_t(1) << kMaxParams> slice{};
    std::array<double, std::size_t(1) << kMaxParams> weight{};
    std::size_t count = 0;
  };
  // The grid cell holding a point of the unit square (clamped into it).
  struct Cell {
    std::size_t ix, iy;
    double fx, fy;
  };

  double cells() const { return double(nx_ - 1) * double(ny_ - 1); }

  Blend blend(std::span<const double> params) const;
  // Entry e of a per-slice array (slice_length entries per slice), blended across slices.
  static double lookup(const std::vector<double>& a, std::size_t slice_length, std::size_t e,
                       const Blend& b) {
    double v = 0;
    for (std::size_t c = 0; c < b.count; ++c)
      v += b.weight[c] * a[b.slice[c] * slice_length + e];
    return v;
  }
  double data(std::size_t y, std::size_t x, const Blend& b) const {
    return lookup(data_, nx_ * ny_, y * nx_ + x, b);
  }
  double conditional(std::size_t y, std::size_t x, const Blend& b) const {
    return lookup(conditional_, nx_ * ny_, y * nx_ + x, b);
  }
  double marginal(std::size_t y, const Blend& b) const { return lookup(marginal_, ny_, y, b); }

  Cell locate(const Vec2& pos) const;

  std::size_t nx_ = 2, ny_ = 2;
  std::vector<std::vector<double>> grids_;
  std::vector<std::size_t> strides_;
  std::vector<double> data_, conditional_, marginal_;
  bool density_ = false;
};

}  // namespace basis::rgl
