// Vectors: directions of any length against exact unit vectors.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "basis/core/vector.h"

namespace basis {
namespace {

TEST(UnitDirection, IsTheDirectionWhateverItsLengthAndZeroForNone) {
  // (2, 3, 6) has length 7 exactly.
  const Vec3 expected(2.0 / 7, 3.0 / 7, 6.0 / 7);
  for (const double scale : {1.0, -1.0, 1e300, 1e-300})
    EXPECT_LT((unit_direction(Vec3(2, 3, 6) * scale) - std::copysign(1.0, scale) * expected).norm(),
              1e-15)
        << scale;
  EXPECT_EQ(unit_direction(Vec3::Zero()), Vec3::Zero());
  EXPECT_EQ(unit_direction(Vec3(1, std::numeric_limits<double>::infinity(), 0)), Vec3::Zero());
  EXPECT_EQ(unit_direction(Vec3(1, std::nan(""), 0)), Vec3::Zero());
}

}  // namespace
}  // namespace basis
