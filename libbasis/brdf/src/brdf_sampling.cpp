#include "basis/brdf/brdf_sampling.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "basis/core/color.h"
#include "basis/core/frame.h"

namespace basis {

namespace {

constexpr double kPi = std::numbers::pi;

Vec3 mirror(const Vec3& w) {
  return {-w.x(), -w.y(), w.z()};
}

// A direction at polar angle acos(cos_theta) and azimuth phi about `axis`.
Vec3 about(const Vec3& axis, double cos_theta, double phi) {
  const double sin_theta = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
  return Frame::from_normal(axis).to_world(
      {sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta});
}

// The specular lobe of a model: its weight against the diffuse part, a draw and its density.
struct Lobe {
  double diffuse_weight = 1;  // probability of the cosine lobe
  enum class Kind { none, phong, blinn_phong, ward, ggx } kind = Kind::none;
  double parameter = 0;  // exponent or alpha
};

double mixture_weight(const Color& diffuse, const Color& specular) {
  const double d = luminance(diffuse), s = luminance(specular);
  return d + s > 0 ? d / (d + s) : 1;
}

Lobe lobe_of(const Brdf& brdf) {
  if (const auto* p = std::get_if<Phong>(&brdf))
    return {mixture_weight(p->kd, p->ks), Lobe::Kind::phong, p->exponent};
  if (const auto* p = std::get_if<BlinnPhong>(&brdf))
    return {mixture_weight(p->kd, p->ks), Lobe::Kind::blinn_phong, p->exponent};
  if (const auto* p = std::get_if<Ward>(&brdf))
    return {mixture_weight(p->kd, p->ks), Lobe::Kind::ward, p->alpha};
  if (const auto* p = std::get_if<Ggx>(&brdf))
    return {mixture_weight(p->kd, p->f0), Lobe::Kind::ggx, p->alpha};
  return {};
}

// Density of a half vector h (h.z > 0) per unit solid angle of h.
double half_vector_pdf(const Lobe& lobe, const Vec3& h) {
  const double c = h.z();
  if (!(c > 0)) return 0;
  switch (lobe.kind) {
    case Lobe::Kind::blinn_phong:
      return (lobe.parameter + 1) / (2 * kPi) * std::pow(c, lobe.parameter);
    case Lobe::Kind::ward: {
      const double a2 = lobe.parameter * lobe.parameter, tan2 = (1 - c * c) / (c * c);
      return std::exp(-tan2 / a2) / (kPi * a2 * c * c * c);
    }
    case Lobe::Kind::ggx: {
      const double a2 = lobe.parameter * lobe.parameter, c2 = c * c;
      const double d = c2 * (a2 - 1) + 1;
      return a2 / (kPi * d * d) * c;  // D(h) cos(theta_h)
    }
    default:
      return 0;
  }
}

double specular_pdf(const Lobe& lobe, const Vec3& wi, const Vec3& wo) {
  if (lobe.kind == Lobe::Kind::phong) {
    const double c = wi.dot(mirror(wo));
    return c > 0 ? (lobe.parameter + 1) / (2 * kPi) * std::pow(c, lobe.parameter) : 0;
  }
  const Vec3 sum = wi + wo;
  if (!(sum.norm() > 1e-12)) return 0;
  const Vec3 h = sum.normalized();
  const double oh = wo.dot(h);
  return oh > 0 ? half_vector_pdf(lobe, h) / (4 * oh) : 0;
}

}  // namespace

BrdfSample sample_brdf(const Brdf& brdf, const Vec3& wo, double u_lobe, double u1, double u2) {
  const Lobe lobe = lobe_of(brdf);
  const double phi = 2 * kPi * u2;
  Vec3 wi;
  if (lobe.kind == Lobe::Kind::none || u_lobe < lobe.diffuse_weight) {
    wi = about({0, 0, 1}, std::sqrt(1 - u1), phi);  // cosine-weighted
  } else if (lobe.kind == Lobe::Kind::phong) {
    wi = about(mirror(wo), std::pow(1 - u1, 1 / (lobe.parameter + 1)), phi);
  } else {
    double cos_h = 1;
    if (lobe.kind == Lobe::Kind::blinn_phong) {
      cos_h = std::pow(1 - u1, 1 / (lobe.parameter + 1));
    } else if (lobe.kind == Lobe::Kind::ward) {
      const double tan2 = -lobe.parameter * lobe.parameter * std::log(1 - u1);
      cos_h = 1 / std::sqrt(1 + tan2);
    } else {  // GGX
      const double tan2 = lobe.parameter * lobe.parameter * u1 / (1 - u1);
      cos_h = 1 / std::sqrt(1 + tan2);
    }
    const Vec3 h = about({0, 0, 1}, cos_h, phi);
    wi = 2 * wo.dot(h) * h - wo;
  }
  wi.normalize();
  return {wi, brdf_pdf(brdf, wi, wo)};
}

double brdf_pdf(const Brdf& brdf, const Vec3& wi, const Vec3& wo) {
  if (!(wi.z() > 0) || !(wo.z() > 0)) return 0;
  const Lobe lobe = lobe_of(brdf);
  const double diffuse = wi.z() / kPi;
  if (lobe.kind == Lobe::Kind::none) return diffuse;
  return lobe.diffuse_weight * diffuse + (1 - lobe.diffuse_weight) * specular_pdf(lobe, wi, wo);
}

}  // namespace basis
