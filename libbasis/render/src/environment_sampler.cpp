#include "basis/render/environment_sampler.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "basis/core/latlong.h"

namespace basis {

namespace {

// The index i with cdf[i] <= u < cdf[i + 1], skipping empty intervals.
std::size_t find_interval(const double* cdf, std::size_t count, double u) {
  const double* at = std::upper_bound(cdf, cdf + count + 1, u);
  return std::min<std::size_t>(count - 1, std::size_t(std::max<std::ptrdiff_t>(0, at - cdf - 1)));
}

}  // namespace

EnvironmentSampler::EnvironmentSampler(const Environment& environment)
    : environment_(&environment) {
  if (environment.is_constant()) return;
  const int w = environment.width(), h = environment.height();
  std::vector<double> weight(std::size_t(w) * h);
  double mean = 0;
  for (int y = 0; y < h; ++y) {
    const double solid_angle = latlong_pixel_solid_angle(y, w, h);
    for (int x = 0; x < w; ++x) {
      const Color l = environment.pixel_radiance(y, x);
      weight[std::size_t(y) * w + x] = std::max(luminance(l), (l[0] + l[1] + l[2]) / 3);
      mean += weight[std::size_t(y) * w + x] * solid_angle;
    }
  }
  mean /= 4 * std::numbers::pi;
  const double floor = mean > 0 ? 1e-4 * mean : 1;
  row_cdf_.assign(std::size_t(h) + 1, 0);
  column_cdf_.assign(std::size_t(h) * (w + 1), 0);
  pixel_probability_.assign(std::size_t(w) * h, 0);
  for (int y = 0; y < h; ++y) {
    const double solid_angle = latlong_pixel_solid_angle(y, w, h);
    double* columns = &column_cdf_[std::size_t(y) * (w + 1)];
    for (int x = 0; x < w; ++x)
      columns[x + 1] = columns[x] + std::max(weight[std::size_t(y) * w + x], floor) * solid_angle;
    row_cdf_[y + 1] = row_cdf_[y] + columns[w];
  }
  const double total = row_cdf_[h];
  for (int y = 0; y < h; ++y) {
    double* columns = &column_cdf_[std::size_t(y) * (w + 1)];
    const double row_total = columns[w];
    for (int x = 0; x < w; ++x)
      pixel_probability_[std::size_t(y) * w + x] = (columns[x + 1] - columns[x]) / total;
    for (int x = 0; x <= w; ++x)
      columns[x] /= row_total;
    row_cdf_[y] /= total;
  }
  row_cdf_[h] = 1;
}

EnvironmentSampler::Sample EnvironmentSampler::sample(double u_row, double u_column, double u_theta,
                                                      double u_phi) const {
  if (environment_->is_constant()) {  // uniform over the sphere
    const double z = 1 - 2 * u_theta, r = std::sqrt(std::max(0.0, 1 - z * z));
    const double phi = 2 * std::numbers::pi * u_phi;
    return {{r * std::cos(phi), r * std::sin(phi), z}, 1 / (4 * std::numbers::pi)};
  }
  const int w = environment_->width(), h = environment_->height();
  const std::size_t y = find_interval(row_cdf_.data(), std::size_t(h), u_row);
  const std::size_t x =
      find_interval(&column_cdf_[y * std::size_t(w + 1)], std::size_t(w), u_column);
  // Uniform in solid angle within the pixel: cos(theta) uniform over the row's band.
  const double c0 = std::cos(std::numbers::pi * double(y) / h);
  const double c1 = std::cos(std::numbers::pi * double(y + 1) / h);
  const double theta = std::acos(std::clamp(c0 + (c1 - c0) * u_theta, -1.0, 1.0));
  const double row =
      std::clamp(theta * h / std::numbers::pi, double(y), std::nextafter(y + 1.0, 0));
  const Vec3 direction = environment_->direction(double(x) + u_phi, row);
  return {direction, pdf(direction)};
}

double EnvironmentSampler::pdf(const Vec3& w) const {
  if (environment_->is_constant()) return 1 / (4 * std::numbers::pi);
  const auto [row, column] = environment_->pixel_at(w);
  const int width = environment_->width();
  return pixel_probability_[std::size_t(row) * width + column] /
         latlong_pixel_solid_angle(row, width, environment_->height());
}

}  // namespace basis
