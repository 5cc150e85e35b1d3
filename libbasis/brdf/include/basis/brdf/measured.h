// Measured BRDFs: a common interface for tabulated data (the MERL format and others).
#pragma once

#include <memory>
#include <string>
#include <variant>

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
  // The XXH3-128 (checksum.h's hex digits) of the file the data was read from, so that a table
  // made from it can tell when the file has changed since; empty for data made in memory.
  const std::string& data_checksum() const { return data_checksum_; }

 protected:
  std::string data_checksum_;
};

// The data checksum of a measured BRDF (MeasuredBrdf::data_checksum), empty for analytic ones.
inline std::string brdf_data_checksum(const Brdf& brdf) {
  const auto* measured = std::get_if<std::shared_ptr<const MeasuredBrdf>>(&brdf);
  return measured && *measured ? (*measured)->data_checksum() : std::string();
}

}  // namespace basis
