// The rotation chart's study: shading a surface tilted against the frame its radiance was
// captured in, by the quadtree table (no compensation, re-parametrised, compensated) and by
// spherical harmonics rotated exactly, against the exactly rotated reference.
#pragma once

#include <string>
#include <vector>

#include "basis/brdf/table_lookup.h"
#include "basis/lighting/environment.h"

namespace basis {

struct TiltStudyRow {
  std::string method;  // none, reparametrised, compensated, sh_rotated
  int sh_order = 0;
  double tilt_degrees = 0;
  double rel_error = 0;  // mean over tilt axes and outgoing directions, green channel
};

struct TiltStudyOptions {
  std::vector<double> tilts_degrees{0, 1, 2, 3, 5, 7.5, 10, 15, 20, 25, 30};
  int axes = 6;                               // tilt axes around the normal
  std::vector<double> wo_degrees{0, 30, 60};  // outgoing directions' angles from the normal
  std::vector<int> sh_orders{8, 16};
  int capture_resolution = 64;
  double capture_tolerance = 0.01;
  int reference_subsamples = 2;  // per map pixel and axis, for the exactly rotated reference
};

// Record at the origin with normal `record_normal` (world), lit by `environment`, no scene.
std::vector<TiltStudyRow> study_tilts(const Environment& environment, const Vec3& record_normal,
                                      const Brdf& brdf, const BrdfTableView& table,
                                      const TiltStudyOptions& options);

}  // namespace basis
