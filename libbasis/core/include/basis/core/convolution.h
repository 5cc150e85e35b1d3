// Convolution of quadtrees (Vostryakov, section 2.3): the integral over the unit square of the
// product of two or more trees, by simultaneous descent, with a certified error bound. Every
// function here runs with gradual underflow, whatever the caller's flush-to-zero and
// denormals-are-zero modes, which it gives back on return.
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

#include "basis/core/color.h"
#include "basis/core/packed_tree.h"
#include "basis/core/quadtree.h"

namespace basis {

// A value with its certified bound, per channel; a single-channel result is repeated in all
// three lanes. convolve() returns the integral over [0,1]^2 of a(u,v) b(u,v) du dv (group 0 of
// both trees); lookups built on it (reflect, shade, capture_product) return hemisphere
// integrals, pi times that. The bound is on |value - the same integral of the trees'
// full-resolution grids|; +infinity when the values alone were asked for (ConvolutionOptions).
struct Convolution {
  Rgb value{};
  Rgb bound{};
};

// Channel counts must be equal or one of them 1 (a grey function against RGB). Trees of
// different resolutions convolve as the piecewise-constant functions they are. The value is
// the two trees' integral, summed in floats; the bound covers its difference to the product of
// the source grids: on every quadrant where the descent stops it adds
// area * min(ea eb + |a| rb + |b| ra, ea (|b| + rb) + |a| rb, eb (|a| + ra) + |b| ra), ea, eb the
// quadrants' error bounds and ra, rb how far their stored averages may lie from their texels'
// means (half a float step and the double sums' 2^-48 of the largest texel); the second only
// when b is known to be >= 0 (QuadtreeView::non_negative), the third likewise, so that it holds
// for functions of any sign; and then the float sums' rounding, (2 P + 8) 2^-24 of the sum of
// area |a b| (P the pairs visited; in double for convolve_scalar). Where the float sums of the
// value leave the floats (products of texels beyond about 1.8e19), the descent is done again in
// double; a bound beyond the floats is +infinity; a value beyond them throws
// std::overflow_error.
// For the hemisphere integral of A * B * cos in the cosine-weighted map, multiply by pi.
Convolution convolve(const QuadtreeView& a, const QuadtreeView& b);

// The value alone: the fastest path (SSE, four quadrants per instruction); convolve()'s value to
// the bit (infinite where that throws).
Rgb convolve_value(const QuadtreeView& a, const QuadtreeView& b);

// Portable recursive scalar implementation of convolve (double accumulation), the reference
// for the SIMD path.
Convolution convolve_scalar(const QuadtreeView& a, const QuadtreeView& b);

// Each channel group of `a` (1 to 3 groups) against group 0 of `b`, in one descent: value[g]
// is the integral of a_g * b (groups a lacks are zero); bound is convolve()'s bound for group 0.
// Used for rotation compensation.
struct GroupConvolution {
  std::array<Rgb, 3> value{};
  Rgb bound{};
};
GroupConvolution convolve_groups(const QuadtreeView& a, const QuadtreeView& b);

// Portable scalar implementation of convolve_groups, the reference for its SIMD path.
GroupConvolution convolve_groups_scalar(const QuadtreeView& a, const QuadtreeView& b);

// Integral over [0,1]^2 of the product of several trees (group 0; 1 to 8 of them, else
// std::invalid_argument). The descent stops on a quadrant as soon as all factors but one are
// leaves there.
Rgb convolve_product(std::span<const QuadtreeView> factors);

// ---------------------------------------------------------------- packed trees

struct ConvolutionOptions {
  // Accuracy-targeted descent: a pair of internal quadrants also stops (its product taken as
  // a * b * area, the integral of the two quadrants' averages) once, in every channel, its
  // certified bound is at most accuracy / 2 x (|a b| + E) area, E the whole integral as the
  // roots' quadrants estimate it. The bounds of such stops add up to at most accuracy / 2 x
  // (value + E): the reported bound stays within about `accuracy` of the value (plus what the
  // leaves contribute). 0 descends to the leaves. From 0 to 1 (std::invalid_argument otherwise,
  // NaN included).
  double accuracy = 0;
  // Whether to certify: false gives the value alone, from the same descent (the same pairs and
  // sums, so the same value to the bit), without the bound's arithmetic, and a bound of
  // +infinity in every channel (nothing certified). An accuracy target stops on the bound, so
  // it needs one (std::invalid_argument otherwise).
  bool bound = true;
};

// A result computed in double as a float value and a float bound that still holds for it: the
// value rounded to nearest, the bound plus that rounding, rounded up (so that results below the
// normal floats keep a bound that is not zero; a bound beyond the floats becomes +infinity).
// std::overflow_error when the value rounds beyond the largest float (from half a step above it
// on) or is NaN.
struct CertifiedFloat {
  float value = 0;
  float bound = 0;
};
[[noreturn]] void throw_beyond_floats(double value);
inline CertifiedFloat certified_float(double value, double bound) {
  constexpr double kLargest = std::numeric_limits<float>::max();
  // Halfway from the largest float to 2^128, which rounds to infinity (the largest is odd).
  constexpr double kRoundsBeyond = kLargest + 0x1p103;
  if (!(std::abs(value) < kRoundsBeyond)) throw_beyond_floats(value);
  CertifiedFloat out;
  out.value = float(value);
  const double widened = bound + std::abs(value - double(out.value));
  if (!(widened <= kLargest)) {  // +infinity, or beyond the floats: nothing a float certifies
    out.bound = std::numeric_limits<float>::infinity();
    return out;
  }
  out.bound = float(widened);
  // Rounded down: the next float up (widened >= 0, so the bits of the next one are one more).
  if (double(out.bound) < widened)
    out.bound = std::bit_cast<float>(std::bit_cast<std::uint32_t>(out.bound) + 1u);
  return out;
}

// A result whose channels were summed in double, each made a CertifiedFloat.
inline Convolution certified_convolution(const std::array<double, 3>& value,
                                         const std::array<double, 3>& bound) {
  Convolution out;
  for (int c = 0; c < 3; ++c) {
    const CertifiedFloat f = certified_float(value[c], bound[c]);
    out.value[c] = f.value;
    out.bound[c] = f.bound;
  }
  return out;
}

// The integral over [0,1]^2 of a * b (group 0 of both), as convolve() does for float trees, on
// packed trees. Results beyond the floats throw std::overflow_error (certified_float). The bound
// adds, on every quadrant where the descent stops,
//   area * min(sa sb, [a linf] ea |b|, [b linf] eb |a|),
// sa, sb the quadrants' RMS bounds (both kinds bound the RMS deviation; Cauchy-Schwarz bounds
// the integral of (A - a)(B - b) by their product), ea, eb their largest-deviation bounds
// (for a non-negative other side: ea |b| needs B >= 0, which only a capture's shared-exponent
// words are known to be; against halves, which may hold a signed grid, the alternative adds
// sa sb); then, summed over those quadrants, the values' rounding (about 2^-10 of area |a b|,
// half a step of either side's halves) and the sums' own: gamma_n of the same magnitudes
// (Higham's bound, n unit / (1 - n unit), unit 2^-24 and in double for convolve_scalar 2^-53, n
// the smaller tree's nodes plus 52). Channel counts equal or one of them 1.
Convolution convolve(const PackedTreeView& a, const PackedTreeView& b,
                     const ConvolutionOptions& options = {});

// Portable scalar implementation (double accumulation), the reference for the SIMD path.
Convolution convolve_scalar(const PackedTreeView& a, const PackedTreeView& b,
                            const ConvolutionOptions& options = {});

// The integral over [0,1]^2 of (sum_g weights[g] a_g) * b: groups 0 .. weights.size() - 1 of a,
// combined with the weights into one function, against group 0 of b, in one descent. The bound
// is convolve()'s for that function, whose RMS (and largest) deviations are at most
// sum_g |weights[g]| times the groups'. Needs bounds for every weighted group (weights.size()
// from 1 to a's bounded_groups; std::invalid_argument otherwise). Used by table lookups that
// interpolate over wo with the entries' derivatives (table_lookup.h).
Convolution convolve_weighted(const PackedTreeView& a, std::span<const float> weights,
                              const PackedTreeView& b, const ConvolutionOptions& options = {});
// Portable scalar implementation, the reference for the SIMD path.
Convolution convolve_weighted_scalar(const PackedTreeView& a, std::span<const float> weights,
                                     const PackedTreeView& b,
                                     const ConvolutionOptions& options = {});

// Each channel group of packed tree a against group 0 of b in one descent (see the float
// version); the bound is convolve()'s, for group 0. Descends to the leaves.
GroupConvolution convolve_groups(const PackedTreeView& a, const PackedTreeView& b);
GroupConvolution convolve_groups_scalar(const PackedTreeView& a, const PackedTreeView& b);

}  // namespace basis
