// qtbench: the speed-versus-accuracy chart. The same hemisphere functions (BRDF slices and
// captures of a real HDR map with a sun, with and without an occluder) in every basis, each
// convolution timed and compared with the integral over the map's pixels.
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>

#include "basis/core/file_error.h"
#include "basis/core/version.h"
#include "basis/io/image_file.h"
#include "basis/study/speed_study.h"
#include "basis/study/wo_study.h"
#include "cli.h"

extern char** environ;

namespace {

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

// A file of the real inputs beside the project (../shared/data/RELATIVE, from the working
// folder or the source tree), or "" when absent.
std::string shared_data(const std::string& relative) {
  for (const std::string& root : {std::string(".."), std::string(BASIS_SOURCE_DIR) + "/.."})
    if (const std::string path = root + "/shared/data/" + relative; std::filesystem::exists(path))
      return path;
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "The speed-versus-accuracy chart: BRDF slices (Lambert, Phong 10/100/1000, GGX "
      "0.5/0.1/0.02) against captures of a real HDR map with a sun (with and without an "
      "occluder, and at points of a real scene, averaged over them), in packed quadtrees "
      "(several resolutions and tolerances, full and accuracy-targeted descents), dense grids (8^2 "
      "to "
      "256^2, naive and vectorised), real spherical harmonics (orders 2 to 16) and Haar "
      "wavelets (16 to 1024 kept coefficients). Ground truth: the integral of the exact BRDF "
      "over the map's pixels, occlusion traced per pixel. Writes DIR/results.csv "
      "(method,param,brdf,light,bytes,project_ns,convolve_ns,rel_error), DIR/rotation.csv, "
      "DIR/lookups.csv (lookups between table entries: error against the offset from the "
      "nearest entry, the first version's bilinear tables against the default Hermite ones, "
      "under a map of bright windows and the shared probes uffizi and grace when present), "
      "DIR/lookup_sources.csv (where that error comes from), the charts DIR/chart.png, "
      "DIR/storage.png, DIR/rotation.png, DIR/lookups.png and DIR/summary.md (matplotlib "
      "through /usr/bin/python3; the numbers come from here).",
      "qtbench");
  std::string out_dir, map, measured, scene = std::string(BASIS_SOURCE_DIR) + "/data/scene.obj";
  bool quick = false, lookups_only = false;
  int threads = 0, scene_points = 0;
  app.add_option("--out", out_dir, "output folder (created if missing)")->required();
  app.add_flag("--quick", quick, "three panels, one light, fewer parameters: under a minute");
  app.add_flag("--lookups-only", lookups_only,
               "only the study of lookups between table entries (lookups.csv, "
               "lookup_sources.csv, lookups.png, summary.md): about 35 s, 5 s with --quick");
  app.add_option("--map", map,
                 "lat-long HDR map with a sun (default: the Poly Haven sunrise from Debian's "
                 "blender-data)");
  app.add_option("--measured", measured,
                 "an RGL EPFL .bsdf file to add as a panel (default: ../shared/data/rgl-bsdf's "
                 "satin_rosaline when present)");
  app.add_option("--scene", scene,
                 "OBJ scene of the real-scene panel: captures at points sampled on it, errors and "
                 "times averaged over them (default: data/scene.obj, the main job's)");
  app.add_option("--scene-points", scene_points,
                 "points of the real-scene panel (default 8, 4 with --quick; 0 leaves it out)")
      ->check(CLI::Range(0, 10000));
  app.add_option("--threads", threads, "worker threads for the preparation (timings run on one)")
      ->check(CLI::Range(1, 1024));
  app.set_version_flag("--version", basis::kVersion);

  return basis::cli::run(app, argc, argv, [&] {
    const auto start = std::chrono::steady_clock::now();
    if (lookups_only)
      for (const char* flag : {"--map", "--measured", "--scene", "--scene-points"})
        if (app.count(flag) > 0)
          throw basis::cli::UsageError(std::string(flag) +
                                       " shapes the full study's panels: not with --lookups-only");
    if (map.empty()) map = "/usr/share/blender/datafiles/studiolights/world/sunrise.exr";
    std::optional<basis::Environment> env;
    if (!lookups_only) env.emplace(basis::read_image(map), 0, map);
    std::error_code error;
    std::filesystem::create_directories(out_dir, error);
    if (error || !std::filesystem::is_directory(out_dir))
      throw basis::FileError(
          out_dir + ": cannot be the output folder: " + (error ? error.message() : "not a folder"));
    basis::SpeedStudyOptions options{.quick = quick, .measured = measured, .scene = scene};
    options.scene_points = app.count("--scene-points") ? scene_points : quick ? 4 : 8;
    if (options.measured.empty())
      options.measured = shared_data("rgl-bsdf/satin_rosaline_rgb.bsdf");
    const auto arena = basis::cli::thread_arena(threads);
    const std::filesystem::path out(out_dir);
    std::size_t rows = 0;
    if (!lookups_only) {
      basis::cli::ProgressBar preparing("qtbench: cases", false);
      const std::vector<basis::ComparisonCase> cases = arena->execute([&] {
        return basis::speed_study_cases(*env, basis::speed_study_panels(options), options,
                                        preparing.control());
      });
      preparing.finish();
      basis::cli::ProgressBar timing("qtbench: timings", false);
      const std::vector<basis::ComparisonRow> results =
          basis::run_speed_study(cases, basis::speed_study_comparison(quick), timing.control());
      timing.finish();
      basis::write_comparison_csv((out / "results.csv").string(), results);
      rows = results.size();
      const auto rotation = arena->execute([&] { return basis::run_rotation_study(*env, quick); });
      basis::write_rotation_csv((out / "rotation.csv").string(),
                                std::filesystem::path(map).stem().string(), rotation);
    }

    // Lookups between table entries under high-contrast light: the synthetic windows and the
    // shared probes with the most contrast, when present.
    std::vector<std::string> probes;
    for (const std::string name : {"uffizi", "grace"})
      if (const std::string path = shared_data("probes/" + name + ".hdr"); !path.empty())
        probes.push_back(path);
    const std::vector<basis::WoStudyMap> lookup_maps = basis::wo_study_maps(probes);
    basis::cli::ProgressBar lookups("qtbench: lookups", false);
    const auto brdfs = basis::wo_study_brdfs(quick);
    const auto offsets = arena->execute(
        [&] { return basis::wo_offset_study(lookup_maps, brdfs, quick, lookups.control()); });
    const auto sources =
        arena->execute([&] { return basis::wo_error_sources(lookup_maps, brdfs); });
    lookups.finish();
    basis::write_wo_csv((out / "lookups.csv").string(), offsets);
    basis::write_wo_sources_csv((out / "lookup_sources.csv").string(), sources);

    const std::string script = std::string(BASIS_SOURCE_DIR) + "/scripts/plot_bench.py";
    const bool plotted = std::filesystem::exists(script) && run_plotter(script, {out_dir});
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const std::string tables = lookups_only ? "lookups.csv, lookup_sources.csv"
                                            : std::to_string(rows) +
                                                  " rows in results.csv; rotation.csv, "
                                                  "lookups.csv, lookup_sources.csv";
    const std::string charts = lookups_only
                                   ? "charts lookups.png, summary.md"
                                   : "charts chart.png, storage.png, rotation.png, lookups.png, "
                                     "summary.md";
    std::printf("qtbench: in %s: %s, %s, %.0f s\n", out_dir.c_str(), tables.c_str(),
                plotted ? charts.c_str() : "charts not drawn (run scripts/plot_bench.py DIR)",
                seconds);
  });
}
