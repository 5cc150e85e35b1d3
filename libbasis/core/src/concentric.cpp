#include "basis/core/concentric.h"

#include <cmath>
#include <numbers>

namespace basis {

namespace {
constexpr double kQuarterPi = std::numbers::pi / 4;
}

Vec2 square_to_uniform_disk_concentric(const Vec2& uv) {
  const double a = 2 * uv.x() - 1;
  const double b = 2 * uv.y() - 1;
  if (a == 0 && b == 0) return {0, 0};
  // Shirley & Chiu: the square's concentric rings map to the disk's concentric circles.
  double r, phi;
  if (std::abs(a) > std::abs(b)) {
    r = a;
    phi = kQuarterPi * (b / a);
  } else {
    r = b;
    phi = 2 * kQuarterPi - kQuarterPi * (a / b);
  }
  return {r * std::cos(phi), r * std::sin(phi)};
}

Vec2 uniform_disk_to_square_concentric(const Vec2& xy) {
  const double r = std::hypot(xy.x(), xy.y());
  if (r == 0) return {0.5, 0.5};
  double phi = std::atan2(xy.y(), xy.x());             // (-pi, pi]
  if (phi < -kQuarterPi) phi += 2 * std::numbers::pi;  // [-pi/4, 7pi/4)
  double a, b;
  if (phi < kQuarterPi) {  // right wedge
    a = r;
    b = r * phi / kQuarterPi;
  } else if (phi < 3 * kQuarterPi) {  // top wedge
    b = r;
    a = -r * (phi - 2 * kQuarterPi) / kQuarterPi;
  } else if (phi < 5 * kQuarterPi) {  // left wedge
    a = -r;
    b = -r * (phi - 4 * kQuarterPi) / kQuarterPi;
  } else {  // bottom wedge
    b = -r;
    a = r * (phi - 6 * kQuarterPi) / kQuarterPi;
  }
  return {(a + 1) / 2, (b + 1) / 2};
}

double square_to_uniform_disk_concentric_pdf() {
  return 1 / std::numbers::pi;
}

}  // namespace basis
