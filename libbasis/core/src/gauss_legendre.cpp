#include "basis/core/gauss_legendre.h"

#include <cmath>
#include <numbers>

namespace basis {

std::vector<QuadratureNode> gauss_legendre(int n) {
  std::vector<QuadratureNode> rule(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    double x = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5)), dp = 0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1);
      const double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-15) break;
    }
    rule[std::size_t(i)] = {x, 2 / ((1 - x * x) * dp * dp)};
  }
  return rule;
}

}  // namespace basis
