// The portable scalar convolution descent (double accumulation), shared by float and packed
// trees and the reference for their SIMD paths. Private to the core library.
#pragma once

#include <cmath>
#include <cstdint>

namespace basis::detail {

struct ScalarSums {
  double value[3][3] = {};  // [group][channel]
  double bound[3] = {};
  double magnitude[3] = {};  // area |a b| of group 0, summed
  std::uint64_t stops = 0;   // quadrant pairs summed
};

// Higham's bound on the rounding of sums through `additions` additions with unit roundoff
// `unit` (2^-24 in floats, 2^-53 in double), as a fraction of the sum of the terms' magnitudes:
// gamma_n = n unit / (1 - n unit). The float and packed descents' bounds take it for their sums.
inline double summation_gamma(double additions, double unit) {
  return additions * unit / (1 - additions * unit);
}

// What an accuracy-targeted descent may spend per unit area of a pair, per channel:
// accuracy / 2 x (|a b| + estimate), estimate the whole integral as the roots' quadrants give
// it. Summed over the pairs where it stops, at most accuracy / 2 x (the value + estimate).
struct AccuracyTarget {
  double accuracy = 0;
  double estimate[3] = {};
};

// Groups 0 .. groups-1 of a against group 0 of b over the cell of nodes (na, nb), whose
// quadrants have the given area. Where either quadrant is a leaf, or (accuracy > 0) where in
// every channel the pair's bound pair_bound(na, nb, ca, cb, q, va, vb) is within the target,
// the pair adds area va vb and area times its bound; elsewhere it descends.
template <typename A, typename B, typename PairBound>
void descend_scalar(const A& a, const B& b, int na, int nb, double area, int channels, int groups,
                    const AccuracyTarget& target, const PairBound& pair_bound, ScalarSums& sums) {
  const int ca_count = a.shape().channels, cb_count = b.shape().channels;
  for (int q = 0; q < 4; ++q) {
    const int child_a = a.child(na, q), child_b = b.child(nb, q);
    bool stop = !(child_a && child_b);
    double va[3], vb[3], bound[3];
    for (int c = 0; c < channels; ++c) {
      const int ca = ca_count == 1 ? 0 : c, cb = cb_count == 1 ? 0 : c;
      va[c] = a.value(na, 0, ca, q);
      vb[c] = b.value(nb, 0, cb, q);
      bound[c] = pair_bound(na, nb, ca, cb, q, va[c], vb[c]);
    }
    if (!stop && target.accuracy > 0) {
      stop = true;
      for (int c = 0; c < channels; ++c)
        if (!(bound[c] <= target.accuracy / 2 * (std::abs(va[c] * vb[c]) + target.estimate[c])))
          stop = false;
    }
    if (!stop) {
      descend_scalar(a, b, child_a, child_b, area / 4, channels, groups, target, pair_bound, sums);
      continue;
    }
    for (int c = 0; c < channels; ++c) {
      const int ca = ca_count == 1 ? 0 : c;
      for (int g = 0; g < groups; ++g)
        sums.value[g][c] += a.value(na, g, ca, q) * vb[c] * area;
      sums.bound[c] += area * bound[c];
      sums.magnitude[c] += std::abs(a.value(na, 0, ca, q) * vb[c]) * area;
    }
    ++sums.stops;
  }
}

}  // namespace basis::detail
