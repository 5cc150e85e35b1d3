// Measured isotropic RGB BRDFs of the RGL-EPFL database (Dupuy & Jakob 2018, tensor_file v1.0
// ".bsdf" files): a checked reader, the reference evaluation, and sampling through its own warps.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "basis/brdf/measured.h"
#include "basis/core/file_error.h"

namespace basis {

class RglBrdf : public MeasuredBrdf {
 public:
  // Reads an isotropic RGB tensor_file; throws FileError "PATH: problem" for any bad file.
  static std::shared_ptr<const RglBrdf> read(const std::string& path);
  // The same from the file's bytes; `name` stands for the file in errors.
  static std::shared_ptr<const RglBrdf> parse(std::vector<unsigned char> bytes,
                                              const std::string& name);
  ~RglBrdf() override;
  RglBrdf(const RglBrdf&) = delete;
  RglBrdf& operator=(const RglBrdf&) = delete;

  // f(wi, wo) per channel per steradian, no cosine, 0 below the horizon, for light arriving
  // from wi and leaving towards wo. The file's tables are parametrised by one direction, which
  // renderers give the viewing direction: here wo, the direction a BRDF table fixes per entry.
  Color evaluate(const Vec3& wi, const Vec3& wo) const override;
  // The file's own evaluation: f per steradian with `parameter` the tables' direction and
  // `free` the other one (the reference evaluation divided by cos(theta_free)).
  Color evaluate_parametrised(const Vec3& parameter, const Vec3& free) const;
  std::string format() const override { return "rgl"; }
  // The file's own description text, as stored.
  std::string description() const;

  struct Sample {
    Vec3 wo;  // sampled direction (zero when !valid)
    // evaluate_parametrised(wi, wo) cos(theta_o) / pdf, wi being the parameter direction (so
    // evaluate(wo, wi) in evaluate's order, whose second argument is the parameter); zero when
    // !valid.
    Color weight;
    double pdf;  // solid-angle density of wo; zero when !valid
    bool valid;  // false for wi below the horizon or a sample that left the hemisphere
  };
  // Draws the free direction (Sample::wo) for the parameter direction wi from the file's
  // luminance and visible-normal warps, for (u1, u2) in [0, 1)^2.
  Sample sample(const Vec3& wi, double u1, double u2) const;
  // Solid-angle density (per steradian of wo) with which sample(wi, ., .) produces wo.
  double pdf(const Vec3& wi, const Vec3& wo) const;

 private:
  struct Tables;  // the parsed warps and interpolants, defined in rgl.cpp
  explicit RglBrdf(std::unique_ptr<const Tables> tables);
  // f(wi, wo) cos(theta_o) per channel (the reference evaluation), zero below the horizon.
  Color evaluate_cosine(const Vec3& wi, const Vec3& wo) const;

  std::unique_ptr<const Tables> tables_;
};

}  // namespace basis
