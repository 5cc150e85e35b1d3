// Mappings: round trips, known values, measures checked by numeric integration against
// analytic integrals, and the symmetries of the square that the maps commute with.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>

#include "basis/core/concentric.h"
#include "basis/core/frame.h"
#include "basis/core/hemisphere.h"
#include "basis/core/latlong.h"
#include "basis/core/parabolic.h"
#include "basis/core/square_symmetry.h"

namespace basis {
namespace {

constexpr double kPi = std::numbers::pi;

// Grid points of [0,1]^2 that include the centre, the seams (u or v = 0.5), the diagonals,
// the edges and the corners: an odd number of points per axis.
std::vector<Vec2> square_grid(int points_per_axis) {
  std::vector<Vec2> grid;
  for (int j = 0; j < points_per_axis; ++j)
    for (int i = 0; i < points_per_axis; ++i)
      grid.emplace_back(double(i) / (points_per_axis - 1), double(j) / (points_per_axis - 1));
  return grid;
}

// Midpoint rule over the unit square with n x n cells.
double integrate_square(int n, const std::function<double(const Vec2&)>& f) {
  double sum = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      sum += f(Vec2((i + 0.5) / n, (j + 0.5) / n));
  return sum / (double(n) * n);
}

TEST(ConcentricMap, KnownValues) {
  const Vec2 corner = square_to_uniform_disk_concentric({0, 0});
  EXPECT_NEAR(corner.x(), -1 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(corner.y(), -1 / std::sqrt(2.0), 1e-12);
  const Vec2 centre = square_to_uniform_disk_concentric({0.5, 0.5});
  EXPECT_EQ(centre.x(), 0);
  EXPECT_EQ(centre.y(), 0);
  const Vec2 edge = square_to_uniform_disk_concentric({1, 0.75});
  EXPECT_NEAR(edge.x(), 0.92388, 1e-5);
  EXPECT_NEAR(edge.y(), 0.382683, 1e-6);
  // Seams map to the axes, diagonals to the diagonals.
  const Vec2 top = square_to_uniform_disk_concentric({0.5, 1});
  EXPECT_NEAR(top.x(), 0, 1e-15);
  EXPECT_NEAR(top.y(), 1, 1e-15);
  const Vec2 diagonal = square_to_uniform_disk_concentric({0.75, 0.75});
  EXPECT_NEAR(diagonal.x(), 0.5 / std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(diagonal.y(), 0.5 / std::sqrt(2.0), 1e-15);
}

TEST(ConcentricMap, RoundTripsOverGrid) {
  for (const Vec2& uv : square_grid(257)) {
    const Vec2 disk = square_to_uniform_disk_concentric(uv);
    EXPECT_LE(disk.norm(), 1 + 1e-12);
    const Vec2 back = uniform_disk_to_square_concentric(disk);
    ASSERT_NEAR(back.x(), uv.x(), 1e-5) << uv.transpose();
    ASSERT_NEAR(back.y(), uv.y(), 1e-5) << uv.transpose();
  }
}

TEST(ConcentricMap, InverseRoundTripsOverDisk) {
  for (int j = 0; j <= 64; ++j)
    for (int i = 0; i <= 256; ++i) {
      const double r = j / 64.0, phi = 2 * kPi * i / 256;
      const Vec2 disk(r * std::cos(phi), r * std::sin(phi));
      const Vec2 back = square_to_uniform_disk_concentric(uniform_disk_to_square_concentric(disk));
      ASSERT_NEAR(back.x(), disk.x(), 1e-5);
      ASSERT_NEAR(back.y(), disk.y(), 1e-5);
    }
}

TEST(ConcentricMap, AreaIsPiTimesSquareArea) {
  // The Jacobian determinant, by central differences, is pi away from the non-differentiable
  // diagonals; summing image areas of a fine grid of cells gives the disk's area.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.01, 0.99);
  const double h = 1e-6;
  for (int k = 0; k < 1000; ++k) {
    const double u = unit(rng), v = unit(rng);
    const Vec2 uv(u, v);
    if (std::abs(std::abs(uv.x() - 0.5) - std::abs(uv.y() - 0.5)) < 1e-4) continue;
    const Vec2 du = (square_to_uniform_disk_concentric(uv + Vec2(h, 0)) -
                     square_to_uniform_disk_concentric(uv - Vec2(h, 0))) /
                    (2 * h);
    const Vec2 dv = (square_to_uniform_disk_concentric(uv + Vec2(0, h)) -
                     square_to_uniform_disk_concentric(uv - Vec2(0, h))) /
                    (2 * h);
    EXPECT_NEAR(std::abs(du.x() * dv.y() - du.y() * dv.x()), kPi, 1e-4);
  }
  EXPECT_DOUBLE_EQ(square_to_uniform_disk_concentric_pdf(), 1 / kPi);
}

TEST(CosineHemisphere, RoundTripsOverGrid) {
  for (const Vec2& uv : square_grid(257)) {
    const Vec3 w = square_to_cosine_hemisphere(uv);
    EXPECT_NEAR(w.norm(), 1, 1e-12);
    EXPECT_GE(w.z(), 0);
    const Vec2 back = cosine_hemisphere_to_square(w);
    ASSERT_NEAR(back.x(), uv.x(), 1e-5) << uv.transpose();
    ASSERT_NEAR(back.y(), uv.y(), 1e-5) << uv.transpose();
  }
  EXPECT_NEAR(square_to_cosine_hemisphere({0.5, 0.5}).z(), 1, 0);
}

TEST(CosineHemisphere, ProductWithCosineIsPiTimesSquareIntegral) {
  // Integral over the hemisphere of cos^n(theta) * cos(theta) = 2 pi / (n + 2).
  for (int n : {0, 1, 10, 100}) {
    const double numeric = kPi * integrate_square(1024, [n](const Vec2& uv) {
                             return std::pow(square_to_cosine_hemisphere(uv).z(), n);
                           });
    EXPECT_NEAR(numeric, 2 * kPi / (n + 2), 1e-4) << "n = " << n;
  }
  // A spherical cap theta < alpha, weighted by (cos(theta) - cos(alpha)) so that it is
  // continuous: its integral with cos is 2 pi ((1 - c^3) / 3 - c (1 - c^2) / 2), c = cos(alpha).
  const double c = std::cos(40 * kPi / 180);
  const double cap = kPi * integrate_square(1024, [c](const Vec2& uv) {
                       return std::max(0.0, square_to_cosine_hemisphere(uv).z() - c);
                     });
  EXPECT_NEAR(cap, 2 * kPi * ((1 - c * c * c) / 3 - c * (1 - c * c) / 2), 1e-4);
  // The density matches the measure: pdf integrates to one over the hemisphere.
  const double pdf_integral = integrate_square(1024, [](const Vec2& uv) {
    const Vec3 w = square_to_cosine_hemisphere(uv);
    return square_to_cosine_hemisphere_pdf(w) * kPi / std::max(w.z(), 1e-300);
  });
  EXPECT_NEAR(pdf_integral, 1, 1e-9);
}

TEST(UniformHemisphere, RoundTripsOverGrid) {
  for (const Vec2& uv : square_grid(257)) {
    const Vec3 w = square_to_uniform_hemisphere(uv);
    EXPECT_NEAR(w.norm(), 1, 1e-12);
    const Vec2 back = uniform_hemisphere_to_square(w);
    ASSERT_NEAR(back.x(), uv.x(), 1e-5) << uv.transpose();
    ASSERT_NEAR(back.y(), uv.y(), 1e-5) << uv.transpose();
  }
}

TEST(UniformHemisphere, IntegralIsTwoPiTimesSquareIntegral) {
  // Integral over the hemisphere of cos^n(theta) = 2 pi / (n + 1).
  for (int n : {0, 1, 10, 100}) {
    const double numeric = 2 * kPi * integrate_square(1024, [n](const Vec2& uv) {
                             return std::pow(square_to_uniform_hemisphere(uv).z(), n);
                           });
    EXPECT_NEAR(numeric, 2 * kPi / (n + 1), 1e-4) << "n = " << n;
  }
  // The continuous cap (cos(theta) - c)^+ integrates to pi (1 - c)^2.
  const double c = std::cos(55 * kPi / 180);
  const double cap = 2 * kPi * integrate_square(1024, [c](const Vec2& uv) {
                       return std::max(0.0, square_to_uniform_hemisphere(uv).z() - c);
                     });
  EXPECT_NEAR(cap, kPi * (1 - c) * (1 - c), 1e-4);
  EXPECT_DOUBLE_EQ(square_to_uniform_hemisphere_pdf(), 1 / (2 * kPi));
}

TEST(ParabolicMap, RadiusIsTanHalfTheta) {
  for (int k = 0; k <= 90; ++k) {
    const double theta = k * kPi / 180, phi = 0.3 * k;
    const Vec3 w(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    const Vec2 st = hemisphere_to_parabolic(w);
    EXPECT_NEAR(st.norm(), std::tan(theta / 2), 1e-12);
    EXPECT_NEAR(std::atan2(st.y(), st.x()), std::atan2(w.y(), w.x()), k ? 1e-12 : 4);
  }
}

TEST(ParabolicMap, RoundTripsAndClampsOutsideTheDisk) {
  for (int j = 0; j <= 128; ++j)
    for (int i = 0; i <= 128; ++i) {
      const Vec2 st(-1 + 2.0 * i / 128, -1 + 2.0 * j / 128);
      const Vec3 w = parabolic_to_hemisphere(st);
      EXPECT_NEAR(w.norm(), 1, 1e-12);
      EXPECT_GE(w.z(), 0);
      const Vec2 back = hemisphere_to_parabolic(w);
      if (st.norm() <= 1) {
        ASSERT_NEAR(back.x(), st.x(), 1e-5);
        ASSERT_NEAR(back.y(), st.y(), 1e-5);
      } else {
        EXPECT_NEAR(w.z(), 0, 1e-12);  // clamped to the horizon
        ASSERT_NEAR(back.x(), st.x() / st.norm(), 1e-5);
        ASSERT_NEAR(back.y(), st.y() / st.norm(), 1e-5);
      }
    }
}

TEST(ParabolicMap, JacobianIntegratesToTwoPi) {
  // Polar midpoint rule over the unit disk.
  const int nr = 2000, nphi = 64;
  double area = 0, cosine_lobe = 0;
  for (int i = 0; i < nr; ++i)
    for (int k = 0; k < nphi; ++k) {
      const double r = (i + 0.5) / nr, phi = 2 * kPi * (k + 0.5) / nphi;
      const Vec2 st(r * std::cos(phi), r * std::sin(phi));
      const double dA = r * (1.0 / nr) * (2 * kPi / nphi);
      const double dw = parabolic_to_hemisphere_jacobian(st) * dA;
      area += dw;
      cosine_lobe += std::pow(parabolic_to_hemisphere(st).z(), 10) * dw;
    }
  EXPECT_NEAR(area, 2 * kPi, 1e-4);
  EXPECT_NEAR(cosine_lobe, 2 * kPi / 11, 1e-4);
}

// A point of the square moved by a symmetry about the square's centre.
Vec2 move_square_point(const SquareSymmetry& g, const Vec2& uv) {
  const Vec3 c = g.apply(Vec3(2 * uv.x() - 1, 2 * uv.y() - 1, 0));
  return {(c.x() + 1) / 2, (c.y() + 1) / 2};
}

TEST(SquareSymmetry, FormAGroupOfEight) {
  const auto all = SquareSymmetry::all();
  EXPECT_TRUE(all[0].is_identity());
  for (const SquareSymmetry& a : all) {
    EXPECT_EQ(std::abs(a.determinant()), 1);
    for (const SquareSymmetry& b : all) {
      // The product a b, as a matrix, is one of the eight.
      SquareSymmetry ab;
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j)
          ab.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j];
      EXPECT_NE(std::find(all.begin(), all.end(), ab), all.end());
    }
    // The inverse undoes the move of grid indices, for odd and even grids.
    for (const int n : {7, 8})
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const auto [x, y] = a.apply(i, j, n);
          ASSERT_GE(std::min(x, y), 0);
          ASSERT_LT(std::max(x, y), n);
          EXPECT_EQ(a.inverse().apply(x, y, n), (std::array<int, 2>{i, j}));
        }
  }
}

TEST(SquareSymmetry, CommuteWithTheConcentricAndParabolicMaps) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0, 1);
  for (const SquareSymmetry& g : SquareSymmetry::all())
    for (int k = 0; k < 2000; ++k) {
      const double u = unit(rng), v = unit(rng);
      const Vec2 uv(u, v);
      const Vec3 moved = g.apply(square_to_cosine_hemisphere(uv));
      EXPECT_LT((square_to_cosine_hemisphere(move_square_point(g, uv)) - moved).norm(), 1e-12);
      const Vec2 st = hemisphere_to_parabolic(square_to_cosine_hemisphere(uv));
      const Vec3 st_moved = g.apply(Vec3(st.x(), st.y(), 0));
      EXPECT_LT((hemisphere_to_parabolic(moved) - Vec2(st_moved.x(), st_moved.y())).norm(), 1e-12);
    }
}

TEST(SquareSymmetry, TransformGridMovesTheFunctionAndTurnsItsVectors) {
  const int n = 16;
  // Groups: a scalar function, then a vector field (its two components), over the square.
  auto f = [](const Vec2& p) { return std::sin(3 * p.x()) + p.y() * p.y() + 0.3 * p.x() * p.y(); };
  auto field = [](const Vec2& p) { return Vec2(std::cos(2 * p.y()) + p.x(), p.x() * p.y() - 1); };
  Grid grid(n, 1, 3);
  auto centre = [&](int x, int y) { return Vec2(2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1); };
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      grid.at(0, 0, x, y) = float(f(centre(x, y)));
      grid.at(1, 0, x, y) = float(field(centre(x, y)).x());
      grid.at(2, 0, x, y) = float(field(centre(x, y)).y());
    }
  for (const SquareSymmetry& g : SquareSymmetry::all())
    for (const bool axial : {false, true}) {
      const Grid moved = transform_grid(grid, g, {1, axial});
      const int sign = axial ? g.determinant() : 1;
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          // The moved function at p is the original at A^-1 p; vectors are turned by A.
          const Vec2 p = centre(x, y);
          const Vec3 q = g.inverse().apply(Vec3(p.x(), p.y(), 0));
          const Vec2 before = field(Vec2(q.x(), q.y()));
          const Vec3 turned = g.apply(Vec3(before.x(), before.y(), 0)) * sign;
          EXPECT_NEAR(moved.at(0, 0, x, y), f(Vec2(q.x(), q.y())), 1e-5);
          EXPECT_NEAR(moved.at(1, 0, x, y), turned.x(), 1e-5);
          EXPECT_NEAR(moved.at(2, 0, x, y), turned.y(), 1e-5);
        }
    }
}

TEST(Frame, IdentityForPlusZ) {
  const Frame f = Frame::from_normal({0, 0, 1});
  EXPECT_EQ(f.tangent, Vec3(1, 0, 0));
  EXPECT_EQ(f.bitangent, Vec3(0, 1, 0));
  EXPECT_EQ(f.normal, Vec3(0, 0, 1));
}

TEST(Frame, OrthonormalRightHandedAndInvertible) {
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss;
  std::vector<Vec3> normals = {{0, 0, -1}, {1, 0, 0}, {0, -1, 0}, {1e-9, 0, -1}};
  for (int k = 0; k < 1000; ++k)
    normals.emplace_back(gauss(rng), gauss(rng), gauss(rng));
  for (Vec3 n : normals) {
    n.normalize();
    const Frame f = Frame::from_normal(n);
    EXPECT_NEAR(f.tangent.norm(), 1, 1e-12);
    EXPECT_NEAR(f.bitangent.norm(), 1, 1e-12);
    EXPECT_NEAR(f.tangent.dot(f.bitangent), 0, 1e-12);
    EXPECT_NEAR(f.tangent.dot(n), 0, 1e-12);
    EXPECT_NEAR((f.tangent.cross(f.bitangent) - n).norm(), 0, 1e-12);
    const Vec3 v(0.3, -0.5, 0.8);
    EXPECT_NEAR((f.to_world(f.to_local(v)) - v).norm(), 0, 1e-12);
    EXPECT_NEAR((f.to_local(n) - Vec3(0, 0, 1)).norm(), 0, 1e-12);
  }
}

TEST(LatLong, PixelSolidAnglesSumToFourPi) {
  for (auto [w, h] : {std::pair{256, 128}, {1024, 512}, {7, 3}}) {
    double sum = 0;
    for (int j = 0; j < h; ++j)
      sum += w * latlong_pixel_solid_angle(j, w, h);
    EXPECT_NEAR(sum, 4 * kPi, 1e-12);
  }
  // The Jacobian, integrated over a row, equals the exact pixel solid angle.
  const int w = 64, h = 32, n = 1000;
  for (int j : {0, 5, 16, 31}) {
    double sum = 0;
    for (int k = 0; k < n; ++k)
      sum += latlong_to_direction_jacobian(j + (k + 0.5) / n, w, h) / n;
    EXPECT_NEAR(sum, latlong_pixel_solid_angle(j, w, h), 1e-9);
  }
}

TEST(LatLong, ConventionAndRoundTrip) {
  const int w = 256, h = 128;
  EXPECT_NEAR((latlong_to_direction({0, 0}, w, h) - Vec3(0, 0, 1)).norm(), 0, 1e-12);
  EXPECT_NEAR((latlong_to_direction({0, 64}, w, h) - Vec3(1, 0, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR((latlong_to_direction({64, 64}, w, h) - Vec3(0, 1, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR((latlong_to_direction({0, 128}, w, h) - Vec3(0, 0, -1)).norm(), 0, 1e-12);
  for (int j = 1; j < 128; ++j)
    for (int i = 0; i < 256; i += 3) {
      const Vec2 p(i + 0.25, j + 0.5);
      const Vec2 back = direction_to_latlong(latlong_to_direction(p, w, h), w, h);
      ASSERT_NEAR(back.x(), p.x(), 1e-9);
      ASSERT_NEAR(back.y(), p.y(), 1e-9);
    }
}

}  // namespace
}  // namespace basis
