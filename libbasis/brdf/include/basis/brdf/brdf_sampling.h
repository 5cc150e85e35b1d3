// Importance sampling of BRDFs in the local frame (z = normal): directions wi drawn for an
// outgoing direction wo from a mixture of a cosine lobe (the diffuse part) and the model's own
// specular lobe, with their density per unit solid angle, for Monte Carlo rendering.
#pragma once

#include "basis/brdf/brdf.h"

namespace basis {

struct BrdfSample {
  Vec3 wi;     // unit; may lie below the horizon, where f is 0
  double pdf;  // density of wi per unit solid angle (brdf_pdf)
};

// Draws wi from three numbers in [0, 1): u_lobe picks the diffuse or the specular lobe (in
// proportion to the luminance of kd and of ks, or f0 for GGX), (u1, u2) place wi in it.
// Specular lobes: Phong cos^n about the mirror direction, Blinn-Phong cos^n of the half
// vector, Ward's and GGX's distributions of the half vector; measured BRDFs, cosine only.
BrdfSample sample_brdf(const Brdf& brdf, const Vec3& wo, double u_lobe, double u1, double u2);

// The density of sample_brdf's wi per unit solid angle (both lobes, as mixed); 0 below the
// horizon of wo or wi.
double brdf_pdf(const Brdf& brdf, const Vec3& wi, const Vec3& wo);

}  // namespace basis
