// Linear RGB colours. Color (double) holds radiance, BRDF values and energies as they are
// computed; Rgb (float) holds what trees store and convolutions return.
#pragma once

#include <array>

namespace basis {

using Color = std::array<double, 3>;
using Rgb = std::array<float, 3>;

// Rec. 709 luminance of a linear RGB colour.
inline double luminance(const Color& rgb) {
  return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

// The first `channels` (1 or 3) values as RGB: one channel stands for all three.
template <typename T>
Rgb channels_to_rgb(const T* values, int channels) {
  return channels == 1 ? Rgb{float(values[0]), float(values[0]), float(values[0])}
                       : Rgb{float(values[0]), float(values[1]), float(values[2])};
}

}  // namespace basis
