// Gauss-Legendre quadrature on [-1, 1].
#pragma once

#include <vector>

namespace basis {

struct QuadratureNode {
  double x;
  double weight;
};

// The n nodes and weights (n >= 1) that integrate polynomials of degree up to 2n - 1 exactly
// over [-1, 1] (Newton iteration on the Legendre polynomial P_n).
std::vector<QuadratureNode> gauss_legendre(int n);

}  // namespace basis
