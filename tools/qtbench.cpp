// qtbench: the speed-versus-accuracy chart. The same hemisphere functions (BRDF slices and
// captures of a real HDR map with a sun, with and without an occluder) in every basis, each
// convolution timed and compared with the integral over the map's pixels.
#include <spawn.h>
#include <sys/wait.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>

#include "basis/brdf/brdf_table.h"
#include "basis/brdf/rgl.h"
#include "basis/core/version.h"
#include "basis/io/image_file.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/embree_scene.h"
#include "basis/study/comparison.h"
#include "basis/study/reference.h"
#include "basis/study/tilt_study.h"
#include "cli.h"

extern char** environ;

namespace {

using namespace basis;

struct Panel {
  std::string name;
  Brdf brdf;
};

// The panels; `measured` is an RGL .bsdf file to add as a panel when it exists.
std::vector<Panel> panels(bool quick, const std::string& measured) {
  const Color kd{0.5, 0.5, 0.5}, ks{0.4, 0.4, 0.4}, g{0.1, 0.1, 0.1}, f0{0.9, 0.9, 0.9};
  std::vector<Panel> all = {
      {"lambert", Lambert{{0.8, 0.8, 0.8}}}, {"phong10", Phong{kd, ks, 10}},
      {"phong100", Phong{kd, ks, 100}},      {"phong1000", Phong{kd, ks, 1000}},
      {"ggx0.5", Ggx{g, f0, 0.5}},           {"ggx0.1", Ggx{g, f0, 0.1}},
      {"ggx0.02", Ggx{g, f0, 0.02}}};
  if (quick) all = {all[0], all[2], all[5]};
  if (!measured.empty() && std::filesystem::exists(measured))
    all.push_back({"rgl:" + std::filesystem::path(measured).stem().string(),
                   std::shared_ptr<const MeasuredBrdf>(RglBrdf::read(measured))});
  return all;
}

// The brightest direction of the map (its sun).
Vec3 sun_direction(const Environment& env) {
  double best = -1;
  Vec3 sun = Vec3::UnitZ();
  for (const auto& b : env.bright_pixels()) {
    const double e = b.excess[0] + b.excess[1] + b.excess[2];
    if (e > best) {
      best = e;
      sun = env.direction(b.column + 0.5, b.row + 0.5);
    }
  }
  return sun;
}

// A wall on the side away from the sun, hiding part of the sky but not the sun.
TriangleMesh occluder(const Vec3& sun) {
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

void write_rows(const std::string& path, const std::vector<ComparisonRow>& rows) {
  std::ofstream out(path);
  out << "method,param,brdf,light,bytes,project_ns,convolve_ns,rel_error\n";
  for (const auto& r : rows)
    out << r.method << "," << r.param << "," << r.brdf << "," << r.light << "," << r.bytes << ","
        << r.project_ns << "," << r.convolve_ns << "," << r.rel_error << "\n";
  if (!out) throw FileError(path + ": cannot write");
}

bool run_plotter(const std::string& script, const std::vector<std::string>& args) {
  std::vector<std::string> storage = {"/usr/bin/python3", script};
  storage.insert(storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : storage)
    argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) return false;
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "The speed-versus-accuracy chart: BRDF slices (Lambert, Phong 10/100/1000, GGX "
      "0.5/0.1/0.02) against captures of a real HDR map with a sun (with and without an "
      "occluder), in the quadtree (several resolutions and tolerances), dense grids (8^2 to "
      "256^2, naive and vectorised), real spherical harmonics (orders 2 to 16) and Haar "
      "wavelets (16 to 1024 kept coefficients). Ground truth: the integral of the exact BRDF "
      "over the map's pixels, occlusion traced per pixel. Writes DIR/results.csv "
      "(method,param,brdf,light,bytes,project_ns,convolve_ns,rel_error), DIR/rotation.csv, "
      "and the charts DIR/chart.png, DIR/storage.png, DIR/rotation.png (matplotlib through "
      "/usr/bin/python3; the numbers come from here).",
      "qtbench");
  std::string out_dir, map, measured;
  bool quick = false;
  int threads = 0;
  app.add_option("--out", out_dir, "output folder (created if missing)")->required();
  app.add_flag("--quick", quick, "three panels, one light, fewer parameters: under a minute");
  app.add_option("--map", map,
                 "lat-long HDR map with a sun (default: the Poly Haven sunrise from Debian's "
                 "blender-data)");
  app.add_option("--measured", measured,
                 "an RGL EPFL .bsdf file to add as a panel (default: ../shared/data/rgl-bsdf's "
                 "satin_rosaline when present)");
  app.add_option("--threads", threads, "worker threads for the preparation (timings run on one)")
      ->check(CLI::Range(1, 1024));
  app.set_version_flag("--version", basis::kVersion);

  return basis::cli::run(app, argc, argv, [&] {
    const auto start = std::chrono::steady_clock::now();
    if (map.empty()) map = "/usr/share/blender/datafiles/studiolights/world/sunrise.exr";
    const Environment env(read_image(map));
    std::filesystem::create_directories(out_dir);

    // The record: at the origin, its normal 50 degrees up towards the sun's azimuth.
    const Vec3 sun = sun_direction(env);
    const double azimuth = std::atan2(sun.y(), sun.x());
    const double up = 50 * std::numbers::pi / 180;
    const Vec3 normal(std::cos(up) * std::cos(azimuth), std::cos(up) * std::sin(azimuth),
                      std::sin(up));
    const Frame frame = Frame::from_normal(normal);
    const TriangleMesh wall = occluder(sun);
    const EmbreeScene wall_scene(wall);
    const int finest = quick ? 128 : 256;
    struct Light {
      std::string name;
      const RayScene* scene;
      Grid grid;
    };
    std::vector<Light> lights = {{"sun", nullptr, {}}};
    if (!quick) lights.push_back({"sun+occluder", &wall_scene, {}});
    for (Light& l : lights)
      l.grid =
          capture(env, l.scene, Vec3::Zero(), frame, {.resolution = finest, .strata = 2}).texels;

    // Outgoing directions: where the sun's mirror image lies (the highlight), and oblique.
    const Vec3 sun_local = frame.to_local(sun);
    std::vector<Vec3> outgoing = {Vec3(-sun_local.x(), -sun_local.y(), sun_local.z()).normalized()};
    if (!quick) outgoing.push_back(Vec3(std::sin(0.5), 0, std::cos(0.5)));

    // Cases: grids and ground truths, prepared in parallel.
    if (measured.empty())
      for (const auto& folder : {std::string("../shared/data/rgl-bsdf"),
                                 std::string(BASIS_SOURCE_DIR) + "/../shared/data/rgl-bsdf"})
        if (std::filesystem::exists(folder + "/satin_rosaline_rgb.bsdf")) {
          measured = folder + "/satin_rosaline_rgb.bsdf";
          break;
        }
    const std::vector<Panel> brdfs = panels(quick, measured);
    std::vector<ComparisonCase> cases;
    std::vector<std::size_t> case_wo;
    for (const Panel& p : brdfs)
      for (const Light& l : lights)
        for (std::size_t w = 0; w < outgoing.size(); ++w) {
          cases.push_back({p.name, l.name, {}, l.grid, {}});
          case_wo.push_back(w);
        }
    basis::cli::ProgressBar progress("qtbench", false);
    const auto arena = basis::cli::thread_arena(threads);
    std::atomic<std::size_t> prepared{0};
    arena->execute([&] {
      tbb::parallel_for(std::size_t(0), cases.size(), [&](std::size_t i) {
        const Panel& p = *std::find_if(brdfs.begin(), brdfs.end(),
                                       [&](const Panel& q) { return q.name == cases[i].brdf; });
        const Light& l = *std::find_if(lights.begin(), lights.end(),
                                       [&](const Light& q) { return q.name == cases[i].light; });
        BrdfTableOptions o;
        o.wi_resolution = finest;
        cases[i].brdf_grid = tabulate_entry(p.brdf, outgoing[case_wo[i]], o);
        cases[i].truth = reference_reflection(env, l.scene, Vec3::Zero(), frame, p.brdf,
                                              outgoing[case_wo[i]], quick ? 1 : 2);
        progress.control().report(++prepared, cases.size());
      });
    });
    progress.finish();

    // Timings, one case at a time; rows averaged over the outgoing directions.
    ComparisonOptions options;
    if (quick) {
      options.quadtree_resolutions = {32, 128};
      options.quadtree_tolerances = {0.01, 0.05, 0.3};
      options.dense_resolutions = {8, 32, 128};
      options.sh_orders = {2, 4, 8, 16};
      options.haar_kept = {16, 128, 1024};
      options.seconds_per_timing = 0.004;
    }
    std::map<std::string, std::pair<ComparisonRow, int>> merged;
    std::vector<std::string> order;
    for (std::size_t i = 0; i < cases.size(); ++i) {
      basis::cli::interrupt_flag().load() ? throw Cancelled() : void();
      for (const ComparisonRow& r : compare_methods(cases[i], options)) {
        const std::string key = r.method + "|" + r.param + "|" + r.brdf + "|" + r.light;
        auto [it, fresh] = merged.try_emplace(key, r, 0);
        if (fresh) {
          order.push_back(key);
          it->second.first.rel_error = it->second.first.convolve_ns = it->second.first.project_ns =
              0;
        }
        ComparisonRow& m = it->second.first;
        m.rel_error += r.rel_error;
        m.convolve_ns += r.convolve_ns;
        m.project_ns += r.project_ns;
        ++it->second.second;
      }
      std::fprintf(stderr, "\rqtbench: measured %zu of %zu cases", i + 1, cases.size());
    }
    std::fprintf(stderr, "\n");
    std::vector<ComparisonRow> rows;
    for (const std::string& key : order) {
      ComparisonRow r = merged[key].first;
      const int n = merged[key].second;
      r.rel_error /= n;
      r.convolve_ns /= n;
      r.project_ns /= n;
      rows.push_back(r);
    }
    write_rows((std::filesystem::path(out_dir) / "results.csv").string(), rows);

    // The rotation study: Lambert 0.5 + Phong 10 and 100 (ks 0.4), quadtree against SH.
    {
      std::ofstream out(std::filesystem::path(out_dir) / "rotation.csv");
      out << "map,brdf,tilt_degrees,method,rel_error\n";
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
      for (const double exponent : {10.0, 100.0}) {
        const Brdf brdf = Phong{{0.5, 0.5, 0.5}, {0.4, 0.4, 0.4}, exponent};
        const BrdfTable table = arena->execute([&] { return tabulate_brdf(brdf, o); });
        const std::string name = "phong" + std::to_string(int(exponent));
        for (const TiltStudyRow& r : study_tilts(env, normal, brdf, table.view(), tilt))
          out << std::filesystem::path(map).stem().string() << "," << name << "," << r.tilt_degrees
              << ","
              << (r.method == "sh_rotated" ? "sh" + std::to_string(r.sh_order) + "_rotated"
                                           : r.method)
              << "," << r.rel_error << "\n";
      }
    }

    const std::string script = std::string(BASIS_SOURCE_DIR) + "/scripts/plot_bench.py";
    const bool plotted = std::filesystem::exists(script) && run_plotter(script, {out_dir});
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("qtbench: %zu rows in %s/results.csv, rotation in %s/rotation.csv%s, %.0f s\n",
                rows.size(), out_dir.c_str(), out_dir.c_str(),
                plotted ? ", charts chart.png, storage.png, rotation.png"
                        : " (charts not drawn: "
                          "run scripts/plot_bench.py DIR)",
                seconds);
  });
}
