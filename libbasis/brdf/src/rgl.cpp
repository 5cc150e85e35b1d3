#include "basis/brdf/rgl.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "basis/core/file_error.h"
#include "basis/core/hemisphere.h"
#include "basis/io/checksum.h"
#include "tensor_file.h"
#include "warp2d.h"

namespace basis {

namespace {

using rgl::Field;
using rgl::kFloat32;
using rgl::kMaxFileSize;
using rgl::kUint8;
using rgl::shape_text;
using rgl::TensorFile;
using rgl::Warp2D;

// Angles and their unit-square coordinates: u_theta = sqrt(2 theta / pi), u_phi = (phi + pi) / 2pi.

// Angle from +z of a unit vector, accurate near the pole.
double elevation(const Vec3& d) {
  return 2 * std::asin(std::min(1.0, 0.5 * (d - Vec3::UnitZ()).norm()));
}
double theta_to_u(double theta) {
  return std::sqrt(std::max(0.0, 2 * theta / std::numbers::pi));
}
double phi_to_u(double phi) {
  return (phi + std::numbers::pi) / (2 * std::numbers::pi);
}
double u_to_theta(double u) {
  return 0.5 * std::numbers::pi * u * u;
}
double u_to_phi(double u) {
  return (2 * u - 1) * std::numbers::pi;
}

// The table parameters of an incident direction.
struct Incident {
  double theta, phi;
  Vec2 u;                        // (u_theta, u_phi), where sigma is looked up
  std::array<double, 2> params;  // (phi_i, theta_i), the vndf and luminance parameters
};

Incident incident(const Vec3& wi) {
  const double theta = elevation(wi), phi = std::atan2(wi.y(), wi.x());
  return {theta, phi, Vec2(theta_to_u(theta), phi_to_u(phi)), {phi, theta}};
}

// (u_theta, u_phi) of a half vector, its azimuth taken relative to phi_i and wrapped to [0, 1).
Vec2 half_vector_u(const Vec3& wm, double phi_i) {
  double u_phi = phi_to_u(std::atan2(wm.y(), wm.x()) - phi_i);
  u_phi -= std::floor(u_phi);
  return Vec2(theta_to_u(elevation(wm)), u_phi);
}

// Solid-angle Jacobian of the half vector in the u-square times the reflection Jacobian.
double half_vector_jacobian(double u_theta, double sin_theta_m, double wi_dot_wm) {
  return std::max(2 * std::numbers::pi * std::numbers::pi * u_theta * sin_theta_m, 1e-6) * 4 *
         wi_dot_wm;
}

bool above_horizon(const Vec3& w) {
  return w.allFinite() && w.z() > 0;
}

}  // namespace

struct RglBrdf::Tables {
  std::string description;
  bool jacobian = true;
  Warp2D ndf, sigma;  // plain interpolants on (u_theta, u_phi)
  Warp2D vndf;        // density on (u_theta_m, relative u_phi_m), parameters (phi_i, theta_i)
  Warp2D luminance;   // density on the sample square, parameters (phi_i, theta_i)
  Warp2D rgb;         // plain, on the sample square, parameters (phi_i, theta_i, channel)

  // f cos(theta_o) per channel for an incident direction, a sample-square point s and the
  // half vector's u-square point um.
  Color reflectance(const Incident& in, const Vec2& s, const Vec2& um) const {
    const double scale = jacobian ? ndf.eval(um, {}) / (4 * sigma.eval(in.u, {})) : 1.0;
    Color value;
    for (int c = 0; c < 3; ++c) {
      const std::array<double, 3> params = {in.phi, in.theta, double(c)};
      value[std::size_t(c)] = std::max(0.0, rgb.eval(s, params)) * scale;
    }
    return value;
  }
};

RglBrdf::RglBrdf(std::unique_ptr<const Tables> tables) : tables_(std::move(tables)) {}

RglBrdf::~RglBrdf() = default;

std::shared_ptr<const RglBrdf> RglBrdf::read(const std::string& path) {
  check_regular_file(path);
  std::error_code error;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path + ": " + std::strerror(errno));
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error) throw FileError(path + ": " + error.message());
  if (size > kMaxFileSize)
    throw FileError(path + ": too large for an RGL BRDF (" + std::to_string(size) + " bytes)");
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  if (std::uintmax_t(in.gcount()) != size)
    throw FileError(path + ": could not read the whole file (" + std::to_string(in.gcount()) +
                    " of " + std::to_string(size) + " bytes)");
  return parse(std::move(bytes), path);
}

std::shared_ptr<const RglBrdf> RglBrdf::parse(std::vector<unsigned char> bytes,
                                              const std::string& path) {
  if (bytes.size() > kMaxFileSize)
    throw FileError(path + ": too large for an RGL BRDF (" + std::to_string(bytes.size()) +
                    " bytes)");
  const std::string checksum = checksum_hex(std::as_bytes(std::span(bytes)));
  const TensorFile file(path, std::move(bytes));
  if (file.has("wavelengths") || file.has("spectra"))
    file.fail("spectral files are not supported (only RGB files with an 'rgb' field)");

  auto tables = std::make_unique<Tables>();
  {
    const std::vector<unsigned char> text = file.octets(file.get("description", kUint8, 1));
    tables->description.assign(text.begin(), text.end());
  }

  // Incident grids: phi_i (one entry, or two, for isotropic files) and theta_i, increasing.
  const Field& phi_field = file.get("phi_i", kFloat32, 1);
  const Field& theta_field = file.get("theta_i", kFloat32, 1);
  const std::vector<double> phi_grid = file.floats(phi_field);
  const std::vector<double> theta_grid = file.floats(theta_field);
  if (phi_grid.empty()) file.fail("field 'phi_i' is empty");
  if (theta_grid.empty()) file.fail("field 'theta_i' is empty");
  if (phi_grid.size() > 2)
    file.fail("anisotropic files are not supported (phi_i has " + std::to_string(phi_grid.size()) +
              " entries)");
  for (const auto* grid : {&phi_grid, &theta_grid})
    for (std::size_t k = 1; k < grid->size(); ++k)
      if (!((*grid)[k] > (*grid)[k - 1]))
        file.fail(std::string("field '") + (grid == &phi_grid ? "phi_i" : "theta_i") +
                  "' is not strictly increasing");
  const std::uint64_t n_phi = phi_grid.size(), n_theta = theta_grid.size();

  // Builds a warp from a field, reporting construction problems against the field.
  auto warp = [&](const std::string& name, const std::vector<double>& values, std::uint64_t nx,
                  std::uint64_t ny, std::vector<std::vector<double>> grids,
                  bool density) -> Warp2D {
    try {
      return Warp2D(values, std::size_t(nx), std::size_t(ny), std::move(grids), density);
    } catch (const std::invalid_argument& e) {
      file.fail("field '" + name + "': " + e.what());
    }
  };
  auto at_least_2x2 = [&](const Field& f) {
    const std::size_t n = f.shape.size();
    if (f.shape[n - 1] < 2 || f.shape[n - 2] < 2)
      file.fail("field '" + f.name + "' needs at least 2 x 2 entries per slice, got shape " +
                shape_text(f.shape));
  };
  auto incident_dims = [&](const Field& f) {
    if (f.shape[0] != n_phi || f.shape[1] != n_theta)
      file.fail("field '" + f.name + "' has shape " + shape_text(f.shape) + " but phi_i and " +
                "theta_i have " + std::to_string(n_phi) + " and " + std::to_string(n_theta) +
                " entries");
  };
  auto non_negative = [&](const std::string& name, const std::vector<double>& values) {
    for (double v : values)
      if (v < 0) file.fail("field '" + name + "' holds negative values");
  };

  // ndf and sigma: plain interpolants on (x = u_theta, y = u_phi).
  const Field& ndf_field = file.get("ndf", kFloat32, 2);
  const Field& sigma_field = file.get("sigma", kFloat32, 2);
  at_least_2x2(ndf_field);
  at_least_2x2(sigma_field);
  const std::vector<double> ndf = file.floats(ndf_field);
  const std::vector<double> sigma = file.floats(sigma_field);
  non_negative("ndf", ndf);
  for (double v : sigma)
    if (!(v > 0)) file.fail("field 'sigma' holds values that are not positive");
  tables->ndf = warp("ndf", ndf, ndf_field.shape[1], ndf_field.shape[0], {}, false);
  tables->sigma = warp("sigma", sigma, sigma_field.shape[1], sigma_field.shape[0], {}, false);

  // vndf: [phi_i][theta_i][u_phi_m][u_theta_m], a density per incident direction.
  const Field& vndf_field = file.get("vndf", kFloat32, 4);
  incident_dims(vndf_field);
  at_least_2x2(vndf_field);
  const std::vector<double> vndf = file.floats(vndf_field);
  non_negative("vndf", vndf);
  tables->vndf =
      warp("vndf", vndf, vndf_field.shape[3], vndf_field.shape[2], {phi_grid, theta_grid}, true);

  // luminance: [phi_i][theta_i][y][x] on the square sample grid, a density per direction.
  const Field& luminance_field = file.get("luminance", kFloat32, 4);
  incident_dims(luminance_field);
  at_least_2x2(luminance_field);
  if (luminance_field.shape[2] != luminance_field.shape[3])
    file.fail("field 'luminance' is not square: shape " + shape_text(luminance_field.shape));
  const std::vector<double> luminance = file.floats(luminance_field);
  non_negative("luminance", luminance);
  tables->luminance = warp("luminance", luminance, luminance_field.shape[3],
                           luminance_field.shape[2], {phi_grid, theta_grid}, true);

  // rgb: [phi_i][theta_i][channel][y][x], on the same grid as luminance.
  const Field& rgb_field = file.get("rgb", kFloat32, 5);
  incident_dims(rgb_field);
  if (rgb_field.shape[2] != 3 || rgb_field.shape[3] != luminance_field.shape[2] ||
      rgb_field.shape[4] != luminance_field.shape[3])
    file.fail("field 'rgb' has shape " + shape_text(rgb_field.shape) + ", expected [" +
              std::to_string(n_phi) + " x " + std::to_string(n_theta) + " x 3 x " +
              std::to_string(luminance_field.shape[2]) + " x " +
              std::to_string(luminance_field.shape[3]) + "]");
  tables->rgb = warp("rgb", file.floats(rgb_field), rgb_field.shape[4], rgb_field.shape[3],
                     {phi_grid, theta_grid, {0.0, 1.0, 2.0}}, false);

  // jacobian: one byte; when set the value is rgb * D / (4 sigma), else rgb alone.
  const Field& jacobian_field = file.get("jacobian", kUint8, 1);
  if (jacobian_field.count != 1)
    file.fail("field 'jacobian' must hold one byte, got shape " + shape_text(jacobian_field.shape));
  tables->jacobian = file.octets(jacobian_field)[0] != 0;
  // 'valid' and 'version' are not used by the reference evaluation; their bounds were checked.

  std::shared_ptr<RglBrdf> brdf(new RglBrdf(std::move(tables)));
  brdf->data_checksum_ = checksum;
  return brdf;
}

std::string RglBrdf::description() const {
  return tables_->description;
}

Color RglBrdf::evaluate_cosine(const Vec3& wi_in, const Vec3& wo_in) const {
  if (!above_horizon(wi_in) || !above_horizon(wo_in)) return {0, 0, 0};
  const Vec3 wi = wi_in.normalized(), wo = wo_in.normalized();
  const Vec3 wm = half_vector(wi, wo);
  const Incident in = incident(wi);
  const Vec2 um = half_vector_u(wm, in.phi);
  const Vec2 s = tables_->vndf.invert(um, in.params).pos;
  return tables_->reflectance(in, s, um);
}

Color RglBrdf::evaluate_parametrised(const Vec3& parameter, const Vec3& free) const {
  Color f = evaluate_cosine(parameter, free);
  if (f[0] == 0 && f[1] == 0 && f[2] == 0) return f;
  const double cos_free = free.z() / free.norm();
  for (double& v : f)
    v /= cos_free;
  return f;
}

Color RglBrdf::evaluate(const Vec3& wi, const Vec3& wo) const {
  return evaluate_parametrised(wo, wi);
}

double RglBrdf::pdf(const Vec3& wi_in, const Vec3& wo_in) const {
  if (!above_horizon(wi_in) || !above_horizon(wo_in)) return 0;
  const Vec3 wi = wi_in.normalized(), wo = wo_in.normalized();
  const Vec3 wm = half_vector(wi, wo);
  const Incident in = incident(wi);
  const Vec2 um = half_vector_u(wm, in.phi);
  const Warp2D::Point p = tables_->vndf.invert(um, in.params);
  const double luminance_pdf = tables_->luminance.eval(p.pos, in.params);
  const double sin_theta_m = std::hypot(wm.x(), wm.y());
  return p.pdf * luminance_pdf / half_vector_jacobian(um.x(), sin_theta_m, wi.dot(wm));
}

RglBrdf::Sample RglBrdf::sample(const Vec3& wi_in, double u1, double u2) const {
  const Sample failed{Vec3(0, 0, 0), {0, 0, 0}, 0, false};
  if (!above_horizon(wi_in)) return failed;
  const Vec3 wi = wi_in.normalized();
  const Incident in = incident(wi);
  // As the reference does, the second variate drives the first (x) coordinate.
  const Warp2D::Point s = tables_->luminance.sample(Vec2(u2, u1), in.params);
  const Warp2D::Point um = tables_->vndf.sample(s.pos, in.params);
  const double theta_m = u_to_theta(um.pos.x()), phi_m = u_to_phi(um.pos.y()) + in.phi;
  const double sin_theta_m = std::sin(theta_m);
  const Vec3 wm(std::cos(phi_m) * sin_theta_m, std::sin(phi_m) * sin_theta_m, std::cos(theta_m));
  const double wi_dot_wm = wi.dot(wm);
  if (!(wi_dot_wm > 0)) return failed;
  const Vec3 wo = 2 * wi_dot_wm * wm - wi;
  if (!(wo.z() > 0)) return failed;
  const double pdf = um.pdf * s.pdf / half_vector_jacobian(um.pos.x(), sin_theta_m, wi_dot_wm);
  if (!(pdf > 0) || !std::isfinite(pdf)) return failed;
  const Color value = tables_->reflectance(in, s.pos, um.pos);
  return {wo, {value[0] / pdf, value[1] / pdf, value[2] / pdf}, pdf, true};
}

}  // namespace basis
