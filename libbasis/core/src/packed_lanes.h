// Packed values and bound codes as SSE lanes: what the SIMD descents and the fold decode. Private
// to the core library; needs SSE4.1 and F16C.
#pragma once

#include <immintrin.h>

#include <cstdint>

#include "basis/core/packed_tree.h"

namespace basis::detail {

// The four halves at p as floats (exactly).
inline __m128 load_halves(const void* p) {
  return _mm_cvtph_ps(_mm_loadl_epi64(static_cast<const __m128i*>(p)));
}

// The four bound codes of the word at p as the floats they stand for (before the tree's scale):
// their float bits are (code << 20) + kBoundCodeBias (packed_tree.h).
inline __m128 load_bound_codes(const std::uint32_t* p) {
  const __m128i codes = _mm_cvtepu8_epi32(_mm_cvtsi32_si128(int(*p)));
  return _mm_castsi128_ps(
      _mm_add_epi32(_mm_slli_epi32(codes, 20), _mm_set1_epi32(int(kBoundCodeBias))));
}

// |x| in each lane (the sign bit cleared).
inline __m128 abs_ps(__m128 x) {
  return _mm_andnot_ps(_mm_set1_ps(-0.0f), x);
}

}  // namespace basis::detail
