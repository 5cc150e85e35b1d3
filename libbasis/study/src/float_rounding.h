// Rounding doubles up to floats, so that bounds computed in doubles stay bounds in floats.
#pragma once

#include <cmath>
#include <limits>

namespace basis {

// A double rounded up to a float.
inline float round_up(double x) {
  float f = float(x);
  if (double(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

}  // namespace basis
