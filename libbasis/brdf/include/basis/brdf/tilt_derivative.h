// The derivative of a BRDF's reflection integrand with respect to a small tilt of the surface:
// the first-order rotation compensation that BRDF tables store beside each entry.
#pragma once

#include "basis/brdf/brdf.h"
#include "basis/core/vector.h"

namespace basis {

// The integrand of the tilted reflection, in the record's frame and the cosine-weighted
// measure of the record's normal, relative to its re-parametrised approximation:
//   B(t) = f(R^-1 w, wo) max(0, w . R z) / w.z  -  f(w, R^-1 wo),  R = rotation by t about axis,
// and its derivative at t = 0 by central differences of step h. Axis 0 is the tangent, axis 1
// the bitangent (BRDF tables store them as channel groups 0 and 1 of their tilt trees). Zero
// at the rim (w.z = 0).
Color tilt_derivative(const Brdf& brdf, const Vec3& w, const Vec3& wo, int axis, double h);

}  // namespace basis
