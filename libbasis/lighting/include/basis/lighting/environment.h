// Distant lighting from a latitude-longitude radiance map (z up, the convention of latlong.h):
// point lookups, the bright pixels that captures integrate exactly instead of sampling them,
// and the compact lights (a sun) among them that captures can keep apart as directions.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "basis/core/color.h"
#include "basis/core/vector.h"
#include "basis/io/image.h"

namespace basis {

// Texels an environment map had to repair: NaN, +-Inf and negative values are set to 0 and
// never reach a capture.
struct EnvironmentRepairs {
  long long nan = 0;
  long long infinite = 0;
  long long negative = 0;
  long long total() const { return nan + infinite + negative; }
};

class Environment {
 public:
  // From a lat-long image (1 channel: grey; 3 or more: RGB, extra channels ignored), rotated by
  // `rotate_z_degrees` about z (a feature at azimuth phi moves to phi + rotation). Pixels whose
  // luminance exceeds 8 times the map's mean (at most 0.5 % of them) are bright: their excess
  // over that level is kept apart and splatted exactly by captures. `name` (the map's file)
  // stands for the environment in errors. A map narrower than 2 pixels is a FileError naming it.
  explicit Environment(const Image& latlong, double rotate_z_degrees = 0,
                       std::string name = "environment map");
  // A constant environment. Throws std::invalid_argument unless every channel is finite, at
  // least 0 and within the float range.
  static Environment constant(const Color& radiance);

  const std::string& name() const { return name_; }

  int width() const { return width_; }
  int height() const { return height_; }
  const EnvironmentRepairs& repairs() const { return repairs_; }

  // Radiance of the pixel seen in world direction w (bright part included).
  Color radiance(const Vec3& w) const;
  // The pixel {row, column} seen in world direction w ({0, 0} for a constant environment), and
  // its radiance (bright part included).
  std::array<int, 2> pixel_at(const Vec3& w) const;
  Color pixel_radiance(int row, int column) const { return pixel(row, column); }
  bool is_constant() const { return constant_; }
  // The map's RGB rows as read, repairs applied (a constant environment: its one pixel).
  std::span<const float> pixels() const { return pixels_; }
  // Radiance of the smooth part (bright excess removed) of the pixel seen in direction w.
  Color smooth_radiance(const Vec3& w) const;
  // The smooth part averaged over about `pixels` x `pixels` map pixels around w: bilinear in
  // the first level of a box-filtered pyramid (solid-angle weighted, each level halving the
  // last) whose pixels are at least that wide; the map's own pixel for 1 or less.
  Color smooth_radiance(const Vec3& w, double pixels) const;
  // Angular height of a pixel row (pi / height), 0 for a constant environment: the scale at
  // which captures sample the map.
  double pixel_angle() const;

  struct BrightPixel {
    int row, column;
    Color excess;                // radiance above the smooth part's level
    int light = -1;              // the compact light it belongs to, -1 for none
    Vec3 centre = Vec3::Zero();  // world direction of the pixel's centre (rotation applied)
    double solid_angle = 0;      // of the pixel
  };
  std::span<const BrightPixel> bright_pixels() const { return bright_; }

  // A compact light: a connected group of bright pixels at least kLightContrast times the
  // smooth level, all (to their extent) within kMaxLightRadiusDegrees of their energy-weighted
  // centre. Much
  // smaller than a capture's texels near the horizon, it is kept apart as a direction.
  static constexpr double kLightContrast = 4;
  static constexpr double kMaxLightRadiusDegrees = 3;
  struct CompactLight {
    Vec3 direction;  // world, unit: the centre of its excess energy
    double radius;   // radians: largest angle from the centre to a pixel's centre, plus half
                     // a pixel's diagonal at the equator
    Color energy;    // integral of the excess radiance over its pixels' solid angle
  };
  // The compact lights, the most luminous energy first (ties in the map's row-major order), so
  // that a consumer that takes the first few takes the brightest.
  std::span<const CompactLight> lights() const { return lights_; }
  // The compact light of the most luminous energy (the sun), null when there is none.
  const CompactLight* brightest_light() const;
  // World direction of map position (column x, row y) in pixels, rotation applied.
  Vec3 direction(double x, double y) const;
  // Solid angle of the map band between rows y0 and y1 (fractional) and columns spanning dx.
  double band_solid_angle(double y0, double y1, double dx) const;

  // Visits the s x s sub-pixels of the pixels [column_begin, column_end) of `row`, sub-rows
  // outermost: visit(column, w, solid_angle) with the sub-pixel's centre direction w (world,
  // rotation applied) and its exact solid angle.
  template <typename Visit>
  void for_each_subpixel(int row, int column_begin, int column_end, int s, Visit&& visit) const {
    for (int sy = 0; sy < s; ++sy) {
      const double y0 = row + double(sy) / s, y1 = row + double(sy + 1) / s;
      const double solid_angle = band_solid_angle(y0, y1, 1.0 / s);
      for (int x = column_begin; x < column_end; ++x)
        for (int sx = 0; sx < s; ++sx)
          visit(x, direction(x + (sx + 0.5) / s, (y0 + y1) / 2), solid_angle);
    }
  }

  // Integral over the sphere of L(w) max(0, w . n) dw, directly over the map's pixels: the
  // irradiance on a surface of normal n, for references.
  Color irradiance(const Vec3& n, int subsamples = 4) const;

 private:
  Environment() = default;
  Color pixel(int row, int column) const;
  void find_compact_lights(double level, std::span<const double> pixel_luminance);

  std::string name_;
  int width_ = 0, height_ = 0;
  double rotation_ = 0;  // radians
  double cos_rotation_ = 1, sin_rotation_ = 0;
  std::vector<float> pixels_;  // RGB rows, bright excess included
  std::vector<float> smooth_;  // RGB rows, bright excess removed
  struct Level {
    int width, height;
    std::vector<float> pixels;  // RGB rows
  };
  std::vector<Level> pyramid_;  // smooth_ halved again and again (level k at index k - 1)
  void build_pyramid();
  std::vector<double> row_solid_angle_;  // per pixel of each row
  std::vector<BrightPixel> bright_;
  std::vector<CompactLight> lights_;
  EnvironmentRepairs repairs_;
  bool constant_ = false;
};

// What an environment's repaired texels mean for its caller. NaN or infinite texels are a
// FileError naming the map, ending with `remedy` in brackets (how to repair or allow them),
// unless `zero_invalid` lets them be read as 0; then, or for negative texels alone, the result
// is a one-line warning counting what was set to 0. Empty when nothing was repaired.
std::string repaired_texels_warning(const Environment& environment, bool zero_invalid,
                                    const std::string& remedy);

}  // namespace basis
