// The speed study's set-up: the record faces the sun, the wall hides sky but not the sun, and
// rows of one method and case are averaged over the outgoing directions.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "basis/lighting/embree_scene.h"
#include "basis/study/speed_study.h"
#include "support/environments.h"

namespace basis {
namespace {

TEST(SpeedStudy, TheRecordFacesTheSunFiftyDegreesUp) {
  const Environment env(testing::synthetic_sky());
  ASSERT_EQ(env.lights().size(), 1u);
  const Vec3 sun = env.lights()[0].direction;
  const Vec3 n = speed_study_record(env).normal;
  EXPECT_NEAR(n.z(), std::sin(50 * std::numbers::pi / 180), 1e-12);
  EXPECT_NEAR(std::atan2(n.y(), n.x()), std::atan2(sun.y(), sun.x()), 1e-12);
  EXPECT_THROW(speed_study_record(Environment::constant({1, 1, 1})), std::invalid_argument);
}

TEST(SpeedStudy, TheWallHidesSkyButNotTheSun) {
  const Environment env(testing::synthetic_sky());
  const Vec3 sun = env.lights()[0].direction;
  const EmbreeScene wall(occluding_wall(sun));
  const Vec3 away = Vec3(-sun.x(), -sun.y(), 0.3).normalized();
  const Ray rays[] = {{Vec3::Zero(), sun}, {Vec3::Zero(), away}};
  RayHit hits[2];
  wall.trace(rays, hits);
  EXPECT_FALSE(hits[0].hit);
  EXPECT_TRUE(hits[1].hit);
}

TEST(SpeedStudy, RowsAreAveragedOverOutgoingDirections) {
  const Environment env(testing::synthetic_sky());
  std::vector<ComparisonCase> cases = speed_study_cases(
      env, {{"phong100", Phong{{0.5, 0.5, 0.5}, {0.4, 0.4, 0.4}, 100}}}, {.quick = true});
  ASSERT_EQ(cases.size(), 1u);  // quick: one light, one outgoing direction
  // A second outgoing direction of the same panel and light: the first with a doubled truth.
  cases.push_back(cases[0]);
  for (double& t : cases[1].truth)
    t *= 2;
  ComparisonOptions options;
  options.quadtree_resolutions = {32};
  options.quadtree_tolerances = {0.05};
  options.dense_resolutions = {32};
  options.sh_orders = {4};
  options.haar_kept = {64};
  options.seconds_per_timing = 1e-4;
  const std::vector<ComparisonRow> rows = run_speed_study(cases, options);
  const std::vector<ComparisonRow> first = compare_methods(cases[0], options);
  const std::vector<ComparisonRow> second = compare_methods(cases[1], options);
  ASSERT_EQ(rows.size(), first.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].method, first[i].method);
    EXPECT_EQ(rows[i].param, first[i].param);
    EXPECT_NEAR(rows[i].rel_error, (first[i].rel_error + second[i].rel_error) / 2,
                1e-12 * (1 + first[i].rel_error))
        << rows[i].method << " " << rows[i].param;
  }
}

}  // namespace
}  // namespace basis
