// Convolution of packed trees: the SIMD descent (SSE4.1 and F16C) and its scalar reference.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "basis/core/convolution.h"
#include "scalar_descent.h"

#if defined(__SSE4_1__) && defined(__F16C__)
#include <immintrin.h>
#define BASIS_PACKED_SIMD 1
#endif

namespace basis {

namespace {

void check_compatible(const PackedShape& a, const PackedShape& b) {
  if (a.channels != b.channels && a.channels != 1 && b.channels != 1)
    throw std::invalid_argument("cannot convolve trees of " + std::to_string(a.channels) + " and " +
                                std::to_string(b.channels) + " channels");
}

// How far a half-rounded value may lie from the average it stands for, in units of its tree's
// value scale: half an ulp, 2^-11 of the value, or half the subnormal spacing.
constexpr double kHalfRounding = 0x1p-11, kHalfSubnormalRounding = 0x1p-25;

// The bound of a stopped pair of packed quadrants with values a, b, which stand for true
// averages a + da, b + db (|da|, |db| at most half an ulp):
//   |integral of AB - area a b| <= area (|integral of (A - a)(B - b)| / area + |a| db + |b| da),
// the first term at most min(sa sb, [a linf] ea (|b| + db) + |b| da, [b linf] likewise).
auto packed_pair_bound(const PackedTreeView& a, const PackedTreeView& b) {
  const bool linf_a = a.shape().bounds == BoundKind::linf;
  const bool linf_b = b.shape().bounds == BoundKind::linf;
  return [&a, &b, linf_a, linf_b](int na, int nb, int ca, int cb, int q, double va, double vb) {
    const double sa = a.bound(na, ca, q), sb = b.bound(nb, cb, q);
    const double da =
        kHalfRounding * std::abs(va) + kHalfSubnormalRounding * a.scales().value_scale;
    const double db =
        kHalfRounding * std::abs(vb) + kHalfSubnormalRounding * b.scales().value_scale;
    double product = sa * sb;
    if (linf_a) product = std::min(product, sa * (std::abs(vb) + db) + std::abs(vb) * da);
    if (linf_b) product = std::min(product, sb * (std::abs(va) + da) + std::abs(va) * db);
    return product + std::abs(va) * db + std::abs(vb) * da;
  };
}

GroupConvolution scalar(const PackedTreeView& a, const PackedTreeView& b, int groups,
                        double accuracy) {
  check_compatible(a.shape(), b.shape());
  const int channels = std::max(a.shape().channels, b.shape().channels);
  detail::ScalarSums sums;
  detail::descend_scalar(a, b, 0, 0, 0.25, channels, groups, accuracy, packed_pair_bound(a, b),
                         sums);
  GroupConvolution result;
  for (int g = 0; g < groups; ++g)
    result.value[g] = channels_to_rgb(sums.value[g], channels);
  result.bound = channels_to_rgb(sums.bound, channels);
  return result;
}

#if defined(BASIS_PACKED_SIMD)

// Lanes of the quadrants whose bit is set in a 4-bit mask.
alignas(16) constexpr std::uint32_t kLaneMasks[16][4] = {
    {0, 0, 0, 0},     {~0u, 0, 0, 0},     {0, ~0u, 0, 0},     {~0u, ~0u, 0, 0},
    {0, 0, ~0u, 0},   {~0u, 0, ~0u, 0},   {0, ~0u, ~0u, 0},   {~0u, ~0u, ~0u, 0},
    {0, 0, 0, ~0u},   {~0u, 0, 0, ~0u},   {0, ~0u, 0, ~0u},   {~0u, ~0u, 0, ~0u},
    {0, 0, ~0u, ~0u}, {~0u, 0, ~0u, ~0u}, {0, ~0u, ~0u, ~0u}, {~0u, ~0u, ~0u, ~0u}};

inline __m128 lanes_of(unsigned mask) {
  return _mm_load_ps(reinterpret_cast<const float*>(kLaneMasks[mask]));
}

inline __m128 abs_ps(__m128 x) {
  return _mm_andnot_ps(_mm_set1_ps(-0.0f), x);
}

// The four halves at p as floats.
inline __m128 load_halves(const void* p) {
  return _mm_cvtph_ps(_mm_loadl_epi64(static_cast<const __m128i*>(p)));
}

// The four bound codes of the word at p as the floats they stand for (before the tree's scale).
inline __m128 load_bound_codes(const std::uint32_t* p) {
  const __m128i codes = _mm_cvtepu8_epi32(_mm_cvtsi32_si128(int(*p)));
  return _mm_castsi128_ps(
      _mm_add_epi32(_mm_slli_epi32(codes, 20), _mm_set1_epi32(int(kBoundCodeBias))));
}

template <int C>
inline void store_lane_sums(const __m128 (&v)[C], float* out) {
  if constexpr (C == 1) {
    const __m128 pairs = _mm_add_ps(v[0], _mm_movehl_ps(v[0], v[0]));
    _mm_store_ss(out, _mm_add_ss(pairs, _mm_shuffle_ps(pairs, pairs, 1)));
  } else {
    const __m128 t = _mm_hadd_ps(v[0], v[1]);
    const __m128 u = _mm_hadd_ps(v[2], v[2]);
    _mm_storeu_ps(out, _mm_hadd_ps(t, u));
  }
}

// Breadth-first simultaneous descent of packed trees a (groups 0..GA-1) and b (group 0): pairs
// are taken first in, first out from a ring, so that consecutive pairs do not depend on each
// other and, nodes lying breadth first, each level's nodes are read in increasing address
// order. Values and bounds are summed without the trees' scales, applied once at the end.
template <int CA, int CB, int GA, bool kLinfA, bool kLinfB>
class PackedDescent {
 public:
  static constexpr int C = CA > CB ? CA : CB;
  struct Sums {
    __m128 value[GA][C];
    __m128 bound[C];     // bound products, in units of the bound scales
    __m128 rounding[C];  // the values' rounding terms, in units of the value scales
  };

  PackedDescent(const PackedTreeView& a, const PackedTreeView& b, double accuracy)
      : a_(a.words().data()),
        b_(b.words().data()),
        words_a_(a.shape().words_per_node()),
        words_b_(b.shape().words_per_node()),
        codes_a_(1 + 2 * a.shape().groups * CA),
        codes_b_(1 + 2 * b.shape().groups * CB),
        accuracy_(float(accuracy)) {
    // Sums are kept without the trees' scales: values and the rounding terms in units of
    // value_scale_a value_scale_b, bound products in units of bound_scale_a bound_scale_b; the
    // largest-deviation alternatives are brought to the latter's units.
    const TreeScales& sa = a.scales();
    const TreeScales& sb = b.scales();
    bound_scale_ = sa.bound_scale * sb.bound_scale;
    value_scale_ = sa.value_scale * sb.value_scale;
    values_in_bound_units_ = _mm_set1_ps(value_scale_ / bound_scale_);
    linf_a_scale_ = _mm_set1_ps(sb.value_scale / sb.bound_scale);
    linf_b_scale_ = _mm_set1_ps(sa.value_scale / sa.bound_scale);
    // The accuracy test, in bound units: product + rounding x values_in_bound_units <=
    // accuracy |a b| values_in_bound_units.
    accuracy_unscaled_ = _mm_set1_ps(float(accuracy * value_scale_ / bound_scale_));
  }

  Sums run(std::uint32_t root_a, std::uint32_t root_b, float quadrant_area, int depth) const {
    if (depth > kMaxTreeLevels) throw std::runtime_error("quadtree deeper than its resolution");
    Sums sums;
    for (int c = 0; c < C; ++c) {
      for (int g = 0; g < GA; ++g)
        sums.value[g][c] = _mm_setzero_ps();
      sums.bound[c] = sums.rounding[c] = _mm_setzero_ps();
    }
    std::uint32_t ring[kRing][2];
    unsigned head = 0, tail = 0, level_end = 0;
    float area = quadrant_area;
    std::uint32_t na = root_a, nb = root_b;
    for (;;) {
      const std::uint32_t* wa = a_ + std::size_t(na) * words_a_;
      const std::uint32_t* wb = b_ + std::size_t(nb) * words_b_;
      const std::uint32_t la = wa[0], lb = wb[0];
      unsigned internal = la & lb & 0xFu;
      __m128 va[C], vb[C], term[C], rounding[C];
      const __m128 half_ulp = _mm_set1_ps(float(kHalfRounding));
      const __m128 subnormal = _mm_set1_ps(float(kHalfSubnormalRounding));
      for (int c = 0; c < C; ++c) {
        va[c] = load_halves(wa + 1 + 2 * (CA == 1 ? 0 : c));
        vb[c] = load_halves(wb + 1 + 2 * (CB == 1 ? 0 : c));
        const __m128 abs_a = abs_ps(va[c]), abs_b = abs_ps(vb[c]);
        const __m128 da = _mm_add_ps(_mm_mul_ps(half_ulp, abs_a), subnormal);
        const __m128 db = _mm_add_ps(_mm_mul_ps(half_ulp, abs_b), subnormal);
        const __m128 sa = load_bound_codes(wa + codes_a_ + (CA == 1 ? 0 : c));
        const __m128 sb = load_bound_codes(wb + codes_b_ + (CB == 1 ? 0 : c));
        rounding[c] = _mm_add_ps(_mm_mul_ps(abs_a, db), _mm_mul_ps(abs_b, da));
        term[c] = _mm_mul_ps(sa, sb);
        if constexpr (kLinfA)
          term[c] = _mm_min_ps(
              term[c], _mm_add_ps(_mm_mul_ps(_mm_mul_ps(sa, _mm_add_ps(abs_b, db)), linf_a_scale_),
                                  _mm_mul_ps(_mm_mul_ps(abs_b, da), values_in_bound_units_)));
        if constexpr (kLinfB)
          term[c] = _mm_min_ps(
              term[c], _mm_add_ps(_mm_mul_ps(_mm_mul_ps(sb, _mm_add_ps(abs_a, da)), linf_b_scale_),
                                  _mm_mul_ps(_mm_mul_ps(abs_a, db), values_in_bound_units_)));
      }
      if (internal && accuracy_ > 0) {
        __m128 enough = _mm_castsi128_ps(_mm_set1_epi32(-1));
        for (int c = 0; c < C; ++c) {
          const __m128 bound = _mm_add_ps(term[c], _mm_mul_ps(rounding[c], values_in_bound_units_));
          const __m128 allowed = _mm_mul_ps(accuracy_unscaled_, abs_ps(_mm_mul_ps(va[c], vb[c])));
          enough = _mm_and_ps(enough, _mm_cmple_ps(bound, allowed));
        }
        internal &= ~unsigned(_mm_movemask_ps(enough));
      }
      const __m128 leaf_area = _mm_andnot_ps(lanes_of(internal), _mm_set1_ps(area));
      for (int c = 0; c < C; ++c) {
        const __m128 weighted_b = _mm_mul_ps(vb[c], leaf_area);
        sums.value[0][c] = _mm_add_ps(sums.value[0][c], _mm_mul_ps(va[c], weighted_b));
        for (int g = 1; g < GA; ++g) {
          const __m128 vg = load_halves(wa + 1 + 2 * (g * CA + (CA == 1 ? 0 : c)));
          sums.value[g][c] = _mm_add_ps(sums.value[g][c], _mm_mul_ps(vg, weighted_b));
        }
        sums.bound[c] = _mm_add_ps(sums.bound[c], _mm_mul_ps(term[c], leaf_area));
        sums.rounding[c] = _mm_add_ps(sums.rounding[c], _mm_mul_ps(rounding[c], leaf_area));
      }
      if (internal) {
        if (tail - head > kRing - 4) [[unlikely]] {
          // No room: descend this pair's internal quadrants now, each in a nested call.
          for (unsigned q = 0; q < 4; ++q)
            if (internal >> q & 1)
              add(sums, run(first_child(la, q), first_child(lb, q), area * 0.25f, depth + 1));
        } else {
          for (unsigned q = 0; q < 4; ++q)
            if (internal >> q & 1) {
              ring[tail & kMask][0] = first_child(la, q);
              ring[tail & kMask][1] = first_child(lb, q);
              ++tail;
            }
        }
      }
      if (head == tail) break;
      if (head == level_end) {  // the next level starts: quadrants are a quarter the size
        area *= 0.25f;
        level_end = tail;
      }
      na = ring[head & kMask][0];
      nb = ring[head & kMask][1];
      ++head;
    }
    return sums;
  }

  float value_scale() const { return value_scale_; }
  float bound_scale() const { return bound_scale_; }

 private:
  static constexpr unsigned kRing = 256, kMask = kRing - 1;

  static std::uint32_t first_child(std::uint32_t link, unsigned q) {
    return (link >> 4) + std::uint32_t(std::popcount(link & ((1u << q) - 1)));
  }
  static void add(Sums& to, const Sums& from) {
    for (int c = 0; c < C; ++c) {
      for (int g = 0; g < GA; ++g)
        to.value[g][c] = _mm_add_ps(to.value[g][c], from.value[g][c]);
      to.bound[c] = _mm_add_ps(to.bound[c], from.bound[c]);
      to.rounding[c] = _mm_add_ps(to.rounding[c], from.rounding[c]);
    }
  }

  const std::uint32_t* a_;
  const std::uint32_t* b_;
  std::size_t words_a_, words_b_;
  std::size_t codes_a_, codes_b_;  // word offset of the bound codes in a node
  float accuracy_;
  float value_scale_ = 1, bound_scale_ = 1;
  __m128 values_in_bound_units_, linf_a_scale_, linf_b_scale_, accuracy_unscaled_;
};

template <int CA, int CB, int GA, bool kLinfA, bool kLinfB>
GroupConvolution descend_simd(const PackedTreeView& a, const PackedTreeView& b, double accuracy) {
  using Descent = PackedDescent<CA, CB, GA, kLinfA, kLinfB>;
  const Descent descent(a, b, accuracy);
  const typename Descent::Sums sums = descent.run(0, 0, 0.25f, 0);
  GroupConvolution result;
  float lanes[4];
  for (int g = 0; g < GA; ++g) {
    store_lane_sums<Descent::C>(sums.value[g], lanes);
    for (int c = 0; c < 3; ++c)
      result.value[g][c] = lanes[Descent::C == 1 ? 0 : c] * descent.value_scale();
  }
  float rounding[4];
  store_lane_sums<Descent::C>(sums.bound, lanes);
  store_lane_sums<Descent::C>(sums.rounding, rounding);
  for (int c = 0; c < 3; ++c)
    result.bound[c] = lanes[Descent::C == 1 ? 0 : c] * descent.bound_scale() +
                      rounding[Descent::C == 1 ? 0 : c] * descent.value_scale();
  return result;
}

template <int GA>
GroupConvolution dispatch_simd(const PackedTreeView& a, const PackedTreeView& b, double accuracy) {
  const int ca = a.shape().channels, cb = b.shape().channels;
  const bool la = a.shape().bounds == BoundKind::linf, lb = b.shape().bounds == BoundKind::linf;
  auto by_kinds = [&]<int CA, int CB>() {
    if (la && lb) return descend_simd<CA, CB, GA, true, true>(a, b, accuracy);
    if (la) return descend_simd<CA, CB, GA, true, false>(a, b, accuracy);
    if (lb) return descend_simd<CA, CB, GA, false, true>(a, b, accuracy);
    return descend_simd<CA, CB, GA, false, false>(a, b, accuracy);
  };
  if (ca == 1 && cb == 1) return by_kinds.template operator()<1, 1>();
  if (ca == 1) return by_kinds.template operator()<1, 3>();
  if (cb == 1) return by_kinds.template operator()<3, 1>();
  return by_kinds.template operator()<3, 3>();
}

#endif  // BASIS_PACKED_SIMD

GroupConvolution dispatch(const PackedTreeView& a, const PackedTreeView& b, int groups,
                          double accuracy) {
#if defined(BASIS_PACKED_SIMD)
  check_compatible(a.shape(), b.shape());
  switch (groups) {
    case 1:
      return dispatch_simd<1>(a, b, accuracy);
    case 2:
      return dispatch_simd<2>(a, b, accuracy);
    default:
      return dispatch_simd<3>(a, b, accuracy);
  }
#else
  return scalar(a, b, groups, accuracy);
#endif
}

}  // namespace

Convolution convolve(const PackedTreeView& a, const PackedTreeView& b,
                     const ConvolutionOptions& options) {
  const GroupConvolution g = dispatch(a, b, 1, options.accuracy);
  return {g.value[0], g.bound};
}

Convolution convolve_scalar(const PackedTreeView& a, const PackedTreeView& b,
                            const ConvolutionOptions& options) {
  const GroupConvolution g = scalar(a, b, 1, options.accuracy);
  return {g.value[0], g.bound};
}

GroupConvolution convolve_groups(const PackedTreeView& a, const PackedTreeView& b) {
  return dispatch(a, b, std::min(a.shape().groups, 3), 0);
}

GroupConvolution convolve_groups_scalar(const PackedTreeView& a, const PackedTreeView& b) {
  return scalar(a, b, std::min(a.shape().groups, 3), 0);
}

}  // namespace basis
