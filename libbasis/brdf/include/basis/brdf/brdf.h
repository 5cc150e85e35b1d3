// Analytic BRDF models in the local frame (z = normal), as value types. All return zero when
// either direction is on or below the horizon.
#pragma once

#include <memory>
#include <string>
#include <variant>

#include "basis/core/color.h"
#include "basis/core/vector.h"

namespace basis {

// albedo / pi.
struct Lambert {
  Color albedo{1, 1, 1};
};

// Normalised modified Phong: kd / pi + ks (n + 2) / (2 pi) max(0, wi . r)^n, r the mirror of wo.
struct Phong {
  Color kd{0, 0, 0};
  Color ks{1, 1, 1};
  double exponent = 10;
};

// Normalised Blinn-Phong: kd / pi + ks (n + 8) / (8 pi) max(0, h.z)^n, h = normalize(wi + wo).
struct BlinnPhong {
  Color kd{0, 0, 0};
  Color ks{1, 1, 1};
  double exponent = 10;
};

// Isotropic Ward: kd / pi + ks exp(-tan^2(theta_h) / alpha^2) / (4 pi alpha^2 sqrt(cos_i cos_o)).
struct Ward {
  Color kd{0, 0, 0};
  Color ks{1, 1, 1};
  double alpha = 0.2;
};

// GGX microfacet (Walter et al. 2007) with separable Smith masking and Schlick Fresnel:
// kd / pi + D G F / (4 cos_i cos_o).
struct Ggx {
  Color kd{0, 0, 0};
  Color f0{0.04, 0.04, 0.04};
  double alpha = 0.2;
};

class MeasuredBrdf;  // defined in measured.h

// A BRDF: one of the analytic models or a measured table (shared, immutable).
using Brdf =
    std::variant<Lambert, Phong, BlinnPhong, Ward, Ggx, std::shared_ptr<const MeasuredBrdf>>;

// f(wi, wo) per channel, for unit wi and wo in the local frame.
Color evaluate(const Brdf& brdf, const Vec3& wi, const Vec3& wo);

// 1 when every channel of every colour parameter is equal (a grey BRDF), else 3.
int channel_count(const Brdf& brdf);

// Model name as used in specs: lambert, phong, blinn-phong, ward, ggx, merl, rgl.
std::string model_name(const Brdf& brdf);

}  // namespace basis
