// Shared-exponent RGB words: three non-negative channels in 32 bits, a 9-bit mantissa each and
// one 5-bit exponent for all three (the layout of GL's RGB9_E5). Channel c of word w is
// ((w >> 9c) & 511) x 2^((w >> 27) - 24): from 2^-24 to just under 2^16, in whatever unit the
// caller scales by. The exact texels of RGB captures are stored so (4 bytes a texel, not 6).
#pragma once

#include <array>
#include <bit>
#include <cstdint>

namespace basis {

inline constexpr int kSharedMantissaBits = 9, kSharedExponentBias = 24;

// The step of word w's mantissas: 2^(exponent - 24). A channel lies within half a step of what
// it rounds.
inline float shared_exponent_step(std::uint32_t w) {
  return std::bit_cast<float>(((w >> 27) + 127u - std::uint32_t(kSharedExponentBias)) << 23);
}

// Channel c (0..2) of word w.
inline float shared_exponent_channel(std::uint32_t w, int c) {
  return float(w >> (kSharedMantissaBits * c) & 511u) * shared_exponent_step(w);
}

// The word nearest to rgb: the smallest exponent whose step keeps every mantissa within 9 bits,
// each channel rounded to the nearest step. Channels must be finite, >= 0 and below 2^15
// (std::invalid_argument otherwise). Each channel then moves at most half a step, and the step
// is at most 1 / 255.75 of the largest channel (2^-8 unless it rounds up to 512), or 2^-24.
std::uint32_t encode_shared_exponent(const std::array<float, 3>& rgb);

}  // namespace basis
