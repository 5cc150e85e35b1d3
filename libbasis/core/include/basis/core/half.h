// IEEE 754 half-precision floats (binary16), the value type of packed trees: conversion from
// float with rounding to nearest even, and back (exact).
#pragma once

#include <cstdint>

namespace basis {

// The half nearest to f (ties to even); beyond the half range, infinity; NaN stays NaN.
std::uint16_t float_to_half(float f);

// The float equal to half h (every half is exactly a float).
float half_to_float(std::uint16_t h);

}  // namespace basis
