#include "basis/study/tilt_study.h"

#include <cmath>
#include <numbers>

#include "basis/core/projection.h"
#include "basis/lighting/capture.h"
#include "basis/study/reference.h"
#include "basis/study/sh.h"

namespace basis {

std::vector<TiltStudyRow> study_tilts(const Environment& environment, const Vec3& record_normal,
                                      const Brdf& brdf, const BrdfTableView& table,
                                      const TiltStudyOptions& o) {
  const Frame record = Frame::from_normal(record_normal.normalized());
  const Grid grid =
      capture(environment, nullptr, Vec3::Zero(), record, {.resolution = o.capture_resolution})
          .texels;
  const PackedTree radiance = pack(project(grid, {.tolerance = o.capture_tolerance}));
  std::vector<std::vector<double>> sh_light;
  for (int order : o.sh_orders)
    sh_light.push_back(sh_project(grid, order, false));
  // SH transfers of the BRDF slice at each outgoing direction (exact wo, no table).
  auto outgoing = [](double degrees) {
    const double a = degrees * std::numbers::pi / 180;
    return Vec3(std::sin(a) * std::cos(1.0), std::sin(a) * std::sin(1.0), std::cos(a));
  };
  BrdfTableOptions slice_options;
  slice_options.wi_resolution = 64;
  const int brdf_channels = channel_count(brdf);
  std::vector<std::vector<std::vector<double>>> transfers;  // [wo][order]
  for (const double wo_degrees : o.wo_degrees) {
    const Grid slice = tabulate_entry(brdf, outgoing(wo_degrees), slice_options);
    transfers.emplace_back();
    for (int order : o.sh_orders)
      transfers.back().push_back(sh_project(slice, order, true));
  }

  std::vector<TiltStudyRow> rows;
  const TiltCompensation modes[] = {TiltCompensation::none, TiltCompensation::reparametrised,
                                    TiltCompensation::compensated};
  const char* mode_names[] = {"none", "reparametrised", "compensated"};
  for (const double degrees : o.tilts_degrees) {
    std::vector<double> errors(3 + o.sh_orders.size(), 0.0);
    int count = 0;
    for (int axis = 0; axis < o.axes; ++axis)
      for (std::size_t w = 0; w < o.wo_degrees.size(); ++w) {
        const double phi = 2 * std::numbers::pi * axis / o.axes + 0.2;
        const double t = degrees * std::numbers::pi / 180;
        const Tilt tilt{t * std::cos(phi), t * std::sin(phi)};
        const Frame shading = tilted_frame(record, tilt);
        const Vec3 wo = outgoing(o.wo_degrees[w]);
        const double exact = reference_reflection(environment, nullptr, Vec3::Zero(), shading, brdf,
                                                  wo, o.reference_subsamples)[1];
        for (int m = 0; m < 3; ++m)
          errors[m] +=
              std::abs(reflect_tilted(table, radiance.view(), wo, tilt, modes[m]).value[1] -
                       exact) /
              exact;
        // SH: the light rotated exactly into the shading frame (L_s(w) = L_record(r w), r the
        // tilt's rotation; the coefficients of f(R^-1 w) with R = r^T), against the transfer.
        const Eigen::Matrix3d r = tilt_rotation(tilt);
        for (std::size_t k = 0; k < o.sh_orders.size(); ++k) {
          const int order = o.sh_orders[k];
          const auto rotated = sh_rotate(sh_light[k], 3, order, sh_rotation(order, r.transpose()));
          const double value = sh_dot(transfers[w][k], brdf_channels, rotated, 3, order)[1];
          errors[3 + k] += std::abs(value - exact) / exact;
        }
        ++count;
      }
    for (int m = 0; m < 3; ++m)
      rows.push_back({mode_names[m], 0, degrees, errors[m] / count});
    for (std::size_t k = 0; k < o.sh_orders.size(); ++k)
      rows.push_back({"sh_rotated", o.sh_orders[k], degrees, errors[3 + k] / count});
  }
  return rows;
}

}  // namespace basis
