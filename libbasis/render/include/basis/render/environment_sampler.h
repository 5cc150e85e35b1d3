// Importance sampling of an environment map: directions drawn in proportion to each pixel's
// luminance times its solid angle (compact lights included), uniform in solid angle within
// the pixel, with their density per unit solid angle.
#pragma once

#include <vector>

#include "basis/lighting/environment.h"

namespace basis {

class EnvironmentSampler {
 public:
  // The piecewise-constant distribution over the map's pixels (uniform over the sphere for a
  // constant environment). Pixels darker than 1e-4 of the mean keep that floor, so that every
  // direction has a density.
  explicit EnvironmentSampler(const Environment& environment);

  struct Sample {
    Vec3 w;      // world, unit
    double pdf;  // per unit solid angle
  };
  // A direction from four numbers in [0, 1): the row, the column, and the point in the pixel.
  Sample sample(double u_row, double u_column, double u_theta, double u_phi) const;
  // The density of sample()'s directions at w, per unit solid angle.
  double pdf(const Vec3& w) const;

 private:
  const Environment* environment_;
  std::vector<double> row_cdf_;     // height + 1 values from 0 to 1
  std::vector<double> column_cdf_;  // per row, width + 1 values from 0 to 1
  std::vector<double> pixel_probability_;
};

}  // namespace basis
