// MERL files written by the tests: the 90 x 90 x 180 header and three channels of doubles.
#pragma once

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace basis::testing {

inline constexpr std::size_t kMerlSamples = 3 * std::size_t(90) * 90 * 180;

// Writes `samples` (kMerlSamples doubles, red then green then blue) as a MERL file.
inline void write_merl_samples(const std::string& path, const std::vector<double>& samples) {
  std::ofstream out(path, std::ios::binary);
  const std::int32_t dims[3] = {90, 90, 180};
  out.write(reinterpret_cast<const char*>(dims), sizeof dims);
  out.write(reinterpret_cast<const char*>(samples.data()),
            std::streamsize(samples.size() * sizeof(double)));
}

}  // namespace basis::testing
