#include "basis/core/shared_exponent.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace basis {
namespace {

// 2^k, exactly, for the exponents a word's step takes (-8 to 24), without a call to ldexp.
double power_of_two(int k) {
  return std::bit_cast<double>(std::uint64_t(1023 + k) << 52);
}

// std::ilogb of a float: from its bits where it is normal (a call only for subnormals).
int float_exponent(float v) {
  const int biased = int(std::bit_cast<std::uint32_t>(v) >> 23 & 0xffu);
  return biased != 0 ? biased - 127 : std::ilogb(v);
}

}  // namespace

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
  int exponent =
      largest > 0 ? std::clamp(float_exponent(largest) - 8 + kSharedExponentBias, 0, 31) : 0;
  // v over the step 2^(exponent - 24), as a product by its inverse: both exact in double.
  double inverse_step = power_of_two(kSharedExponentBias - exponent);
  auto mantissa = [&](float v) { return std::uint32_t(std::nearbyint(double(v) * inverse_step)); };
  if (mantissa(largest) > 511) inverse_step = power_of_two(kSharedExponentBias - ++exponent);
  std::uint32_t word = std::uint32_t(exponent) << 27;
  for (int c = 0; c < 3; ++c)
    word |= mantissa(rgb[std::size_t(c)]) << (kSharedMantissaBits * c);
  return word;
}

}  // namespace basis
