#include "basis/core/half.h"

#include <bit>

namespace basis {

std::uint16_t float_to_half(float f) {
  const std::uint32_t bits = std::bit_cast<std::uint32_t>(f);
  const std::uint32_t sign = (bits >> 16) & 0x8000u;
  const std::uint32_t magnitude = bits & 0x7fffffffu;
  if (magnitude >= 0x7f800000u)  // infinity, or NaN (kept quiet, payload's top bits)
    return std::uint16_t(sign | 0x7c00u |
                         (magnitude > 0x7f800000u ? 0x200u | (magnitude >> 13) : 0));
  if (magnitude >= 0x477ff000u) return std::uint16_t(sign | 0x7c00u);  // rounds past 65504
  if (magnitude >= 0x38800000u) {  // a normal half: rebias the exponent, round the mantissa
    const std::uint32_t rebiased = magnitude - 0x38000000u;
    const std::uint32_t round = 0xfffu + ((rebiased >> 13) & 1u);
    return std::uint16_t(sign | ((rebiased + round) >> 13));
  }
  if (magnitude < 0x33000000u) return std::uint16_t(sign);  // below half the smallest subnormal
  // A subnormal half: shift the mantissa with its implicit one into place, rounding to even.
  const std::uint32_t exponent = magnitude >> 23;
  const std::uint32_t mantissa = (magnitude & 0x7fffffu) | 0x800000u;
  const std::uint32_t shift = 126 - exponent;  // 14 .. 24
  const std::uint32_t kept = mantissa >> shift;
  const std::uint32_t rest = mantissa & ((1u << shift) - 1);
  const std::uint32_t half_way = 1u << (shift - 1);
  const std::uint32_t up = rest > half_way || (rest == half_way && (kept & 1u));
  return std::uint16_t(sign | (kept + up));
}

float half_to_float(std::uint16_t h) {
  const std::uint32_t sign = std::uint32_t(h & 0x8000u) << 16;
  const std::uint32_t exponent = (h >> 10) & 0x1fu;
  const std::uint32_t mantissa = h & 0x3ffu;
  if (exponent == 0x1f) return std::bit_cast<float>(sign | 0x7f800000u | (mantissa << 13));
  if (exponent != 0)
    return std::bit_cast<float>(sign | ((exponent + 112) << 23) | (mantissa << 13));
  // Zero or subnormal: mantissa x 2^-24, exact in float.
  const float value = float(mantissa) * 0x1p-24f;
  return sign ? -value : value;
}

}  // namespace basis
