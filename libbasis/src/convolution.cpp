#include "basis/convolution.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace basis {

namespace {

void check_compatible(const QuadtreeShape& a, const QuadtreeShape& b) {
  if (a.channels != b.channels && a.channels != 1 && b.channels != 1)
    throw std::invalid_argument("cannot convolve trees of " + std::to_string(a.channels) + " and " +
                                std::to_string(b.channels) + " channels");
}

// Result lanes: a one-channel result is repeated in all three lanes.
template <typename T>
Rgb to_rgb(const T (&v)[3], int channels) {
  return channels == 1 ? Rgb{float(v[0]), float(v[0]), float(v[0])}
                       : Rgb{float(v[0]), float(v[1]), float(v[2])};
}

// ---------------------------------------------------------------- portable scalar reference

struct ScalarSums {
  double value[3] = {};
  double bound[3] = {};
};

void descend_scalar(const QuadtreeView& a, const QuadtreeView& b, int na, int nb, double area,
                    int channels, ScalarSums& sums) {
  const int ca_count = a.shape().channels, cb_count = b.shape().channels;
  for (int q = 0; q < 4; ++q) {
    const int child_a = a.child(na, q), child_b = b.child(nb, q);
    if (child_a && child_b) {
      descend_scalar(a, b, child_a, child_b, area / 4, channels, sums);
      continue;
    }
    for (int c = 0; c < channels; ++c) {
      const int ca = ca_count == 1 ? 0 : c, cb = cb_count == 1 ? 0 : c;
      const double va = a.value(na, 0, ca, q), vb = b.value(nb, 0, cb, q);
      const double ea = a.error(na, ca, q), eb = b.error(nb, cb, q);
      sums.value[c] += va * vb * area;
      sums.bound[c] += area * std::min({ea * eb, ea * std::abs(vb), eb * std::abs(va)});
    }
  }
}

// ---------------------------------------------------------------- SSE path

#if defined(__SSE2__)

struct StackEntry {
  std::int32_t a, b;
  float area;
};
// A pop pushes at most four entries and trees are at most kMaxTreeLevels deep.
constexpr int kStackSize = 4 * kMaxTreeLevels + 8;

inline __m128 abs_ps(__m128 x) {
  return _mm_andnot_ps(_mm_set1_ps(-0.0f), x);
}

inline float horizontal_sum(__m128 v) {
  alignas(16) float lanes[4];
  _mm_store_ps(lanes, v);
  return (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
}

// Simultaneous descent of a (groups 0..GA-1) and b (group 0). Where either quadrant is a leaf,
// adds a * b * area (masked lanes); pushes the quadrants where both trees go on.
template <int CA, int CB, int GA, bool kBound>
void descend_sse(const QuadtreeView& a, const QuadtreeView& b, float (&value)[GA][3],
                 float (&bound)[3]) {
  constexpr int C = CA > CB ? CA : CB;
  const Quad* nodes_a = a.nodes().data();
  const Quad* nodes_b = b.nodes().data();
  const Quad* errors_a = a.errors().data();
  const Quad* errors_b = b.errors().data();
  const std::size_t stride_a = a.shape().stride(), stride_b = b.shape().stride();

  __m128 acc[GA][C];
  __m128 bound_acc[C];
  for (int c = 0; c < C; ++c) {
    for (int g = 0; g < GA; ++g)
      acc[g][c] = _mm_setzero_ps();
    bound_acc[c] = _mm_setzero_ps();
  }
  const __m128i zero = _mm_setzero_si128();

  StackEntry stack[kStackSize];
  int top = 0;
  stack[top++] = {0, 0, 0.25f};
  while (top > 0) {
    const StackEntry e = stack[--top];
    const Quad* qa = nodes_a + e.a * stride_a;
    const Quad* qb = nodes_b + e.b * stride_b;
    const __m128i links_a = _mm_load_si128(reinterpret_cast<const __m128i*>(qa));
    const __m128i links_b = _mm_load_si128(reinterpret_cast<const __m128i*>(qb));
    const __m128 leaf = _mm_castsi128_ps(
        _mm_or_si128(_mm_cmpeq_epi32(links_a, zero), _mm_cmpeq_epi32(links_b, zero)));
    const __m128 leaf_area = _mm_and_ps(leaf, _mm_set1_ps(e.area));
    for (int c = 0; c < C; ++c) {
      const __m128 vb = _mm_load_ps(qb[1 + (CB == 1 ? 0 : c)].lane);
      for (int g = 0; g < GA; ++g) {
        const __m128 va = _mm_load_ps(qa[1 + g * CA + (CA == 1 ? 0 : c)].lane);
        acc[g][c] = _mm_add_ps(acc[g][c], _mm_mul_ps(_mm_mul_ps(va, vb), leaf_area));
      }
      if constexpr (kBound) {
        const __m128 va = _mm_load_ps(qa[1 + (CA == 1 ? 0 : c)].lane);
        const __m128 ea = _mm_load_ps(errors_a[e.a * CA + (CA == 1 ? 0 : c)].lane);
        const __m128 eb = _mm_load_ps(errors_b[e.b * CB + (CB == 1 ? 0 : c)].lane);
        const __m128 term = _mm_min_ps(
            _mm_mul_ps(ea, eb), _mm_min_ps(_mm_mul_ps(ea, abs_ps(vb)), _mm_mul_ps(eb, abs_ps(va))));
        bound_acc[c] = _mm_add_ps(bound_acc[c], _mm_mul_ps(term, leaf_area));
      }
    }
    int internal = ~_mm_movemask_ps(leaf) & 0xF;
    if (!internal) continue;
    if (top + 4 > kStackSize) throw std::runtime_error("quadtree deeper than its resolution");
    alignas(16) std::int32_t child_a[4], child_b[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(child_a), links_a);
    _mm_store_si128(reinterpret_cast<__m128i*>(child_b), links_b);
    const float child_area = e.area * 0.25f;
    do {
      const int q = __builtin_ctz(unsigned(internal));
      internal &= internal - 1;
      stack[top++] = {child_a[q], child_b[q], child_area};
    } while (internal);
  }
  for (int c = 0; c < C; ++c) {
    for (int g = 0; g < GA; ++g)
      value[g][c] = horizontal_sum(acc[g][c]);
    bound[c] = horizontal_sum(bound_acc[c]);
  }
}

template <int GA, bool kBound>
void dispatch_sse(const QuadtreeView& a, const QuadtreeView& b, float (&value)[GA][3],
                  float (&bound)[3]) {
  const int ca = a.shape().channels, cb = b.shape().channels;
  if (ca == 1 && cb == 1) return descend_sse<1, 1, GA, kBound>(a, b, value, bound);
  if (ca == 1) return descend_sse<1, 3, GA, kBound>(a, b, value, bound);
  if (cb == 1) return descend_sse<3, 1, GA, kBound>(a, b, value, bound);
  return descend_sse<3, 3, GA, kBound>(a, b, value, bound);
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

bool convolution_uses_simd() {
#if defined(__SSE2__)
  return true;
#else
  return false;
#endif
}

Convolution convolve_scalar(const QuadtreeView& a, const QuadtreeView& b) {
  check_compatible(a.shape(), b.shape());
  const int channels = std::max(a.shape().channels, b.shape().channels);
  ScalarSums sums;
  descend_scalar(a, b, 0, 0, 0.25, channels, sums);
  return {to_rgb(sums.value, channels), to_rgb(sums.bound, channels)};
}

Convolution convolve(const QuadtreeView& a, const QuadtreeView& b) {
#if defined(__SSE2__)
  check_compatible(a.shape(), b.shape());
  const int channels = std::max(a.shape().channels, b.shape().channels);
  float value[1][3] = {}, bound[3] = {};
  dispatch_sse<1, true>(a, b, value, bound);
  return {to_rgb(value[0], channels), to_rgb(bound, channels)};
#else
  return convolve_scalar(a, b);
#endif
}

Rgb convolve_value(const QuadtreeView& a, const QuadtreeView& b) {
#if defined(__SSE2__)
  check_compatible(a.shape(), b.shape());
  const int channels = std::max(a.shape().channels, b.shape().channels);
  float value[1][3] = {}, bound[3] = {};
  dispatch_sse<1, false>(a, b, value, bound);
  return to_rgb(value[0], channels);
#else
  return convolve_scalar(a, b).value;
#endif
}

std::array<Rgb, 3> convolve_groups(const QuadtreeView& a, const QuadtreeView& b) {
  check_compatible(a.shape(), b.shape());
  const int channels = std::max(a.shape().channels, b.shape().channels);
  std::array<Rgb, 3> result{};
#if defined(__SSE2__)
  float bound[3] = {};
  switch (a.shape().groups) {
    case 1: {
      float value[1][3] = {};
      dispatch_sse<1, false>(a, b, value, bound);
      result[0] = to_rgb(value[0], channels);
      break;
    }
    case 2: {
      float value[2][3] = {};
      dispatch_sse<2, false>(a, b, value, bound);
      for (int g = 0; g < 2; ++g)
        result[g] = to_rgb(value[g], channels);
      break;
    }
    default: {
      float value[3][3] = {};
      dispatch_sse<3, false>(a, b, value, bound);
      for (int g = 0; g < 3; ++g)
        result[g] = to_rgb(value[g], channels);
      break;
    }
  }
#else
  // Portable path: one scalar descent per group over a view that starts at that group.
  for (int g = 0; g < a.shape().groups; ++g) {
    double sum[3] = {};
    auto visit = [&](auto&& self, int na, int nb, double area) -> void {
      for (int q = 0; q < 4; ++q) {
        const int ca = a.child(na, q), cb = b.child(nb, q);
        if (ca && cb) {
          self(self, ca, cb, area / 4);
          continue;
        }
        for (int c = 0; c < channels; ++c)
          sum[c] += area * a.value(na, g, a.shape().channels == 1 ? 0 : c, q) *
                    b.value(nb, 0, b.shape().channels == 1 ? 0 : c, q);
      }
    };
    visit(visit, 0, 0, 0.25);
    result[g] = to_rgb(sum, channels);
  }
#endif
  return result;
}

Rgb convolve_product(std::span<const QuadtreeView> factors) {
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
  return to_rgb(sum, channels);
}

}  // namespace basis
