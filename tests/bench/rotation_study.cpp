// The rotation chart's numbers: error of shading a surface tilted against the capture's frame,
// with no compensation, with the re-parametrised table, and with the first-order compensation,
// against the exactly rotated integral over the map's pixels.
// Usage: basis_rotation_study OUT.csv [PROBE.hdr]  (default: the shared grace probe, or a
// synthetic sky when absent).
#include <cstdio>
#include <fstream>
#include <numbers>

#include "basis/brdf_table.h"
#include "basis/capture.h"
#include "../support/environments.h"
#include "../support/reflection_reference.h"

int main(int argc, char** argv) {
  using namespace basis;
  if (argc < 2) {
    std::fprintf(stderr, "usage: basis_rotation_study OUT.csv [PROBE.hdr]\n");
    return 2;
  }
  std::string map_name = "synthetic";
  Image image = testing::synthetic_sky();
  if (argc > 2) {
    image = read_image(argv[2]);
    map_name = argv[2];
  } else if (auto grace = testing::real_probe("grace")) {
    image = *grace;
    map_name = "grace";
  }
  const Environment env(image);
  const Frame record = Frame::from_normal(Vec3(0.3, -0.2, 0.93).normalized());
  const Quadtree radiance =
      project(capture(env, nullptr, Vec3::Zero(), record, {.resolution = 64}), {.tolerance = 0.01});
  std::ofstream out(argv[1]);
  out << "map,brdf,tilt_degrees,method,rel_error\n";
  for (double exponent : {10.0, 100.0}) {
    const Brdf brdf = Phong{{0.5, 0.5, 0.5}, {0.4, 0.4, 0.4}, exponent};
    const BrdfTable table = tabulate_brdf(brdf, {});
    for (double degrees : {0.0, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0, 15.0, 20.0, 25.0, 30.0}) {
      testing::TiltErrors e;
      int count = 0;
      for (int axis = 0; axis < 6; ++axis)
        for (double wo_degrees : {0.0, 30.0, 60.0}) {
          const double phi = axis * std::numbers::pi / 3 + 0.2, t = degrees * std::numbers::pi / 180;
          const Tilt tilt{t * std::cos(phi), t * std::sin(phi)};
          const Eigen::Matrix3d r = tilt_rotation(tilt);
          Frame shading;
          shading.tangent = record.to_world(r * Vec3::UnitX());
          shading.bitangent = record.to_world(r * Vec3::UnitY());
          shading.normal = record.to_world(r * Vec3::UnitZ());
          const double a = wo_degrees * std::numbers::pi / 180;
          const Vec3 wo(std::sin(a) * std::cos(1.0), std::sin(a) * std::sin(1.0), std::cos(a));
          const double exact = testing::exact_reflection(env, brdf, shading, wo, 1);
          auto error = [&](TiltCompensation mode) {
            return std::abs(reflect_tilted(table.view(), radiance.view(), wo, tilt, mode).value[1] -
                            exact) / exact;
          };
          e.none += error(TiltCompensation::none);
          e.reparametrised += error(TiltCompensation::reparametrised);
          e.compensated += error(TiltCompensation::compensated);
          ++count;
        }
      const std::string brdf_name = "phong" + std::to_string(int(exponent));
      out << map_name << "," << brdf_name << "," << degrees << ",none," << e.none / count << "\n"
          << map_name << "," << brdf_name << "," << degrees << ",reparametrised,"
          << e.reparametrised / count << "\n"
          << map_name << "," << brdf_name << "," << degrees << ",compensated,"
          << e.compensated / count << "\n";
      std::printf("%s %s tilt %5.1f: none %.4f reparametrised %.4f compensated %.4f\n",
                  map_name.c_str(), brdf_name.c_str(), degrees, e.none / count,
                  e.reparametrised / count, e.compensated / count);
    }
  }
}
