#include "basis/core/shared_exponent.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace basis {

std::uint32_t encode_shared_exponent(const std::array<float, 3>& rgb) {
  for (const float v : rgb)
    if (!(v >= 0 && v < 0x1p15f))
      throw std::invalid_argument(
          "a shared-exponent channel is negative, not finite or 2^15 or "
          "more: " +
          std::to_string(v));
  const float largest = std::max({rgb[0], rgb[1], rgb[2]});
  // The largest channel in [2^k, 2^(k+1)) takes mantissas from 256 on at exponent k - 8 + 24,
  // one more when it rounds up to 512; below 2^-16 the smallest exponent.
  int exponent = largest > 0 ? std::clamp(std::ilogb(largest) - 8 + kSharedExponentBias, 0, 31) : 0;
  auto mantissa = [&](float v) {
    return std::uint32_t(
        std::nearbyint(double(v) / std::ldexp(1.0, exponent - kSharedExponentBias)));
  };
  if (mantissa(largest) > 511) ++exponent;
  std::uint32_t word = std::uint32_t(exponent) << 27;
  for (int c = 0; c < 3; ++c)
    word |= mantissa(rgb[std::size_t(c)]) << (kSharedMantissaBits * c);
  return word;
}

}  // namespace basis
