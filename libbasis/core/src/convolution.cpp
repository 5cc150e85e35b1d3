#include "basis/core/convolution.h"
#include "basis/core/gradual_underflow.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "scalar_descent.h"

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace basis {

void throw_beyond_floats(double value) {
  if (std::isnan(value)) throw std::overflow_error("the convolution's value is not a number");
  char text[64];
  std::snprintf(text, sizeof text, "%.3g", value);
  throw std::overflow_error(std::string("the convolution's value (") + text +
                            ") lies beyond what floats hold");
}

namespace {

[[noreturn, gnu::cold, gnu::noinline]] void throw_incompatible(int a, int b) {
  throw std::invalid_argument("cannot convolve trees of " + std::to_string(a) + " and " +
                              std::to_string(b) + " channels");
}

inline void check_compatible(const QuadtreeShape& a, const QuadtreeShape& b) {
  if (a.channels != b.channels && a.channels != 1 && b.channels != 1) [[unlikely]]
    throw_incompatible(a.channels, b.channels);
}

// ---------------------------------------------------------------- portable scalar reference

using detail::ScalarSums;

// How far a float tree's stored average a may lie from its texels' mean (projection.h): half a
// float step, at most 2^-24 |a| (or below 2^-126, the smallest normal float, with subnormals or
// with results flushed to zero; not with subnormal inputs read as zero), plus the double sums'
// 2^-48 of the largest texel, which |a| + ea bounds.
constexpr double kAverageRounding = 0x1p-24, kAverageSumRounding = 0x1p-48,
                 kAverageFloor = 0x1p-126;
inline double average_rounding(double a, double ea) {
  return kAverageRounding * std::abs(a) + kAverageSumRounding * (std::abs(a) + ea) + kAverageFloor;
}

// The bound of a stopped pair of float trees whose averages a, b lie within ra, rb of their
// texels' means (mean_A, mean_B), per unit area:
//   integral of AB - area a b = integral of (A - a)(B - b) + area (a (mean_B - b) + b (mean_A - a))
//     <= ea eb + |a| rb + |b| ra;
//   = integral of (A - a) B + area a (mean_B - b) <= ea (|b| + rb) + |a| rb where B >= 0 (the mean
//     of |B| is then mean_B), and likewise with a and b exchanged where A >= 0.
// The alternatives only where that side is known to be >= 0 (QuadtreeView::non_negative).
auto float_pair_bound(const QuadtreeView& a, const QuadtreeView& b) {
  return [&a, &b](int na, int nb, int ca, int cb, int q, double va, double vb) {
    const double ea = a.error(na, ca, q), eb = b.error(nb, cb, q);
    const double ra = average_rounding(va, ea), rb = average_rounding(vb, eb);
    const double abs_a = std::abs(va), abs_b = std::abs(vb);
    double bound = ea * eb + abs_a * rb + abs_b * ra;
    if (b.non_negative()) bound = std::min(bound, ea * (abs_b + rb) + abs_a * rb);
    if (a.non_negative()) bound = std::min(bound, eb * (abs_a + ra) + abs_b * ra);
    return bound;
  };
}

// How a float-tree descent summed: no accumulator took more than `additions` terms; each term
// was computed to `unit` (a product: 2^-24 in floats; in double, products of floats are exact and
// unit is the sums' own 2^-53), and a bound term in at most four roundings (in double up to seven,
// which float_tree_result's last factor covers); and each term may also have lost `floor` to
// underflow (0 in double).
struct FloatSummation {
  double additions = 0, unit = 0, floor = 0;
};

// A float-tree descent's group-0 sums as a certified result: the value's rounding lies within
// (gamma + unit)(1 + unit) of the magnitudes' sum, gamma = n unit / (1 - n unit) (Higham's bound
// on recursive summation), and the exact bound within 1 / ((1 - 4 unit)(1 - gamma)) of its
// float sum; each term's underflow adds `floor`, four lanes of `additions` terms each, for the
// value and for the bound.
template <typename T>
Convolution float_tree_result(const T* value, const T* bound, const T* magnitude,
                              const FloatSummation& summation, int channels) {
  const double unit = summation.unit;
  const double gamma = detail::summation_gamma(summation.additions, unit);
  const double underflow = 8 * summation.additions * summation.floor;
  std::array<double, 3> v{}, b{};
  for (int c = 0; c < 3; ++c) {
    const int k = channels == 1 ? 0 : c;
    v[std::size_t(c)] = double(value[k]);
    // The last factor covers this line's own double rounding.
    b[std::size_t(c)] =
        (double(bound[k]) + (gamma + unit) * (1 + unit) * double(magnitude[k]) + underflow) /
        ((1 - 4 * unit) * (1 - gamma)) * (1 + 0x1p-40);
  }
  return certified_convolution(v, b);
}

// How the scalar descent sums, in double: one accumulator per channel takes every stopped pair.
FloatSummation scalar_summation(const ScalarSums& sums) {
  return {double(sums.stops) + 2, 0x1p-53, 0};
}

// ---------------------------------------------------------------- SSE path

#if defined(__SSE2__)

inline __m128 abs_ps(__m128 x) {
  return _mm_andnot_ps(_mm_set1_ps(-0.0f), x);
}

// average_rounding of |a| = abs_a and ea in floats, its factors raised by 2^-20 so that the
// float products and sums' rounding cannot bring it below the exact value.
inline __m128 average_rounding_ps(__m128 abs_a, __m128 ea) {
  constexpr double kRaised = 1 + 0x1p-20;
  const __m128 per_value = _mm_set1_ps(float((kAverageRounding + kAverageSumRounding) * kRaised));
  const __m128 per_error = _mm_set1_ps(float(kAverageSumRounding * kRaised));
  return _mm_add_ps(_mm_add_ps(_mm_mul_ps(abs_a, per_value), _mm_mul_ps(ea, per_error)),
                    _mm_set1_ps(float(kAverageFloor * kRaised)));
}

// Lane sums of C accumulators (C = 1 or 3) into out[0..C-1]; out has room for four floats.
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

// Simultaneous descent of a (groups 0..GA-1) and b (group 0). Where either quadrant is a leaf,
// adds a * b * area (masked lanes); queues the quadrants where both trees go on. Pairs are
// taken first-in first-out (breadth first), so that consecutive pairs do not depend on each
// other and their loads overlap, and all pairs of one level share one quadrant area. When the
// ring is full the pending quadrants descend in a nested call.
template <int CA, int CB, int GA, bool kBound>
class SseDescent {
 public:
  static constexpr int C = CA > CB ? CA : CB;
  // Lane sums, and for the bound the lanes' sums of |area a b| of group 0 and how many pairs
  // were visited: what the rounding of the float sums is bounded by (float_tree_result).
  struct Sums {
    __m128 value[GA][C];
    __m128 bound[C];
    __m128 magnitude[C];
    std::uint64_t pairs = 0;
  };

  SseDescent(const QuadtreeView& a, const QuadtreeView& b)
      : nodes_a_(a.nodes().data()),
        nodes_b_(b.nodes().data()),
        errors_a_(a.errors().data()),
        errors_b_(b.errors().data()),
        stride_a_(a.shape().stride()),
        stride_b_(b.shape().stride()),
        error_stride_a_(a.shape().error_stride()),
        error_stride_b_(b.shape().error_stride()),
        non_negative_a_(a.non_negative()),
        non_negative_b_(b.non_negative()) {}

  // Integral over the cell of nodes (root_a, root_b), whose quadrants have area quadrant_area.
  Sums run(std::int32_t root_a, std::int32_t root_b, float quadrant_area, int depth = 0) const {
    if (depth > kMaxTreeLevels) throw std::runtime_error("quadtree deeper than its resolution");
    __m128 value[GA][C], bound[C], magnitude[C];
    for (int c = 0; c < C; ++c) {
      for (int g = 0; g < GA; ++g)
        value[g][c] = _mm_setzero_ps();
      bound[c] = magnitude[c] = _mm_setzero_ps();
    }
    std::uint64_t pairs = 0;
    const Quad* const nodes_a = nodes_a_;
    const Quad* const nodes_b = nodes_b_;
    const std::size_t stride_a = stride_a_, stride_b = stride_b_;
    const __m128i zero = _mm_setzero_si128();

    // Pending pairs as (node a, node b) lanes of 64 bits; the root pair is taken directly.
    alignas(16) std::int64_t ring[kRing];
    unsigned head = 0, tail = 0, level_end = 0;
    float area = quadrant_area;
    std::int32_t na = root_a, nb = root_b;
    for (;;) {
      const Quad* qa = nodes_a + na * stride_a;
      const Quad* qb = nodes_b + nb * stride_b;
      const __m128i links_a = _mm_load_si128(reinterpret_cast<const __m128i*>(qa));
      const __m128i links_b = _mm_load_si128(reinterpret_cast<const __m128i*>(qb));
      const __m128 leaf = _mm_castsi128_ps(
          _mm_or_si128(_mm_cmpeq_epi32(links_a, zero), _mm_cmpeq_epi32(links_b, zero)));
      const __m128 area_all = _mm_set1_ps(area);
      for (int c = 0; c < C; ++c) {
        const __m128 vb = _mm_load_ps(qb[1 + (CB == 1 ? 0 : c)].lane);
        __m128 product_0 = _mm_setzero_ps();  // group 0's, for the magnitudes
        for (int g = 0; g < GA; ++g) {
          const __m128 va = _mm_load_ps(qa[1 + g * CA + (CA == 1 ? 0 : c)].lane);
          // Masked rather than times an area of 0, so that a product beyond the floats on a
          // quadrant that goes on leaves no NaN.
          const __m128 product = _mm_and_ps(leaf, _mm_mul_ps(_mm_mul_ps(va, vb), area_all));
          value[g][c] = _mm_add_ps(value[g][c], product);
          if (g == 0) product_0 = product;
        }
        if constexpr (kBound) {
          const __m128 va = _mm_load_ps(qa[1 + (CA == 1 ? 0 : c)].lane);
          const __m128 ea = _mm_load_ps(errors_a_[na * error_stride_a_ + (CA == 1 ? 0 : c)].lane);
          const __m128 eb = _mm_load_ps(errors_b_[nb * error_stride_b_ + (CB == 1 ? 0 : c)].lane);
          // float_pair_bound, its constants raised by 2^-20 for their own float rounding.
          const __m128 abs_a = abs_ps(va), abs_b = abs_ps(vb);
          const __m128 ra = average_rounding_ps(abs_a, ea), rb = average_rounding_ps(abs_b, eb);
          const __m128 a_rb = _mm_mul_ps(abs_a, rb), b_ra = _mm_mul_ps(abs_b, ra);
          __m128 term = _mm_add_ps(_mm_mul_ps(ea, eb), _mm_add_ps(a_rb, b_ra));
          if (non_negative_b_)
            term = _mm_min_ps(term, _mm_add_ps(_mm_mul_ps(ea, _mm_add_ps(abs_b, rb)), a_rb));
          if (non_negative_a_)
            term = _mm_min_ps(term, _mm_add_ps(_mm_mul_ps(eb, _mm_add_ps(abs_a, ra)), b_ra));
          bound[c] = _mm_add_ps(bound[c], _mm_and_ps(leaf, _mm_mul_ps(term, area_all)));
          magnitude[c] = _mm_add_ps(magnitude[c], abs_ps(product_0));
        }
      }
      ++pairs;
      const int internal = ~_mm_movemask_ps(leaf) & 0xF;
      if (internal)
        enqueue(internal, links_a, links_b, ring, head, tail, area, depth, value, bound, magnitude,
                pairs);
      if (head == tail) break;
      if (head == level_end) {  // the next level starts: quadrants are a quarter the size
        area *= 0.25f;
        level_end = tail;
      }
      const __m128i pair = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(&ring[head++ & kMask]));
      na = _mm_cvtsi128_si32(pair);
      nb = _mm_cvtsi128_si32(_mm_srli_si128(pair, 4));
    }
    Sums sums;
    for (int c = 0; c < C; ++c) {
      for (int g = 0; g < GA; ++g)
        sums.value[g][c] = value[g][c];
      sums.bound[c] = bound[c];
      sums.magnitude[c] = magnitude[c];
    }
    sums.pairs = pairs;
    return sums;
  }

 private:
  static constexpr unsigned kRing = 128, kMask = kRing - 1;

  // Queues the internal quadrants of a pair whose quadrants have the given area; when the ring
  // has no room, descends them in nested calls and adds their sums.
  [[gnu::always_inline]] void enqueue(int internal, __m128i links_a, __m128i links_b,
                                      std::int64_t* ring, unsigned head, unsigned& tail, float area,
                                      int depth, __m128 (&value)[GA][C], __m128 (&bound)[C],
                                      __m128 (&magnitude)[C], std::uint64_t& pairs) const {
    const __m128i low = _mm_unpacklo_epi32(links_a, links_b);   // (a0 b0) (a1 b1)
    const __m128i high = _mm_unpackhi_epi32(links_a, links_b);  // (a2 b2) (a3 b3)
    if (tail - head > kRing - 4) [[unlikely]] {
      const Sums nested = descend_now(internal, low, high, area * 0.25f, depth + 1);
      for (int c = 0; c < C; ++c) {
        for (int g = 0; g < GA; ++g)
          value[g][c] = _mm_add_ps(value[g][c], nested.value[g][c]);
        bound[c] = _mm_add_ps(bound[c], nested.bound[c]);
        magnitude[c] = _mm_add_ps(magnitude[c], nested.magnitude[c]);
      }
      pairs += nested.pairs;
      return;
    }
    // Branchless enqueue: every quadrant is written, the tail passes internal ones only.
    auto slot = [&] { return reinterpret_cast<__m128i*>(&ring[tail & kMask]); };
    _mm_storel_epi64(slot(), low);
    tail += internal & 1;
    _mm_storel_epi64(slot(), _mm_srli_si128(low, 8));
    tail += (internal >> 1) & 1;
    _mm_storel_epi64(slot(), high);
    tail += (internal >> 2) & 1;
    _mm_storel_epi64(slot(), _mm_srli_si128(high, 8));
    tail += (internal >> 3) & 1;
  }

  // Sums of the internal quadrants' pairs, each descended by its own call.
  [[gnu::noinline]] Sums descend_now(int internal, __m128i low, __m128i high, float area,
                                     int depth) const {
    alignas(16) std::int32_t pairs[8];
    _mm_store_si128(reinterpret_cast<__m128i*>(pairs), low);
    _mm_store_si128(reinterpret_cast<__m128i*>(pairs + 4), high);
    Sums total{};
    for (int q = 0; q < 4; ++q)
      if (internal >> q & 1) {
        const Sums nested = run(pairs[2 * q], pairs[2 * q + 1], area, depth);
        for (int c = 0; c < C; ++c) {
          for (int g = 0; g < GA; ++g)
            total.value[g][c] = _mm_add_ps(total.value[g][c], nested.value[g][c]);
          total.bound[c] = _mm_add_ps(total.bound[c], nested.bound[c]);
          total.magnitude[c] = _mm_add_ps(total.magnitude[c], nested.magnitude[c]);
        }
        total.pairs += nested.pairs;
      }
    return total;
  }

  const Quad* nodes_a_;
  const Quad* nodes_b_;
  const Quad* errors_a_;
  const Quad* errors_b_;
  std::size_t stride_a_, stride_b_;
  std::size_t error_stride_a_, error_stride_b_;
  bool non_negative_a_, non_negative_b_;
};

// A float descent's channel sums: values per group, and for the bound its sum, the sum of
// |area a b| and the pairs visited (float_tree_result).
template <int GA>
struct FloatSums {
  float value[GA][4] = {};
  float bound[4] = {}, magnitude[4] = {};
  std::uint64_t pairs = 0;
};

// Whether group g's float sums stayed finite: a product of two texels beyond the floats (from
// about 1.8e19 each) leaves them, even where the integral does not; the scalar descent, in
// double, then takes over. (A bound or magnitude beyond the floats makes the bound +infinity:
// float_tree_result.)
template <int GA>
bool finite_values(const FloatSums<GA>& sums, int g) {
  bool finite = true;
  for (int k = 0; k < 4; ++k)
    finite = finite && std::isfinite(sums.value[g][k]);
  return finite;
}

// How the SSE descent sums, in floats: a lane takes a pair's term or none per pair, and sums of
// nested descents (each after dozens of its own pairs) and the lanes' sums add fewer than as many
// again; a term below the normal floats may lose up to 2^-125 (subnormal or flushed to zero).
template <int GA>
FloatSummation sse_summation(const FloatSums<GA>& sums) {
  return {2 * double(sums.pairs) + 8, 0x1p-24, 0x1p-125};
}

template <int CA, int CB, int GA, bool kBound>
void descend_sse(const QuadtreeView& a, const QuadtreeView& b, FloatSums<GA>& out) {
  using Descent = SseDescent<CA, CB, GA, kBound>;
  const typename Descent::Sums sums = Descent(a, b).run(0, 0, 0.25f);
  for (int g = 0; g < GA; ++g)
    store_lane_sums<Descent::C>(sums.value[g], out.value[g]);
  if constexpr (kBound) {
    store_lane_sums<Descent::C>(sums.bound, out.bound);
    store_lane_sums<Descent::C>(sums.magnitude, out.magnitude);
    out.pairs = sums.pairs;
  }
}

template <int GA, bool kBound>
void dispatch_sse(const QuadtreeView& a, const QuadtreeView& b, FloatSums<GA>& out) {
  const int ca = a.shape().channels, cb = b.shape().channels;
  if (ca == 1 && cb == 1) return descend_sse<1, 1, GA, kBound>(a, b, out);
  if (ca == 1) return descend_sse<1, 3, GA, kBound>(a, b, out);
  if (cb == 1) return descend_sse<3, 1, GA, kBound>(a, b, out);
  return descend_sse<3, 3, GA, kBound>(a, b, out);
}

#endif  // __SSE2__

// ---------------------------------------------------------------- N-ary product

struct FactorState {
  int node;        // node index, or -1 once the factor is constant over the cell
  float value[3];  // the factor's value when constant
};

constexpr int kMaxFactors = 8;

void descend_product(std::span<const QuadtreeView> factors, const FactorState* states, double area,
                     int channels, double (&sum)[3]) {
  const int k = int(factors.size());
  for (int q = 0; q < 4; ++q) {
    FactorState next[kMaxFactors];
    int internal = 0;
    for (int f = 0; f < k; ++f) {
      next[f] = states[f];
      if (states[f].node < 0) continue;
      const QuadtreeView& t = factors[f];
      const int nc = t.shape().channels;
      for (int c = 0; c < 3; ++c)
        next[f].value[c] = t.value(states[f].node, 0, nc == 1 ? 0 : c, q);
      const int child = t.child(states[f].node, q);
      next[f].node = child ? child : -1;
      internal += child != 0;
    }
    // With at most one factor still refined, its quadrant average is exact for the integral.
    if (internal <= 1) {
      for (int c = 0; c < channels; ++c) {
        double product = area;
        for (int f = 0; f < k; ++f)
          product *= next[f].value[c];
        sum[c] += product;
      }
      continue;
    }
    descend_product(factors, next, area / 4, channels, sum);
  }
}

}  // namespace

GroupConvolution convolve_groups_scalar(const QuadtreeView& a, const QuadtreeView& b) {
  const GradualUnderflow gradual_underflow;
  check_compatible(a.shape(), b.shape());
  const int channels = std::max(a.shape().channels, b.shape().channels);
  const int groups = std::min(a.shape().groups, 3);
  ScalarSums sums;
  detail::descend_scalar(a, b, 0, 0, 0.25, channels, groups, {}, float_pair_bound(a, b), sums);
  GroupConvolution result;
  for (int g = 0; g < groups; ++g)
    result.value[g] = channels_to_rgb(sums.value[g], channels);
  result.bound =
      float_tree_result(sums.value[0], sums.bound, sums.magnitude, scalar_summation(sums), channels)
          .bound;
  return result;
}

Convolution convolve_scalar(const QuadtreeView& a, const QuadtreeView& b) {
  const GradualUnderflow gradual_underflow;
  check_compatible(a.shape(), b.shape());
  const int channels = std::max(a.shape().channels, b.shape().channels);
  ScalarSums sums;
  detail::descend_scalar(a, b, 0, 0, 0.25, channels, 1, {}, float_pair_bound(a, b), sums);
  return float_tree_result(sums.value[0], sums.bound, sums.magnitude, scalar_summation(sums),
                           channels);
}

Convolution convolve(const QuadtreeView& a, const QuadtreeView& b) {
  const GradualUnderflow gradual_underflow;
#if defined(__SSE2__)
  check_compatible(a.shape(), b.shape());
  const int channels = std::max(a.shape().channels, b.shape().channels);
  FloatSums<1> sums;
  dispatch_sse<1, true>(a, b, sums);
  if (!finite_values(sums, 0)) return convolve_scalar(a, b);
  return float_tree_result(sums.value[0], sums.bound, sums.magnitude, sse_summation(sums),
                           channels);
#else
  return convolve_scalar(a, b);
#endif
}

Rgb convolve_value(const QuadtreeView& a, const QuadtreeView& b) {
  const GradualUnderflow gradual_underflow;
  check_compatible(a.shape(), b.shape());
  const int channels = std::max(a.shape().channels, b.shape().channels);
#if defined(__SSE2__)
  FloatSums<1> sums;
  dispatch_sse<1, false>(a, b, sums);
  if (finite_values(sums, 0)) return channels_to_rgb(sums.value[0], channels);
#endif
  // In double: a value beyond the floats is infinite here, not an error.
  ScalarSums scalar;
  detail::descend_scalar(a, b, 0, 0, 0.25, channels, 1, {}, float_pair_bound(a, b), scalar);
  return channels_to_rgb(scalar.value[0], channels);
}

GroupConvolution convolve_groups(const QuadtreeView& a, const QuadtreeView& b) {
  const GradualUnderflow gradual_underflow;
#if defined(__SSE2__)
  check_compatible(a.shape(), b.shape());
  const int channels = std::max(a.shape().channels, b.shape().channels);
  // Group 0 and the bound as convolve() gives them; a group whose float sums left the floats
  // from the scalar descent.
  GroupConvolution result;
  bool finite = true;
  auto run = [&]<int G>() {
    FloatSums<G> sums;
    dispatch_sse<G, true>(a, b, sums);
    finite = finite_values(sums, 0);
    if (!finite) return;
    std::optional<GroupConvolution> scalar;
    for (int g = 0; g < G; ++g) {
      if (finite_values(sums, g)) {
        result.value[g] = channels_to_rgb(sums.value[g], channels);
        continue;
      }
      if (!scalar) scalar = convolve_groups_scalar(a, b);
      result.value[g] = scalar->value[g];
    }
    result.bound =
        float_tree_result(sums.value[0], sums.bound, sums.magnitude, sse_summation(sums), channels)
            .bound;
  };
  switch (a.shape().groups) {
    case 1:
      run.operator()<1>();
      break;
    case 2:
      run.operator()<2>();
      break;
    default:
      run.operator()<3>();
  }
  if (finite) return result;
#endif
  return convolve_groups_scalar(a, b);
}

Rgb convolve_product(std::span<const QuadtreeView> factors) {
  const GradualUnderflow gradual_underflow;
  if (factors.empty() || factors.size() > kMaxFactors)
    throw std::invalid_argument("a product takes 1 to " + std::to_string(kMaxFactors) +
                                " trees, got " + std::to_string(factors.size()));
  int channels = 1;
  for (const QuadtreeView& f : factors) {
    check_compatible(factors[0].shape(), f.shape());
    channels = std::max(channels, f.shape().channels);
  }
  for (const QuadtreeView& f : factors)
    if (f.shape().channels != 1 && f.shape().channels != channels)
      throw std::invalid_argument("product factors mix incompatible channel counts");
  FactorState roots[kMaxFactors];
  for (std::size_t f = 0; f < factors.size(); ++f)
    roots[f] = {0, {1, 1, 1}};
  double sum[3] = {};
  descend_product(factors, roots, 0.25, channels, sum);
  return channels_to_rgb(sum, channels);
}

}  // namespace basis
