// Dense full-resolution convolution of grids: the references the quadtree is tested and
// benchmarked against (the paper's regular 32 x 32 textures, section 4).
#pragma once

#include "basis/core/convolution.h"
#include "basis/core/grid.h"

namespace basis {

// Integral over [0,1]^2 of a * b for group 0, per channel, by a plain loop over texels with a
// double accumulator. Grids must share the resolution; channels equal or one of them 1.
Rgb dense_convolve_naive(const Grid& a, const Grid& b);

// Same integral as a vectorised dot product (Eigen, float).
Rgb dense_convolve_simd(const Grid& a, const Grid& b);

}  // namespace basis
