#include "basis/study/first_order_lookups.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace basis {

FirstOrderLookupCounts count_first_order_lookups(
    std::span<const Rgb> references,
    const std::function<FirstOrderConvolution(std::size_t)>& lookup) {
  double largest = 0;
  for (const Rgb& reference : references)
    for (const float e : reference)
      largest = std::max(largest, double(e));
  FirstOrderLookupCounts counts;
  std::vector<double> errors, bounds;
  for (std::size_t k = 0; k < references.size(); ++k) {
    const FirstOrderConvolution r = lookup(k);
    counts.pairs += double(r.pairs);
    for (std::size_t c = 0; c < 3; ++c) {
      const double reference = references[k][c];
      const double error = std::abs(double(r.convolution.value[c]) - reference);
      if (error > double(r.convolution.bound[c])) ++counts.bound_failures;
      if (reference > 1e-3 * largest) {
        errors.push_back(error / reference);
        bounds.push_back(double(r.convolution.bound[c]) / reference);
      }
    }
  }
  if (!references.empty()) counts.pairs /= double(references.size());
  std::sort(errors.begin(), errors.end());
  std::sort(bounds.begin(), bounds.end());
  const auto percent_at = [](const std::vector<double>& v, double p) {
    return v.empty() ? 0.0 : 100 * v[std::min(v.size() - 1, std::size_t(p * double(v.size())))];
  };
  counts.error_median = percent_at(errors, 0.5);
  counts.error_p99 = percent_at(errors, 0.99);
  counts.bound_median = percent_at(bounds, 0.5);
  counts.bound_p99 = percent_at(bounds, 0.99);
  return counts;
}

std::array<double, 3> capture_tolerances(const Grid& texels,
                                         std::span<const DirectionalLight> lights,
                                         double tolerance) {
  const Color lights_mean = mean_of_lights(lights);
  std::array<double, 3> tolerances{};
  for (int c = 0; c < 3; ++c) {
    double sum = 0;
    for (int y = 0; y < texels.resolution; ++y)
      for (int x = 0; x < texels.resolution; ++x)
        sum += texels.at(0, std::min(c, texels.channels - 1), x, y);
    const double mean =
        sum / (double(texels.resolution) * texels.resolution) + lights_mean[std::size_t(c)];
    tolerances[std::size_t(c)] = tolerance * std::abs(mean);
  }
  return tolerances;
}

}  // namespace basis
