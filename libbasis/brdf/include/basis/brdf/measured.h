// Measured BRDFs: a common interface for tabulated data (the MERL format and others).
#pragma once

#include <string>

#include "basis/brdf/brdf.h"

namespace basis {

// An immutable measured BRDF evaluated in the local frame (z = normal).
class MeasuredBrdf {
 public:
  virtual ~MeasuredBrdf() = default;
  // f(wi, wo) per channel; zero below the horizon or where the data has no sample.
  virtual Color evaluate(const Vec3& wi, const Vec3& wo) const = 0;
  // "merl" or "rgl".
  virtual std::string format() const = 0;
  virtual int channels() const { return 3; }
};

}  // namespace basis
