#include "basis/lighting/environment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string>

#include "basis/core/file_error.h"
#include "basis/core/latlong.h"

namespace basis {

Environment::Environment(const Image& latlong, double rotate_z_degrees, std::string name)
    : name_(std::move(name)),
      width_(latlong.width),
      height_(latlong.height),
      rotation_(rotate_z_degrees * std::numbers::pi / 180) {
  if (width_ < 2 || height_ < 1)
    throw FileError(name_ + ": a lat-long environment map needs at least 2 x 1 pixels, got " +
                    std::to_string(width_) + " x " + std::to_string(height_));
  if (!std::isfinite(rotation_)) throw std::invalid_argument("environment rotation is not finite");
  cos_rotation_ = std::cos(rotation_);
  sin_rotation_ = std::sin(rotation_);
  pixels_.resize(std::size_t(width_) * height_ * 3);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x)
      for (int c = 0; c < 3; ++c) {
        float v = latlong.at(x, y, latlong.channels >= 3 ? c : 0);
        if (std::isnan(v)) {
          ++repairs_.nan;
          v = 0;
        } else if (std::isinf(v)) {
          ++repairs_.infinite;
          v = 0;
        } else if (v < 0) {
          ++repairs_.negative;
          v = 0;
        }
        pixels_[(std::size_t(y) * width_ + x) * 3 + c] = v;
      }
  row_solid_angle_.resize(height_);
  for (int y = 0; y < height_; ++y)
    row_solid_angle_[y] = latlong_pixel_solid_angle(y, width_, height_);

  // Bright level: 8 x the mean luminance, raised so that at most 0.5 % of pixels exceed it.
  double mean = 0;
  std::vector<double> lum(std::size_t(width_) * height_);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      lum[std::size_t(y) * width_ + x] = luminance(pixel(y, x));
      mean += lum[std::size_t(y) * width_ + x] * row_solid_angle_[y];
    }
  mean /= 4 * std::numbers::pi;
  double level = 8 * mean;
  std::vector<double> sorted = lum;
  const std::size_t keep = std::max<std::size_t>(1, sorted.size() / 200);
  std::nth_element(sorted.begin(), sorted.end() - keep, sorted.end());
  level = std::max(level, *(sorted.end() - keep));
  smooth_ = pixels_;
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const double l = lum[std::size_t(y) * width_ + x];
      if (!(l > level) || level <= 0) continue;
      float* s = &smooth_[(std::size_t(y) * width_ + x) * 3];
      const float* p = &pixels_[(std::size_t(y) * width_ + x) * 3];
      BrightPixel b{y, x, {}, -1, direction(x + 0.5, y + 0.5), row_solid_angle_[y]};
      for (int c = 0; c < 3; ++c) {
        s[c] = float(p[c] * level / l);
        b.excess[c] = double(p[c]) - s[c];
      }
      bright_.push_back(b);
    }
  build_pyramid();
  find_compact_lights(level, lum);
}

void Environment::find_compact_lights(double level, std::span<const double> pixel_luminance) {
  // Candidates: bright pixels far above the smooth level, in row-major order (as bright_ is).
  std::vector<std::size_t> candidates;  // indices into bright_
  std::vector<std::size_t> keys;        // their pixel indices, ascending
  for (std::size_t i = 0; i < bright_.size(); ++i) {
    const std::size_t key = std::size_t(bright_[i].row) * width_ + bright_[i].column;
    if (pixel_luminance[key] >= kLightContrast * level) {
      candidates.push_back(i);
      keys.push_back(key);
    }
  }
  // Connected groups (8-neighbours, columns wrap around) by union-find.
  std::vector<std::size_t> parent(candidates.size());
  for (std::size_t i = 0; i < parent.size(); ++i)
    parent[i] = i;
  auto root = [&](std::size_t i) {
    while (parent[i] != i)
      i = parent[i] = parent[parent[i]];
    return i;
  };
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const BrightPixel& b = bright_[candidates[i]];
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int row = b.row + dy, column = (b.column + dx + width_) % width_;
        if (row < 0 || row >= height_) continue;
        const std::size_t key = std::size_t(row) * width_ + column;
        const auto it = std::lower_bound(keys.begin(), keys.end(), key);
        if (it != keys.end() && *it == key) parent[root(i)] = root(std::size_t(it - keys.begin()));
      }
  }
  // Each group's energy and centre; groups within the radius limit become lights.
  std::vector<std::vector<std::size_t>> groups(candidates.size());
  for (std::size_t i = 0; i < candidates.size(); ++i)
    groups[root(i)].push_back(candidates[i]);
  const double max_radius = kMaxLightRadiusDegrees * std::numbers::pi / 180;
  for (const std::vector<std::size_t>& group : groups) {
    if (group.empty()) continue;
    CompactLight light{Vec3::Zero(), 0, {0, 0, 0}};
    for (const std::size_t i : group) {
      const BrightPixel& b = bright_[i];
      const double omega = row_solid_angle_[b.row];
      for (int c = 0; c < 3; ++c)
        light.energy[c] += b.excess[c] * omega;
      light.direction += luminance(b.excess) * omega * direction(b.column + 0.5, b.row + 0.5);
    }
    if (!(light.direction.norm() > 0)) continue;
    light.direction.normalize();
    light.radius = std::sqrt(0.5) * std::numbers::pi / height_;  // half a pixel's diagonal
    for (const std::size_t i : group) {
      const Vec3 d = direction(bright_[i].column + 0.5, bright_[i].row + 0.5);
      light.radius = std::max(light.radius, std::sqrt(0.5) * std::numbers::pi / height_ +
                                                angle_between(light.direction, d));
    }
    if (light.radius > max_radius) continue;
    for (const std::size_t i : group)
      bright_[i].light = int(lights_.size());
    lights_.push_back(light);
  }
  // The most luminous first, and the pixels' light indices after them.
  std::vector<int> order(lights_.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return luminance(lights_[std::size_t(a)].energy) > luminance(lights_[std::size_t(b)].energy);
  });
  std::vector<int> rank(lights_.size());
  std::vector<CompactLight> sorted;
  sorted.reserve(lights_.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    rank[std::size_t(order[k])] = int(k);
    sorted.push_back(lights_[std::size_t(order[k])]);
  }
  lights_ = std::move(sorted);
  for (BrightPixel& b : bright_)
    if (b.light >= 0) b.light = rank[std::size_t(b.light)];
}

const Environment::CompactLight* Environment::brightest_light() const {
  const auto brightest = std::max_element(lights_.begin(), lights_.end(), [](auto& a, auto& b) {
    return luminance(a.energy) < luminance(b.energy);
  });
  return brightest == lights_.end() ? nullptr : &*brightest;
}

Environment Environment::constant(const Color& radiance) {
  for (const double c : radiance)
    if (!(c >= 0 && c <= std::numeric_limits<float>::max()))
      throw std::invalid_argument(
          "a constant radiance is finite, at least 0 and at most the largest float (3.4e38)");
  Environment e;
  char name[96];
  std::snprintf(name, sizeof name, "constant radiance %g,%g,%g", radiance[0], radiance[1],
                radiance[2]);
  e.name_ = name;
  e.constant_ = true;
  e.width_ = e.height_ = 1;
  e.pixels_ = {float(radiance[0]), float(radiance[1]), float(radiance[2])};
  e.smooth_ = e.pixels_;
  return e;
}

Vec3 Environment::direction(double x, double y) const {
  const Vec3 d = latlong_to_direction({x, y}, width_, height_);
  const double c = cos_rotation_, s = sin_rotation_;
  return {c * d.x() - s * d.y(), s * d.x() + c * d.y(), d.z()};
}

double Environment::band_solid_angle(double y0, double y1, double dx) const {
  return 2 * std::numbers::pi * dx / width_ *
         (std::cos(std::numbers::pi * y0 / height_) - std::cos(std::numbers::pi * y1 / height_));
}

Color Environment::pixel(int row, int column) const {
  const float* p = &pixels_[(std::size_t(row) * width_ + column) * 3];
  return {p[0], p[1], p[2]};
}

std::array<int, 2> Environment::pixel_at(const Vec3& w) const {
  if (constant_) return {0, 0};
  const double c = cos_rotation_, s = sin_rotation_;
  const Vec3 map(c * w.x() + s * w.y(), -s * w.x() + c * w.y(), w.z());
  const Vec2 p = direction_to_latlong(map, width_, height_);
  return {std::clamp(int(p.y()), 0, height_ - 1), std::clamp(int(p.x()), 0, width_ - 1)};
}

Color Environment::radiance(const Vec3& w) const {
  const auto [row, column] = pixel_at(w);
  return pixel(row, column);
}

Color Environment::smooth_radiance(const Vec3& w) const {
  if (constant_) return pixel(0, 0);
  const double c = cos_rotation_, s = sin_rotation_;
  const Vec3 map(c * w.x() + s * w.y(), -s * w.x() + c * w.y(), w.z());
  const Vec2 p = direction_to_latlong(map, width_, height_);
  const float* q = &smooth_[(std::size_t(std::clamp(int(p.y()), 0, height_ - 1)) * width_ +
                             std::clamp(int(p.x()), 0, width_ - 1)) *
                            3];
  return {q[0], q[1], q[2]};
}

void Environment::build_pyramid() {
  pyramid_.clear();
  const std::vector<float>* fine = &smooth_;
  int w = width_, h = height_;
  while (w >= 8 && h >= 4) {
    Level next{w / 2, h / 2, std::vector<float>(std::size_t(w / 2) * (h / 2) * 3, 0.f)};
    for (int y = 0; y < next.height; ++y) {
      // Rows weighted by their solid angle (sin theta at their centres).
      const double w0 = std::sin(std::numbers::pi * (2 * y + 0.5) / h);
      const double w1 = std::sin(std::numbers::pi * (2 * y + 1.5) / h);
      const double total = std::max(1e-12, 2 * (w0 + w1));
      for (int x = 0; x < next.width; ++x)
        for (int c = 0; c < 3; ++c) {
          auto at = [&](int xx, int yy) {
            return double((*fine)[(std::size_t(yy) * w + xx) * 3 + c]);
          };
          const double sum = w0 * (at(2 * x, 2 * y) + at(2 * x + 1, 2 * y)) +
                             w1 * (at(2 * x, 2 * y + 1) + at(2 * x + 1, 2 * y + 1));
          next.pixels[(std::size_t(y) * next.width + x) * 3 + c] = float(sum / total);
        }
    }
    pyramid_.push_back(std::move(next));
    fine = &pyramid_.back().pixels;
    w = pyramid_.back().width;
    h = pyramid_.back().height;
  }
}

Color Environment::smooth_radiance(const Vec3& w, double pixels) const {
  if (constant_ || !(pixels > 1) || pyramid_.empty()) return smooth_radiance(w);
  const int level = std::min(int(pyramid_.size()), int(std::ceil(std::log2(pixels))));
  const Level& l = pyramid_[std::size_t(level - 1)];
  const double c = cos_rotation_, s = sin_rotation_;
  const Vec3 map(c * w.x() + s * w.y(), -s * w.x() + c * w.y(), w.z());
  const Vec2 p = direction_to_latlong(map, width_, height_);
  // Bilinear between the level's pixel centres, wrapping around in x.
  const double x = p.x() * l.width / width_ - 0.5;
  const double y = std::clamp(p.y() * l.height / height_ - 0.5, 0.0, l.height - 1.0);
  const int x0 = int(std::floor(x)), y0 = std::clamp(int(y), 0, std::max(0, l.height - 2));
  const double fx = x - x0, fy = std::clamp(y - y0, 0.0, 1.0);
  const int xa = (x0 % l.width + l.width) % l.width, xb = (xa + 1) % l.width;
  const int yb = std::min(y0 + 1, l.height - 1);
  Color out{0, 0, 0};
  for (int ch = 0; ch < 3; ++ch) {
    auto at = [&](int xx, int yy) {
      return double(l.pixels[(std::size_t(yy) * l.width + xx) * 3 + ch]);
    };
    out[ch] = (1 - fy) * ((1 - fx) * at(xa, y0) + fx * at(xb, y0)) +
              fy * ((1 - fx) * at(xa, yb) + fx * at(xb, yb));
  }
  return out;
}

double Environment::pixel_angle() const {
  return constant_ ? 0.0 : std::numbers::pi / height_;
}

Color Environment::irradiance(const Vec3& n, int subsamples) const {
  if (constant_) {
    const Color l = pixel(0, 0);
    return {l[0] * std::numbers::pi, l[1] * std::numbers::pi, l[2] * std::numbers::pi};
  }
  Color sum{0, 0, 0};
  for (int y = 0; y < height_; ++y)
    for_each_subpixel(y, 0, width_, subsamples, [&](int x, const Vec3& w, double solid_angle) {
      const double cosine = w.dot(n);
      if (cosine <= 0) return;
      const Color l = pixel(y, x);
      for (int c = 0; c < 3; ++c)
        sum[c] += l[c] * cosine * solid_angle;
    });
  return sum;
}

std::string repaired_texels_warning(const Environment& environment, bool zero_invalid,
                                    const std::string& remedy) {
  const EnvironmentRepairs& bad = environment.repairs();
  if (bad.nan + bad.infinite > 0 && !zero_invalid)
    throw FileError(environment.name() + ": " + std::to_string(bad.nan) + " NaN and " +
                    std::to_string(bad.infinite) + " infinite texel values (" + remedy + ")");
  if (bad.total() == 0) return {};
  return environment.name() + ": " + std::to_string(bad.nan) + " NaN, " +
         std::to_string(bad.infinite) + " infinite and " + std::to_string(bad.negative) +
         " negative texel values set to 0";
}

}  // namespace basis
