#include "basis/brdf/brdf.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "basis/brdf/measured.h"
#include "basis/core/hemisphere.h"

namespace basis {

namespace {

constexpr double kInvPi = 1 / std::numbers::pi;

Color mix(const Color& diffuse, double diffuse_scale, const Color& specular,
          double specular_scale) {
  return {diffuse[0] * diffuse_scale + specular[0] * specular_scale,
          diffuse[1] * diffuse_scale + specular[1] * specular_scale,
          diffuse[2] * diffuse_scale + specular[2] * specular_scale};
}

bool grey(const Color& c) {
  return c[0] == c[1] && c[1] == c[2];
}

struct Evaluator {
  const Vec3& wi;
  const Vec3& wo;

  Color operator()(const Lambert& m) const { return mix(m.albedo, kInvPi, {}, 0); }

  Color operator()(const Phong& m) const {
    const Vec3 r(-wo.x(), -wo.y(), wo.z());
    const double c = std::max(0.0, wi.dot(r));
    const double lobe = (m.exponent + 2) / (2 * std::numbers::pi) * std::pow(c, m.exponent);
    return mix(m.kd, kInvPi, m.ks, lobe);
  }

  Color operator()(const BlinnPhong& m) const {
    const Vec3 h = half_vector(wi, wo);
    const double lobe =
        (m.exponent + 8) / (8 * std::numbers::pi) * std::pow(std::max(0.0, h.z()), m.exponent);
    return mix(m.kd, kInvPi, m.ks, lobe);
  }

  Color operator()(const Ward& m) const {
    const Vec3 h = half_vector(wi, wo);
    const double cos2 = h.z() * h.z();
    const double tan2 = (1 - cos2) / cos2;
    const double a2 = m.alpha * m.alpha;
    // sqrt(wi.z) sqrt(wo.z), not sqrt(wi.z wo.z): the product underflows to 0 near the horizon.
    const double lobe =
        std::exp(-tan2 / a2) / (4 * std::numbers::pi * a2 * std::sqrt(wi.z()) * std::sqrt(wo.z()));
    return mix(m.kd, kInvPi, m.ks, lobe);
  }

  Color operator()(const Ggx& m) const {
    const Vec3 h = half_vector(wi, wo);
    const double a2 = m.alpha * m.alpha;
    const double d_denominator = h.z() * h.z() * (a2 - 1) + 1;
    const double d = a2 / (std::numbers::pi * d_denominator * d_denominator);
    // Smith's G1(z) / z, kept apart so that G / (4 wi.z wo.z) has no 0 / 0 near the horizon.
    auto g1_over_z = [a2](double z) { return 2 / (z + std::sqrt(a2 + (1 - a2) * z * z)); };
    const double x = 1 - std::clamp(wi.dot(h), 0.0, 1.0), x2 = x * x;
    const double schlick = x2 * x2 * x;  // (1 - wi.h)^5, without the cost of pow
    const double common = d * g1_over_z(wi.z()) * g1_over_z(wo.z()) / 4;
    Color f;
    for (int c = 0; c < 3; ++c)
      f[c] = m.kd[c] * kInvPi + common * (m.f0[c] + (1 - m.f0[c]) * schlick);
    return f;
  }

  Color operator()(const std::shared_ptr<const MeasuredBrdf>& m) const {
    if (!m) throw std::invalid_argument("a measured BRDF without data (null)");
    return m->evaluate(wi, wo);
  }
};

}  // namespace

Color evaluate(const Brdf& brdf, const Vec3& wi, const Vec3& wo) {
  if (wi.z() <= 0 || wo.z() <= 0) return {0, 0, 0};
  return std::visit(Evaluator{wi, wo}, brdf);
}

int channel_count(const Brdf& brdf) {
  struct Counter {
    int operator()(const Lambert& m) const { return grey(m.albedo) ? 1 : 3; }
    int operator()(const Phong& m) const { return grey(m.kd) && grey(m.ks) ? 1 : 3; }
    int operator()(const BlinnPhong& m) const { return grey(m.kd) && grey(m.ks) ? 1 : 3; }
    int operator()(const Ward& m) const { return grey(m.kd) && grey(m.ks) ? 1 : 3; }
    int operator()(const Ggx& m) const { return grey(m.kd) && grey(m.f0) ? 1 : 3; }
    int operator()(const std::shared_ptr<const MeasuredBrdf>& m) const { return m->channels(); }
  };
  return std::visit(Counter{}, brdf);
}

std::string model_name(const Brdf& brdf) {
  struct Namer {
    std::string operator()(const Lambert&) const { return "lambert"; }
    std::string operator()(const Phong&) const { return "phong"; }
    std::string operator()(const BlinnPhong&) const { return "blinn-phong"; }
    std::string operator()(const Ward&) const { return "ward"; }
    std::string operator()(const Ggx&) const { return "ggx"; }
    std::string operator()(const std::shared_ptr<const MeasuredBrdf>& m) const {
      return m->format();
    }
  };
  return std::visit(Namer{}, brdf);
}

}  // namespace basis
