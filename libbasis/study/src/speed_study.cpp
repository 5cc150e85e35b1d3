#include "basis/study/speed_study.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <numbers>
#include <span>
#include <sstream>
#include <stdexcept>

#include "basis/brdf/brdf_table.h"
#include "basis/brdf/rgl.h"
#include "basis/io/atomic_file.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/embree_scene.h"
#include "basis/lighting/mesh.h"
#include "basis/study/reference.h"

namespace basis {

std::vector<SpeedStudyPanel> speed_study_panels(const SpeedStudyOptions& options) {
  const Color kd{0.5, 0.5, 0.5}, ks{0.4, 0.4, 0.4}, g{0.1, 0.1, 0.1}, f0{0.9, 0.9, 0.9};
  std::vector<SpeedStudyPanel> all = {
      {"lambert", Lambert{{0.8, 0.8, 0.8}}}, {"phong10", Phong{kd, ks, 10}},
      {"phong100", Phong{kd, ks, 100}},      {"phong1000", Phong{kd, ks, 1000}},
      {"ggx0.5", Ggx{g, f0, 0.5}},           {"ggx0.1", Ggx{g, f0, 0.1}},
      {"ggx0.02", Ggx{g, f0, 0.02}}};
  if (options.quick) all = {all[0], all[2], all[5]};
  if (!options.measured.empty())
    all.push_back({"rgl:" + std::filesystem::path(options.measured).stem().string(),
                   std::shared_ptr<const MeasuredBrdf>(RglBrdf::read(options.measured))});
  return all;
}

Frame speed_study_record(const Environment& environment) {
  const Environment::CompactLight* sun = environment.brightest_light();
  if (!sun)
    throw std::invalid_argument(environment.name() +
                                ": no compact light (a sun) to face; the study needs one");
  const double azimuth = std::atan2(sun->direction.y(), sun->direction.x());
  const double up = 50 * std::numbers::pi / 180;
  return Frame::from_normal(
      Vec3(std::cos(up) * std::cos(azimuth), std::cos(up) * std::sin(azimuth), std::sin(up)));
}

TriangleMesh occluding_wall(const Vec3& sun) {
  const Vec3 away = -Vec3(sun.x(), sun.y(), 0).normalized();
  const Vec3 side = Vec3::UnitZ().cross(away);
  const Vec3 centre = away * 1.5;
  TriangleMesh wall;
  auto corner = [&](double s, double h) {
    const Vec3 p = centre + side * s + Vec3::UnitZ() * h;
    return std::array<float, 3>{float(p.x()), float(p.y()), float(p.z())};
  };
  wall.vertices = {corner(-3, -1), corner(3, -1), corner(3, 4), corner(-3, 4)};
  wall.triangles = {{0, 1, 2}, {0, 2, 3}};
  wall.emission = {{0, 0, 0}, {0, 0, 0}};
  return wall;
}

std::vector<ComparisonCase> speed_study_cases(const Environment& environment,
                                              const std::vector<SpeedStudyPanel>& panels,
                                              const SpeedStudyOptions& options,
                                              const TaskControl& control) {
  const Frame frame = speed_study_record(environment);
  const Vec3 sun = environment.brightest_light()->direction;
  const EmbreeScene wall(occluding_wall(sun));
  const int finest = options.quick ? 128 : 256;
  const int subsamples = options.quick ? 1 : 2;
  // A light: a capture at a point with its frame, occluded by a scene or not.
  struct Light {
    std::string name;
    const RayScene* scene;
    Vec3 position;
    Frame frame;
    double ray_offset;  // world units, as the tools take it for the scene
    Grid grid;
  };
  std::vector<Light> lights = {{"sun", nullptr, Vec3::Zero(), frame, 1e-4, {}}};
  if (!options.quick) lights.push_back({"sun+occluder", &wall, Vec3::Zero(), frame, 1e-4, {}});
  // The real-scene panel: points sampled on the scene's surfaces, each its own capture.
  std::unique_ptr<EmbreeScene> scene;
  if (!options.scene.empty() && options.scene_points > 0) {
    const TriangleMesh mesh = read_obj(options.scene);
    scene = std::make_unique<EmbreeScene>(mesh);
    const double offset = mesh.ray_offset();
    for (const SurfacePoint& p : sample_surface(mesh, std::size_t(options.scene_points), 7))
      lights.push_back(
          {"scene", scene.get(), p.position, Frame::from_normal(p.normal), offset, {}});
  }
  for (Light& l : lights)
    l.grid = capture(environment, l.scene, l.position, l.frame,
                     {.resolution = finest, .strata = 2, .ray_offset = l.ray_offset})
                 .texels;
  // Outgoing directions: where the sun's mirror image lies (the highlight), and oblique; at the
  // scene's points 30 degrees from the normal.
  const Vec3 sun_local = frame.to_local(sun);
  std::vector<Vec3> outgoing = {Vec3(-sun_local.x(), -sun_local.y(), sun_local.z()).normalized()};
  if (!options.quick) outgoing.push_back(Vec3(std::sin(0.5), 0, std::cos(0.5)));
  const std::vector<Vec3> scene_outgoing = {Vec3(0.5, 0, std::sqrt(0.75))};

  struct Job {
    const SpeedStudyPanel* panel;
    const Light* light;
    Vec3 wo;
  };
  std::vector<Job> jobs;
  for (const SpeedStudyPanel& p : panels)
    for (const Light& l : lights)
      for (const Vec3& wo : l.name == "scene" ? scene_outgoing : outgoing)
        jobs.push_back({&p, &l, wo});
  std::vector<ComparisonCase> cases(jobs.size());
  std::atomic<std::size_t> prepared{0};
  tbb::parallel_for(std::size_t(0), jobs.size(), [&](std::size_t i) {
    control.check();
    const Job& job = jobs[i];
    BrdfTableOptions o;
    o.wi_resolution = finest;
    cases[i] = {job.panel->name, job.light->name, tabulate_entry(job.panel->brdf, job.wo, o),
                job.light->grid,
                reference_reflection(environment, job.light->scene, job.light->position,
                                     job.light->frame, job.panel->brdf, job.wo, subsamples)};
    control.report(++prepared, jobs.size());
  });
  return cases;
}

ComparisonOptions speed_study_comparison(bool quick) {
  ComparisonOptions options;
  if (quick) {
    options.quadtree_resolutions = {32, 128};
    options.quadtree_tolerances = {0.01, 0.05, 0.3};
    options.dense_resolutions = {8, 32, 128};
    options.sh_orders = {2, 4, 8, 16};
    options.haar_kept = {16, 128, 1024};
    options.seconds_per_timing = 0.004;
  }
  return options;
}

std::vector<ComparisonRow> run_speed_study(const std::vector<ComparisonCase>& cases,
                                           const ComparisonOptions& options,
                                           const TaskControl& control) {
  std::map<std::string, std::pair<ComparisonRow, int>> merged;
  std::vector<std::string> order;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    control.check();
    for (const ComparisonRow& r : compare_methods(cases[i], options)) {
      const std::string key = r.method + "|" + r.param + "|" + r.brdf + "|" + r.light;
      auto [it, fresh] = merged.try_emplace(key, r, 0);
      ComparisonRow& m = it->second.first;
      if (fresh) {
        order.push_back(key);
        m.rel_error = m.convolve_ns = m.project_ns = 0;
      }
      m.rel_error += r.rel_error;
      m.convolve_ns += r.convolve_ns;
      m.project_ns += r.project_ns;
      ++it->second.second;
    }
    control.report(i + 1, cases.size());
  }
  std::vector<ComparisonRow> rows;
  for (const std::string& key : order) {
    ComparisonRow r = merged[key].first;
    const int n = merged[key].second;
    r.rel_error /= n;
    r.convolve_ns /= n;
    r.project_ns /= n;
    rows.push_back(r);
  }
  return rows;
}

std::vector<RotationStudyRow> run_rotation_study(const Environment& environment, bool quick) {
  TiltStudyOptions tilt;
  tilt.capture_resolution = 128;  // the defaults of capture2qt and brdf2qt
  BrdfTableOptions o;
  if (quick) {
    tilt.capture_resolution = 64;
    tilt.tilts_degrees = {0, 5, 15, 30};
    tilt.axes = 2;
    tilt.wo_degrees = {0, 40};
    tilt.reference_subsamples = 1;
    o.wo_resolution = 17;
    o.wi_resolution = 32;
  }
  const Vec3 normal = speed_study_record(environment).normal;
  std::vector<RotationStudyRow> rows;
  for (const double exponent : {10.0, 100.0}) {
    const Brdf brdf = Phong{{0.5, 0.5, 0.5}, {0.4, 0.4, 0.4}, exponent};
    const BrdfTable table = tabulate_brdf(brdf, o);
    for (const TiltStudyRow& r : study_tilts(environment, normal, brdf, table.view(), tilt))
      rows.push_back({"phong" + std::to_string(int(exponent)), r});
  }
  return rows;
}

void write_comparison_csv(const std::string& path, const std::vector<ComparisonRow>& rows) {
  std::ostringstream out;
  out << "method,param,brdf,light,bytes,project_ns,convolve_ns,rel_error\n";
  for (const auto& r : rows)
    out << r.method << "," << r.param << "," << r.brdf << "," << r.light << "," << r.bytes << ","
        << r.project_ns << "," << r.convolve_ns << "," << r.rel_error << "\n";
  write_file_atomically(path, std::as_bytes(std::span(out.view().data(), out.view().size())));
}

void write_rotation_csv(const std::string& path, const std::string& map,
                        const std::vector<RotationStudyRow>& rows) {
  std::ostringstream out;
  out << "map,brdf,tilt_degrees,method,rel_error\n";
  for (const RotationStudyRow& r : rows)
    out << map << "," << r.brdf << "," << r.row.tilt_degrees << ","
        << (r.row.method == "sh_rotated" ? "sh" + std::to_string(r.row.sh_order) + "_rotated"
                                         : r.row.method)
        << "," << r.row.rel_error << "\n";
  write_file_atomically(path, std::as_bytes(std::span(out.view().data(), out.view().size())));
}

}  // namespace basis
