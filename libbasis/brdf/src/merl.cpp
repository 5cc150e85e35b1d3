#include "basis/brdf/merl.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "basis/core/file_error.h"
#include "basis/core/hemisphere.h"
#include "basis/io/checksum.h"

namespace basis {

namespace {

constexpr std::size_t kChannelSize =
    std::size_t(MerlBrdf::kThetaH) * MerlBrdf::kThetaD * MerlBrdf::kPhiD;
// Measured reflectances stay far below this; a table stores f times the scales in floats.
constexpr double kLargestSample = 1e30;
constexpr std::size_t kFileBytes = 3 * sizeof(std::int32_t) + 3 * kChannelSize * sizeof(double);

// Rodrigues' rotation of v about a unit axis.
Vec3 rotate(const Vec3& v, const Vec3& axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return v * c + axis * axis.dot(v) * (1 - c) + axis.cross(v) * s;
}

}  // namespace

MerlBrdf::MerlBrdf(std::vector<double> samples) : samples_(std::move(samples)) {
  if (samples_.size() != 3 * kChannelSize)
    throw std::invalid_argument("a MERL BRDF holds 3 x 90 x 90 x 180 samples");
  std::size_t missing = 0;
  for (double s : samples_)
    missing += s < 0;
  missing_fraction_ = double(missing) / double(samples_.size());
}

std::shared_ptr<const MerlBrdf> MerlBrdf::read(const std::string& path) {
  check_regular_file(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path + ": " + std::strerror(errno));
  // A MERL file has one size: read at most one byte more to see whether it is longer.
  std::vector<unsigned char> bytes(kFileBytes + 1);
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  bytes.resize(std::size_t(in.gcount()));
  return parse(bytes, path);
}

std::shared_ptr<const MerlBrdf> MerlBrdf::parse(std::span<const unsigned char> bytes,
                                                const std::string& name) {
  std::int32_t dims[3] = {};
  if (bytes.size() < sizeof dims) throw FileError(name + ": too short for a MERL header");
  std::memcpy(dims, bytes.data(), sizeof dims);
  if (dims[0] != kThetaH || dims[1] != kThetaD || dims[2] != kPhiD)
    throw FileError(name + ": not a MERL BRDF (dimensions " + std::to_string(dims[0]) + " x " +
                    std::to_string(dims[1]) + " x " + std::to_string(dims[2]) +
                    ", expected 90 x 90 x 180)");
  if (bytes.size() < kFileBytes)
    throw FileError(name + ": truncated MERL file (" + std::to_string(bytes.size()) + " of " +
                    std::to_string(kFileBytes) + " bytes)");
  if (bytes.size() > kFileBytes)
    throw FileError(name + ": longer than a MERL file (" + std::to_string(kFileBytes) + " bytes)");
  std::vector<double> samples(3 * kChannelSize);
  std::memcpy(samples.data(), bytes.data() + sizeof dims, samples.size() * sizeof(double));
  for (double s : samples) {
    if (!std::isfinite(s)) throw FileError(name + ": MERL samples hold NaN or infinity");
    if (s > kLargestSample)
      throw FileError(name + ": MERL samples above 1e30, beyond what a table of floats holds");
  }
  auto brdf = std::make_shared<MerlBrdf>(std::move(samples));
  brdf->data_checksum_ = checksum_hex(std::as_bytes(bytes));
  return brdf;
}

MerlBrdf::HalfDiff MerlBrdf::to_half_diff(const Vec3& wi, const Vec3& wo) {
  const Vec3 h = half_vector(wi, wo);
  const double theta_h = std::acos(std::clamp(h.z(), -1.0, 1.0));
  const double phi_h = std::atan2(h.y(), h.x());
  const Vec3 d = rotate(rotate(wi, Vec3::UnitZ(), -phi_h), Vec3::UnitY(), -theta_h);
  double phi_d = std::atan2(d.y(), d.x());
  if (phi_d < 0) phi_d += 2 * std::numbers::pi;
  return {theta_h, std::acos(std::clamp(d.z(), -1.0, 1.0)), phi_d};
}

std::size_t MerlBrdf::sample_index(const HalfDiff& a) {
  const double half_pi = std::numbers::pi / 2;
  // theta_h: non-linear, index = 90 sqrt(theta_h / (pi/2)).
  const int th =
      a.theta_h <= 0 ? 0 : std::min(kThetaH - 1, int(std::sqrt(a.theta_h / half_pi) * kThetaH));
  const int td = std::clamp(int(a.theta_d / half_pi * kThetaD), 0, kThetaD - 1);
  double phi = std::fmod(a.phi_d, std::numbers::pi);  // reciprocity: phi_d ~ phi_d + pi
  if (phi < 0) phi += std::numbers::pi;
  const int pd = std::clamp(int(phi / std::numbers::pi * kPhiD), 0, kPhiD - 1);
  return (std::size_t(th) * kThetaD + td) * kPhiD + pd;
}

Color MerlBrdf::evaluate(const Vec3& wi, const Vec3& wo) const {
  if (wi.z() <= 0 || wo.z() <= 0) return {0, 0, 0};
  const std::size_t index = sample_index(to_half_diff(wi, wo));
  Color f;
  for (int c = 0; c < 3; ++c)
    f[c] = std::max(0.0, samples_[c * kChannelSize + index]) * kScale[c];
  return f;
}

}  // namespace basis
