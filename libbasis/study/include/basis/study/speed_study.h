// The speed-versus-accuracy study behind qtbench, set up on a real map with a sun: BRDF panels,
// a record facing the sun with and without an occluding wall, ground truth over the map's
// pixels, every basis timed on each case (comparison.h), and the rotation study (tilt_study.h).
#pragma once

#include <string>
#include <vector>

#include "basis/brdf/brdf.h"
#include "basis/core/file_error.h"
#include "basis/core/task.h"
#include "basis/lighting/environment.h"
#include "basis/lighting/mesh.h"
#include "basis/study/comparison.h"
#include "basis/study/tilt_study.h"

namespace basis {

struct SpeedStudyPanel {
  std::string name;  // lambert, phong100, ggx0.1, rgl:NAME, ...
  Brdf brdf;
};

struct SpeedStudyOptions {
  bool quick = false;      // three panels, one light, fewer parameters
  std::string measured{};  // an RGL .bsdf file added as a panel when not empty
  // The real-scene panel: captures at this many points sampled on this OBJ scene (none when
  // empty), looked up 30 degrees from their normals; rows average over the points.
  std::string scene{};
  int scene_points = 8;
};

// Lambert 0.8; Lambert 0.5 + Phong 10, 100, 1000 (ks 0.4); GGX 0.5, 0.1, 0.02 (kd 0.1, f0 0.9);
// quick: Lambert, Phong 100 and GGX 0.1; plus the measured file.
std::vector<SpeedStudyPanel> speed_study_panels(const SpeedStudyOptions& options);

// The study's record: at the origin, its normal 50 degrees above the horizon towards the
// azimuth of the map's brightest compact light. Throws std::invalid_argument for a map without
// a compact light.
Frame speed_study_record(const Environment& environment);

// A wall 1.5 away from the origin on the side away from `sun`, 6 wide and 5 high, hiding part
// of the sky but not the sun.
TriangleMesh occluding_wall(const Vec3& sun);

// One case per panel, light (the sun; the sun and the wall, unless quick; every point of the
// real-scene panel) and outgoing direction (the sun's mirror image; 0.5 rad from the normal,
// unless quick): the BRDF slice and the capture at 256^2 (128^2 quick), and the truth integrated
// over the map's pixels, occluded as the capture is. Prepared in parallel; progress per case.
std::vector<ComparisonCase> speed_study_cases(const Environment& environment,
                                              const std::vector<SpeedStudyPanel>& panels,
                                              const SpeedStudyOptions& options,
                                              const TaskControl& control = {});

// The methods and parameters compared (fewer when quick).
ComparisonOptions speed_study_comparison(bool quick);

// compare_methods on every case, one at a time on the calling thread, rows of one method,
// parameter, panel and light averaged over the outgoing directions.
std::vector<ComparisonRow> run_speed_study(const std::vector<ComparisonCase>& cases,
                                           const ComparisonOptions& options,
                                           const TaskControl& control = {});

// The rotation chart's rows for Lambert 0.5 + Phong 10 and 100 (ks 0.4) at the study's record,
// default tables and 128^2 captures (quick: 17^2 x 32^2 tables, 64^2 captures, four tilts).
struct RotationStudyRow {
  std::string brdf;
  TiltStudyRow row;
};
std::vector<RotationStudyRow> run_rotation_study(const Environment& environment, bool quick);

// CSV files: method,param,brdf,light,bytes,project_ns,convolve_ns,rel_error and
// map,brdf,tilt_degrees,method,rel_error. Throw FileError when they cannot be written.
void write_comparison_csv(const std::string& path, const std::vector<ComparisonRow>& rows);
void write_rotation_csv(const std::string& path, const std::string& map,
                        const std::vector<RotationStudyRow>& rows);

}  // namespace basis
