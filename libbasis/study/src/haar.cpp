#include "basis/study/haar.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace basis {

namespace {

// In-place non-standard 2D Haar transform of an n x n plane (orthonormal): at each level the
// 2 x 2 blocks become (sum, horizontal, vertical, diagonal) / 2, the sums going on.
void forward(std::vector<double>& p, int n) {
  std::vector<double> t(p.size());
  for (int size = n; size > 1; size /= 2) {
    const int half = size / 2;
    for (int y = 0; y < half; ++y)
      for (int x = 0; x < half; ++x) {
        const double a = p[std::size_t(2 * y) * n + 2 * x],
                     b = p[std::size_t(2 * y) * n + 2 * x + 1];
        const double c = p[std::size_t(2 * y + 1) * n + 2 * x],
                     d = p[std::size_t(2 * y + 1) * n + 2 * x + 1];
        t[std::size_t(y) * n + x] = (a + b + c + d) / 2;
        t[std::size_t(y) * n + x + half] = (a - b + c - d) / 2;
        t[std::size_t(y + half) * n + x] = (a + b - c - d) / 2;
        t[std::size_t(y + half) * n + x + half] = (a - b - c + d) / 2;
      }
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x)
        p[std::size_t(y) * n + x] = t[std::size_t(y) * n + x];
  }
}

void inverse(std::vector<double>& p, int n) {
  std::vector<double> t(p.size());
  for (int size = 2; size <= n; size *= 2) {
    const int half = size / 2;
    for (int y = 0; y < half; ++y)
      for (int x = 0; x < half; ++x) {
        const double s = p[std::size_t(y) * n + x], h = p[std::size_t(y) * n + x + half];
        const double v = p[std::size_t(y + half) * n + x],
                     g = p[std::size_t(y + half) * n + x + half];
        t[std::size_t(2 * y) * n + 2 * x] = (s + h + v + g) / 2;
        t[std::size_t(2 * y) * n + 2 * x + 1] = (s - h + v - g) / 2;
        t[std::size_t(2 * y + 1) * n + 2 * x] = (s + h - v - g) / 2;
        t[std::size_t(2 * y + 1) * n + 2 * x + 1] = (s - h - v + g) / 2;
      }
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x)
        p[std::size_t(y) * n + x] = t[std::size_t(y) * n + x];
  }
}

}  // namespace

std::size_t HaarApproximation::bytes() const {
  std::size_t count = 0;
  for (const auto& k : kept)
    count += k.size();
  return count * (sizeof(std::uint32_t) + sizeof(float));
}

HaarApproximation haar_project(const Grid& grid, std::size_t keep) {
  const int n = grid.resolution;
  if (n < 1 || (n & (n - 1)) != 0) throw std::invalid_argument("Haar needs a power-of-two grid");
  HaarApproximation h;
  h.resolution = n;
  h.channels = grid.channels;
  std::vector<double> plane(grid.plane_size());
  std::vector<std::uint32_t> order(plane.size());
  for (int c = 0; c < grid.channels; ++c) {
    const auto source = grid.plane(0, c);
    std::copy(source.begin(), source.end(), plane.begin());
    forward(plane, n);
    for (std::uint32_t i = 0; i < order.size(); ++i)
      order[i] = i;
    const std::size_t count = std::clamp<std::size_t>(keep, 1, plane.size());
    // The scaling coefficient (index 0) first, then the largest magnitudes.
    std::nth_element(
        order.begin() + 1, order.begin() + std::ptrdiff_t(count), order.end(),
        [&](std::uint32_t a, std::uint32_t b) { return std::abs(plane[a]) > std::abs(plane[b]); });
    std::vector<std::pair<std::uint32_t, float>> kept;
    for (std::size_t i = 0; i < count; ++i)
      kept.push_back({order[i], float(plane[order[i]])});
    std::sort(kept.begin(), kept.end());
    h.kept.push_back(std::move(kept));
  }
  return h;
}

Color haar_dot(const HaarApproximation& a, const HaarApproximation& b) {
  if (a.resolution != b.resolution) throw std::invalid_argument("Haar: resolutions differ");
  Color out{};
  const double scale = 1.0 / (double(a.resolution) * a.resolution);
  for (int c = 0; c < 3; ++c) {
    const auto& ka = a.kept[a.channels == 1 ? 0 : c];
    const auto& kb = b.kept[b.channels == 1 ? 0 : c];
    double sum = 0;
    std::size_t i = 0, j = 0;
    while (i < ka.size() && j < kb.size()) {
      if (ka[i].first < kb[j].first) {
        ++i;
      } else if (kb[j].first < ka[i].first) {
        ++j;
      } else {
        sum += double(ka[i++].second) * kb[j++].second;
      }
    }
    out[c] = sum * scale;
  }
  return out;
}

Grid haar_reconstruct(const HaarApproximation& a) {
  Grid grid(a.resolution, a.channels);
  std::vector<double> plane(grid.plane_size());
  for (int c = 0; c < a.channels; ++c) {
    std::fill(plane.begin(), plane.end(), 0.0);
    for (const auto& [index, value] : a.kept[c])
      plane[index] = value;
    inverse(plane, a.resolution);
    auto target = grid.plane(0, c);
    for (std::size_t i = 0; i < plane.size(); ++i)
      target[i] = float(plane[i]);
  }
  return grid;
}

}  // namespace basis
