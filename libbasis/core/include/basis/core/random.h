// Counter-based random numbers: a value depends only on its counter, so that results are the
// same whatever order or thread computes them (SplitMix64, Steele, Lea and Flood 2014).
#pragma once

#include <cstdint>

namespace basis {

// A 64-bit hash of x (the SplitMix64 output function applied after one increment).
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// A number in [0, 1) from the counter x, with 53 random bits.
inline double unit_random(std::uint64_t x) {
  return double(splitmix64(x) >> 11) * 0x1.0p-53;
}

}  // namespace basis
