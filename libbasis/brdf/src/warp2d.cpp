#include "warp2d.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace basis::rgl {

namespace {

constexpr double kOneMinusEpsilon = 0.999999940395355225;  // the float just below 1

// x clamped to [lo, hi]; NaN goes to lo.
double clamp_nan_low(double x, double lo, double hi) {
  return x > lo ? (x < hi ? x : hi) : lo;
}

// Largest i in [0, n - 2] such that i == 0 or pred(i), for pred true on a prefix of 0 .. n-1.
template <typename Pred>
std::size_t find_interval(std::size_t n, const Pred& pred) {
  std::size_t first = 1, count = n - 2;
  while (count > 0) {
    const std::size_t half = count / 2, middle = first + half;
    if (pred(middle)) {
      first = middle + 1;
      count -= half + 1;
    } else {
      count = half;
    }
  }
  return std::min(first - 1, n - 2);
}

// t in [0, 1] with integral_0^t ((1 - s) a + s b) ds = u, for a linear density from a to b.
double invert_linear_segment(double a, double b, double u) {
  if (!(a + b > 0)) return 0;
  double t;
  if (std::abs(a - b) < 1e-4 * (a + b))
    t = 2 * u / (a + b);
  else
    t = (a - std::sqrt(std::max(0.0, a * a - 2 * u * (a - b)))) / (a - b);
  return clamp_nan_low(t, 0, 1);
}

}  // namespace

Warp2D::Warp2D(const std::vector<double>& values, std::size_t nx, std::size_t ny,
               std::vector<std::vector<double>> grids, bool density)
    : nx_(nx), ny_(ny), grids_(std::move(grids)), density_(density) {
  if (nx_ < 2 || ny_ < 2 || grids_.size() > kMaxParams)
    throw std::invalid_argument("needs at least 2 x 2 entries per slice");
  std::size_t slices = 1;
  strides_.assign(grids_.size(), 0);
  for (std::size_t k = grids_.size(); k-- > 0;) {
    if (grids_[k].empty()) throw std::invalid_argument("empty parameter grid");
    strides_[k] = grids_[k].size() > 1 ? slices : 0;
    slices *= grids_[k].size();
  }
  const std::size_t n = nx_ * ny_;
  if (values.size() != slices * n) throw std::invalid_argument("shape does not match the grids");
  data_ = values;
  if (!density_) return;

  conditional_.assign(slices * n, 0.0);
  marginal_.assign(slices * ny_, 0.0);
  for (std::size_t slice = 0; slice < slices; ++slice) {
    double* d = &data_[slice * n];
    double* c = &conditional_[slice * n];
    double* m = &marginal_[slice * ny_];
    for (std::size_t y = 0; y < ny_; ++y) {
      double sum = 0;
      for (std::size_t x = 0; x + 1 < nx_; ++x) {
        sum += 0.5 * (d[y * nx_ + x] + d[y * nx_ + x + 1]);
        c[y * nx_ + x + 1] = sum;
      }
    }
    double sum = 0;
    for (std::size_t y = 0; y + 1 < ny_; ++y) {
      sum += 0.5 * (c[y * nx_ + nx_ - 1] + c[(y + 1) * nx_ + nx_ - 1]);
      m[y + 1] = sum;
    }
    const double scale = 1 / sum;
    if (!(sum > 0) || !std::isfinite(scale))
      throw std::invalid_argument("slice " + std::to_string(slice) + " has no positive mass");
    for (std::size_t k = 0; k < n; ++k) {
      d[k] *= scale;
      c[k] *= scale;
    }
    for (std::size_t y = 0; y < ny_; ++y)
      m[y] *= scale;
  }
}

double Warp2D::eval(const Vec2& pos, std::span<const double> params) const {
  const Blend b = blend(params);
  const Cell c = locate(pos);
  const double v00 = data(c.iy, c.ix, b), v10 = data(c.iy, c.ix + 1, b);
  const double v01 = data(c.iy + 1, c.ix, b), v11 = data(c.iy + 1, c.ix + 1, b);
  const double v =
      (1 - c.fy) * ((1 - c.fx) * v00 + c.fx * v10) + c.fy * ((1 - c.fx) * v01 + c.fx * v11);
  return density_ ? v * cells() : v;
}

Warp2D::Point Warp2D::sample(const Vec2& u_in, std::span<const double> params) const {
  const Blend b = blend(params);
  double ux = clamp_nan_low(u_in.x(), 1 - kOneMinusEpsilon, kOneMinusEpsilon);
  double uy = clamp_nan_low(u_in.y(), 1 - kOneMinusEpsilon, kOneMinusEpsilon);

  const std::size_t row = find_interval(ny_, [&](std::size_t j) { return marginal(j, b) < uy; });
  uy -= marginal(row, b);
  const double r0 = conditional(row, nx_ - 1, b), r1 = conditional(row + 1, nx_ - 1, b);
  const double fy = invert_linear_segment(r0, r1, uy);

  ux *= (1 - fy) * r0 + fy * r1;
  auto row_cdf = [&](std::size_t x) {
    return (1 - fy) * conditional(row, x, b) + fy * conditional(row + 1, x, b);
  };
  const std::size_t col = find_interval(nx_, [&](std::size_t i) { return row_cdf(i) < ux; });
  ux -= row_cdf(col);
  const double c0 = (1 - fy) * data(row, col, b) + fy * data(row + 1, col, b);
  const double c1 = (1 - fy) * data(row, col + 1, b) + fy * data(row + 1, col + 1, b);
  const double fx = invert_linear_segment(c0, c1, ux);

  return {Vec2((double(col) + fx) / double(nx_ - 1), (double(row) + fy) / double(ny_ - 1)),
          ((1 - fx) * c0 + fx * c1) * cells()};
}

Warp2D::Point Warp2D::invert(const Vec2& pos, std::span<const double> params) const {
  const Blend b = blend(params);
  const Cell c = locate(pos);
  const double c0 = (1 - c.fy) * data(c.iy, c.ix, b) + c.fy * data(c.iy + 1, c.ix, b);
  const double c1 = (1 - c.fy) * data(c.iy, c.ix + 1, b) + c.fy * data(c.iy + 1, c.ix + 1, b);
  const double pdf = ((1 - c.fx) * c0 + c.fx * c1) * cells();

  double ux = c.fx * (c0 + 0.5 * c.fx * (c1 - c0));
  ux += (1 - c.fy) * conditional(c.iy, c.ix, b) + c.fy * conditional(c.iy + 1, c.ix, b);
  const double r0 = conditional(c.iy, nx_ - 1, b), r1 = conditional(c.iy + 1, nx_ - 1, b);
  const double row_total = (1 - c.fy) * r0 + c.fy * r1;
  ux = row_total > 0 ? ux / row_total : 0;
  const double uy = c.fy * (r0 + 0.5 * c.fy * (r1 - r0)) + marginal(c.iy, b);
  return {Vec2(ux, uy), pdf};
}

Warp2D::Blend Warp2D::blend(std::span<const double> params) const {
  Blend b;
  b.slice[0] = 0;
  b.weight[0] = 1;
  b.count = 1;
  for (std::size_t k = 0; k < grids_.size(); ++k) {
    const std::vector<double>& g = grids_[k];
    if (g.size() == 1) continue;  // a single slice: weight 1, no search
    const double p = k < params.size() ? params[k] : g.front();
    const std::size_t i = find_interval(g.size(), [&](std::size_t j) { return g[j] <= p; });
    const double t = clamp_nan_low((p - g[i]) / (g[i + 1] - g[i]), 0, 1);
    Blend next;
    for (std::size_t c = 0; c < b.count; ++c) {
      if (1 - t > 0) {
        next.slice[next.count] = b.slice[c] + strides_[k] * i;
        next.weight[next.count++] = b.weight[c] * (1 - t);
      }
      if (t > 0) {
        next.slice[next.count] = b.slice[c] + strides_[k] * (i + 1);
        next.weight[next.count++] = b.weight[c] * t;
      }
    }
    b = next;
  }
  return b;
}

Warp2D::Cell Warp2D::locate(const Vec2& pos) const {
  const double px = clamp_nan_low(pos.x(), 0, 1) * double(nx_ - 1);
  const double py = clamp_nan_low(pos.y(), 0, 1) * double(ny_ - 1);
  const std::size_t ix = std::min(std::size_t(px), nx_ - 2);
  const std::size_t iy = std::min(std::size_t(py), ny_ - 2);
  return {ix, iy, px - double(ix), py - double(iy)};
}

}  // namespace basis::rgl
