// The MERL BRDF database format (Matusik, Pfister, Brand, McMillan 2003): three int32
// dimensions (90, 90, 180), then three channels of 90 * 90 * 180 doubles in Rusinkiewicz's
// half/difference angles (theta_h indexed non-linearly), scaled per channel by 1/1500,
// 1.15/1500 and 1.66/1500.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "basis/brdf/measured.h"
#include "basis/core/file_error.h"

namespace basis {

class MerlBrdf : public MeasuredBrdf {
 public:
  static constexpr int kThetaH = 90, kThetaD = 90, kPhiD = 180;
  static constexpr double kScale[3] = {1.0 / 1500, 1.15 / 1500, 1.66 / 1500};

  // Reads a MERL file; throws FileError naming the file and the problem (missing, short,
  // wrong header, NaN or infinite samples, samples above 1e30, which a table of floats cannot
  // hold). Negative samples mark missing data and evaluate to 0.
  static std::shared_ptr<const MerlBrdf> read(const std::string& path);
  // The same from the file's bytes; `name` stands for the file in errors.
  static std::shared_ptr<const MerlBrdf> parse(std::span<const unsigned char> bytes,
                                               const std::string& name);
  // From raw samples (channel-major, 3 * 90 * 90 * 180 doubles before scaling).
  explicit MerlBrdf(std::vector<double> samples);

  // Nearest sample in (theta_h, theta_d, phi_d), as the database's reference reader does.
  Color evaluate(const Vec3& wi, const Vec3& wo) const override;
  std::string format() const override { return "merl"; }
  // Fraction of samples marked missing (negative).
  double missing_fraction() const { return missing_fraction_; }

  // Half/difference angles of a pair of directions (Rusinkiewicz 1998): theta_h, theta_d in
  // [0, pi/2] for directions above the horizon, phi_d in [0, 2 pi).
  struct HalfDiff {
    double theta_h, theta_d, phi_d;
  };
  static HalfDiff to_half_diff(const Vec3& wi, const Vec3& wo);
  // Index of the sample holding these angles (phi_d folded by reciprocity to [0, pi)).
  static std::size_t sample_index(const HalfDiff& angles);

 private:
  std::vector<double> samples_;
  double missing_fraction_ = 0;
};

}  // namespace basis
