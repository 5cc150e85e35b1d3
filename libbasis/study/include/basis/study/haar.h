// Haar wavelets on the unit square with non-linear approximation (keep the K largest
// coefficients), convolution by sparse dot product. A baseline for qtbench.
#pragma once

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "basis/core/color.h"
#include "basis/core/grid.h"

namespace basis {

// The K largest coefficients of each channel of a function's orthonormal 2D Haar transform
// (non-standard decomposition of its N x N texel grid), as sorted (index, value) pairs.
struct HaarApproximation {
  int resolution = 0;
  int channels = 1;
  std::vector<std::vector<std::pair<std::uint32_t, float>>> kept;  // per channel, by index

  std::size_t bytes() const;  // 8 bytes per kept coefficient
};

// Orthonormal transform of group 0 of the grid, keeping the K largest magnitudes per channel
// (the scaling coefficient always). K >= N^2 keeps everything (exact).
HaarApproximation haar_project(const Grid& grid, std::size_t keep);

// Integral over [0,1]^2 of a * b per channel: the sparse dot product of the kept coefficients
// divided by N^2. Equal resolutions; channels equal or one of them 1.
Color haar_dot(const HaarApproximation& a, const HaarApproximation& b);

// The approximation as a dense grid (inverse transform), for tests.
Grid haar_reconstruct(const HaarApproximation& a);

}  // namespace basis
