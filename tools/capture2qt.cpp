// capture2qt: hemisphere captures of an HDR environment seen through a triangle scene (Embree),
// compressed into quadtrees (a .qt capture set); or one capture image compressed to a tree.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "basis/core/projection.h"
#include "basis/core/version.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_recipe.h"
#include "basis/format/qt_shard.h"
#include "basis/io/checksum.h"
#include "basis/io/image.h"
#include "basis/io/image_file.h"
#include "basis/io/json_text.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/capture_inputs.h"
#include "basis/lighting/embree_scene.h"
#include "basis/lighting/mesh.h"
#include "cli.h"

namespace {

// The --dump images of a run, removed again unless the run's output is written: a failed or
// interrupted capture leaves no output at all. Images are added from the capture's threads.
class DumpedImages {
 public:
  DumpedImages() = default;
  DumpedImages(const DumpedImages&) = delete;
  DumpedImages& operator=(const DumpedImages&) = delete;
  ~DumpedImages() {
    if (kept_) return;
    std::error_code ignored;
    for (const std::string& path : paths_)
      std::filesystem::remove(path, ignored);
  }
  void add(const std::string& path) {
    const std::lock_guard<std::mutex> lock(mutex_);
    paths_.push_back(path);
  }
  void keep() { kept_ = true; }

 private:
  std::mutex mutex_;
  std::vector<std::string> paths_;
  bool kept_ = false;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "Capture incident radiance L(w) V(x, w) over the hemisphere of surface points, lit by an "
      "HDR environment at infinity (lat-long, z up) and occluded by an optional triangle scene "
      "(OBJ; geometry only occludes, except materials with emission Ke, whose radiance it is), "
      "and compress each capture into a quadtree over the cosine-weighted concentric map.\n\n"
      "Every texel is an average over its footprint: spp jittered strata per texel; rays that "
      "escape take the environment averaged over their stratum's solid angle; bright "
      "environment pixels (a sun) are split into pieces whose energy goes exactly into the "
      "texel they fall in, behind a shadow ray, so that no sun is lost or multiplied. "
      "Bright pixels are those above 8 x the map's mean (at most 0.5 % of them); compact "
      "lights among them (a sun: connected pixels at least 4 times above that level, within 3 "
      "degrees) are kept apart as directions with their energy, which qtconvolve shades with "
      "the BRDF at their exact direction; --splat-lights puts them into texels instead. "
      "An environment map with NaN or infinite texels is refused (exit 1) unless --zero-invalid "
      "reads them as 0; negative texels are read as 0; a warning counts what was set to 0.\n\n"
      "With --shard I/N the work is one shard of a larger run, as for a job array (see "
      "scripts/slurm): shard I of N captures its own share of the points, each with the jitter it "
      "has in the whole run, so that qtmerge joins the shards into exactly the bytes one process "
      "writes, and qtconvolve and qtinfo read them through a manifest (qtmerge --manifest). A "
      "shard's file gets its checksum beside it (OUT.xxh128); --skip-existing leaves a shard whose "
      "file is complete and unaltered as it is, so that re-running an array re-does only the "
      "shards that failed.\n\n"
      "Or, with --image, compress one capture image (square, power-of-two side, texel (x, y) "
      "at pixel column x, row y) into a single-tree .qt file.",
      "capture2qt");
  std::string env_path, env_constant, scene_path, at, normal_text = "0,0,1", points_path, output,
                                                      dump, image_path, bounds = "l2", shard_text;
  double env_rotate = 0, tolerance = 0.05;
  long long sample = 0;
  std::uint64_t seed = 1;
  int res = 128, spp = 4, threads = 0;
  bool absolute = false, zero_invalid = false, quiet = false, json = false, splat = false,
       skip_existing = false;
  auto* light = app.add_option_group("light", "environment (one of)");
  light->add_option("--env", env_path,
                    "lat-long environment map (EXR, HDR, any format OpenImageIO reads; at most "
                    "2^28 pixels)");
  light->add_option("--env-constant", env_constant, "constant environment radiance R,G,B");
  app.add_option("--env-rotate", env_rotate,
                 "rotate the environment about z by this many degrees (-1e6 to 1e6)")
      ->check(basis::cli::number_between(-1e6, 1e6));
  app.add_option("--scene", scene_path,
                 "OBJ scene that occludes (polygons are triangulated; up to 4 GiB and 2^28 "
                 "triangles)");
  auto* where = app.add_option_group("points", "where to capture (one of)");
  CLI::Option* at_option = where->add_option("--at", at, "one point X,Y,Z (with --normal)");
  where->add_option("--points", points_path,
                    "CSV file of points: x,y,z,nx,ny,nz per line (up to 10^7 points)");
  where
      ->add_option("--sample", sample,
                   "N points uniformly over the scene's surfaces, normals facing the side the "
                   "triangles' counter-clockwise winding faces (up to 10^7 in one file, 10^12 "
                   "over the shards of a run)")
      ->check(CLI::Range(1LL, 1000000000000LL));
  where->add_option("--image", image_path, "compress this capture image instead of tracing");
  app.add_option("--normal", normal_text, "normal at --at (default 0,0,1)")->needs(at_option);
  app.add_option("--seed", seed, "seed of the jitter and of --sample (default 1)")
      ->check(basis::cli::unsigned_number());
  app.add_option(
      "--res", res,
      "texels per side of each capture, a power of two up to 512 (default 128: "
      "with the sun kept apart and qtconvolve --lights brdf, glossy reflections of a low "
      "sun err by up to 1.3 % at 64, 3.3 % at 32; splatted or with --lights table, up "
      "to 6 % at 64 and 5 % at 128; see README)");
  app.add_option("--spp", spp,
                 "rays per texel, a square number: strata per texel (default 4, up to 4096)")
      ->check(CLI::Range(1, 4096));
  app.add_option("--tolerance", tolerance,
                 "refine while a quadrant's error bound exceeds this fraction of the capture's "
                 "mean, lights kept apart included (default 0.05)")
      ->check(basis::cli::non_negative_number());
  app.add_flag("--absolute", absolute, "read --tolerance as an absolute radiance");
  app.add_option("--bounds", bounds,
                 "what the stored bounds bound: l2 (default), each quadrant's RMS deviation, "
                 "for the tightest certified lookups; or linf, its largest deviation from every "
                 "texel")
      ->check(CLI::IsMember({"l2", "linf"}));
  app.add_option("-o,--output", output,
                 "output .qt file (default captures.qt, or the image's name with .qt); a .qt "
                 "file holds at most 2 GiB, capturing stops with an error beyond");
  app.add_option("--dump", dump,
                 "also write every capture's texels as DIR/capture_KKKKK.exr (K zero-padded to "
                 "five digits; lights splatted in); new files only: an image of those names "
                 "already in DIR is an error before any work");
  app.add_flag("--splat-lights", splat,
               "put compact lights into the texels they fall in instead of keeping them apart");
  app.add_option("--threads", threads, "worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  app.add_option("--shard", shard_text,
                 "capture only shard I of N of the points (I from 0, e.g. "
                 "$SLURM_ARRAY_TASK_ID/4): points [floor(I P / N), floor((I + 1) P / N)) of the P "
                 "points, into OUT (default captures.I.qt) with its checksum in OUT.xxh128");
  app.add_flag("--skip-existing", skip_existing,
               "with --shard: if OUT already holds this shard, complete and unaltered (its "
               "checksum matches) and made with the same parameters, leave it and exit 0");
  app.add_flag("--zero-invalid", zero_invalid,
               "read NaN and infinite environment texels as 0 instead of refusing the map");
  app.add_flag("--json", json, "print the summary as JSON");
  app.add_flag("-q,--quiet", quiet, "no progress bar, warnings or summary (--json still prints)");
  app.set_version_flag("--version", basis::kVersion);

  return basis::cli::run(app, argc, argv, [&] {
    using basis::cli::UsageError;
    basis::cli::check_outputs_spare_inputs({{"-o", output}}, {{"--env", env_path},
                                                              {"--scene", scene_path},
                                                              {"--points", points_path},
                                                              {"--image", image_path}});
    // A shard's name goes into its checksum file's one line (the default name always fits).
    if (!shard_text.empty()) basis::check_name_fits_checksum_line(output);
    if (!basis::is_valid_resolution(res))
      throw UsageError("--res must be a power of two from 2 to 512, got " + std::to_string(res));
    const int strata = int(std::lround(std::sqrt(spp)));
    if (strata * strata != spp)
      throw UsageError("--spp must be a square number (1, 4, 9, 16, ...), got " +
                       std::to_string(spp));
    const basis::BoundKind bound_kind =
        bounds == "linf" ? basis::BoundKind::linf : basis::BoundKind::l2;
    basis::CaptureRecipe recipe;
    recipe.projection.tolerance = tolerance;
    if (absolute) recipe.projection.mode = basis::ProjectionOptions::Mode::absolute;
    const auto start = std::chrono::steady_clock::now();

    if (!image_path.empty()) {
      if (!env_path.empty() || !env_constant.empty() || !scene_path.empty() || !at.empty() ||
          !points_path.empty() || sample)
        throw UsageError("--image compresses an existing capture: no light, scene or points");
      if (!shard_text.empty() || skip_existing)
        throw UsageError("--image compresses one capture: no --shard or --skip-existing");
      for (const char* flag : {"--res", "--spp", "--seed", "--normal", "--splat-lights", "--dump",
                               "--zero-invalid", "--env-rotate", "--threads"})
        if (app.count(flag) > 0)
          throw UsageError(std::string(flag) + " shapes a traced capture; --image takes the " +
                           "image as it is");
      if (output.empty())
        output = std::filesystem::path(image_path).replace_extension(".qt").filename().string();
      basis::cli::check_outputs_spare_inputs({{"-o", output}}, {{"--image", image_path}});
      basis::cli::check_output_place(output);
      const basis::Grid grid = basis::image_to_grid(basis::read_image(image_path), image_path);
      basis::Quadtree tree;
      basis::PackedTree packed;
      try {
        tree = basis::project(grid, recipe.projection);
        packed = basis::pack_exact_texels(tree, bound_kind);
      } catch (const std::overflow_error& e) {
        throw basis::FileError(image_path + ": radiance too large: " + e.what());
      }
      const nlohmann::ordered_json parameters = {{"tolerance", tolerance},
                                                 {"mode", absolute ? "absolute" : "relative"}};
      basis::write_qt(
          output, basis::encode_tree(
                      packed.view(), recipe.projection,
                      {"capture2qt", basis::kVersion, basis::json_text(parameters), {image_path}}));
      if (json)
        std::cout << basis::json_text(nlohmann::ordered_json{{"output", output},
                                                             {"captures", 1},
                                                             {"resolution", grid.resolution},
                                                             {"nodes", tree.node_count()}})
                  << "\n";
      else if (!quiet)
        std::printf("%s: one capture of %d x %d texels, %d nodes\n", output.c_str(),
                    grid.resolution, grid.resolution, tree.node_count());
      return;
    }

    // Light: a map (NaN and infinities refused unless asked for; negative texels, which real
    // maps carry from their processing, read as 0 with a warning) or a constant.
    if (!env_path.empty() && !env_constant.empty())
      throw UsageError("--env and --env-constant exclude each other: give one light");
    if (env_path.empty() && env_constant.empty())
      throw UsageError("give the light: --env FILE or --env-constant R,G,B");
    for (const char* flag : {"--env-rotate", "--zero-invalid"})
      if (!env_constant.empty() && app.count(flag) > 0)
        throw UsageError(std::string(flag) + " is for --env: a constant light has no map");
    const int point_sources = int(!at.empty()) + int(!points_path.empty()) + int(sample > 0);
    if (point_sources > 1)
      throw UsageError("--at, --points and --sample exclude each other: give one set of points");
    if (point_sources == 0)
      throw UsageError("give the points: --at X,Y,Z, --points FILE or --sample N");
    if (!env_constant.empty()) {
      const basis::Vec3 c = basis::cli::parse_triple(env_constant, "--env-constant");
      if (c.minCoeff() < 0) throw UsageError("--env-constant must not be negative");
      if (c.maxCoeff() > std::numeric_limits<float>::max())
        throw UsageError("--env-constant " + env_constant +
                         ": radiance above the largest float (3.4e38)");
      recipe.constant = {c.x(), c.y(), c.z()};
    }
    recipe.environment = env_path;
    recipe.rotate_z_degrees = env_rotate;
    const basis::Environment environment =
        env_path.empty() ? basis::Environment::constant(recipe.constant)
                         : basis::Environment(basis::read_image(env_path), env_rotate, env_path);
    const std::string repaired = basis::repaired_texels_warning(
        environment, zero_invalid, "repair the map, or pass --zero-invalid to read them as 0");
    if (!quiet && !repaired.empty())
      std::fprintf(stderr, "capture2qt: warning: %s\n", repaired.c_str());

    // Scene and points.
    std::unique_ptr<basis::TriangleMesh> mesh;
    std::unique_ptr<basis::EmbreeScene> scene;
    if (!scene_path.empty()) {
      mesh = std::make_unique<basis::TriangleMesh>(basis::read_obj(scene_path));
      if (!quiet && mesh->dropped_degenerate > 0)
        std::fprintf(stderr, "capture2qt: warning: %s: %lld degenerate triangles dropped\n",
                     scene_path.c_str(), mesh->dropped_degenerate);
      for (const std::string& warning : mesh->reader_warnings)
        if (!quiet) std::fprintf(stderr, "capture2qt: warning: %s\n", warning.c_str());
      scene = std::make_unique<basis::EmbreeScene>(*mesh);
    }
    recipe.scene = scene_path;
    recipe.inputs_checksum = basis::capture_inputs_checksum(environment, mesh.get());
    // The provenance can name the inputs (refused before any work otherwise).
    static_cast<void>(basis::capture_parameters(recipe));
    std::vector<basis::SurfacePoint> points;
    if (int(!at.empty()) + int(!points_path.empty()) + int(sample > 0) != 1)
      throw UsageError("give the points: --at X,Y,Z, --points FILE or --sample N");
    if (skip_existing && shard_text.empty())
      throw UsageError("--skip-existing applies to shards: give --shard I/N");
    // The run's points, and the shard of them this process captures.
    std::uint64_t total_points = 0;
    if (!at.empty()) {
      const basis::Vec3 normal = basis::cli::parse_direction(normal_text, "--normal");
      points.push_back({basis::cli::parse_triple(at, "--at"), normal});
      total_points = 1;
    } else if (!points_path.empty()) {
      points = basis::read_points(points_path);
      total_points = points.size();
    } else {
      if (!mesh) throw UsageError("--sample places points on a scene: give --scene");
      total_points = std::uint64_t(sample);
    }
    basis::PointRange mine{0, total_points};
    if (!shard_text.empty()) {
      const basis::Shard shard = basis::cli::parse_shard_option(shard_text, total_points, "points");
      recipe.shard = basis::CaptureShard{shard, total_points};
      mine = recipe.shard->points();
      if (output.empty()) output = "captures." + std::to_string(shard.index) + ".qt";
    }
    if (mine.count > basis::kMaxSurfacePoints)
      throw UsageError(std::to_string(mine.count) + " points in one file, more than the " +
                       std::to_string(basis::kMaxSurfacePoints) +
                       " a capture set holds: split the run with --shard I/N");
    if (sample > 0)
      points = basis::sample_surface(*mesh, mine, seed);
    else if (mine.count != points.size())
      points = std::vector<basis::SurfacePoint>(points.begin() + std::ptrdiff_t(mine.first),
                                                points.begin() + std::ptrdiff_t(mine.end()));

    recipe.options = {.resolution = res,
                      .strata = strata,
                      .seed = seed,
                      .ray_offset = mesh ? mesh->ray_offset() : 1e-4,
                      .compact_lights = splat ? basis::CaptureOptions::CompactLights::splatted
                                              : basis::CaptureOptions::CompactLights::apart};
    basis::CaptureSetOptions options;
    options.capture = recipe.options;
    options.projection = recipe.projection;
    options.bounds = bound_kind;
    options.first_index = mine.first;
    if (output.empty()) output = "captures.qt";
    std::vector<std::string> sources;
    for (const std::string& source : {env_path, scene_path, points_path})
      if (!source.empty()) sources.push_back(source);
    if (recipe.shard) {
      const auto why = basis::why_shard_must_be_made(output, recipe, sources, bound_kind);
      if (skip_existing && !why) {
        if (json)
          std::cout << basis::json_text(nlohmann::ordered_json{
                           {"output", output}, {"shard", shard_text}, {"skipped", true}})
                    << "\n";
        else if (!quiet)
          std::printf("%s: shard %s present, complete and unaltered: skipped\n", output.c_str(),
                      shard_text.c_str());
        return;
      }
      if (skip_existing && !quiet)
        std::fprintf(stderr, "capture2qt: making shard %s: %s\n", shard_text.c_str(), why->c_str());
    }
    // The output, named now if it was not, spares every input, the scene's material files
    // included; its folder is there before any work (or any --dump image) is done.
    std::vector<basis::cli::NamedPath> inputs = {
        {"--env", env_path}, {"--scene", scene_path}, {"--points", points_path}};
    if (mesh)
      for (const std::string& file : mesh->material_files)
        inputs.push_back({"--scene", file, "a material file " + scene_path + " names"});
    // A shard's checksum file beside it is an output too.
    const std::string checksum = shard_text.empty() ? "" : basis::checksum_path(output);
    basis::cli::check_outputs_spare_inputs({{"-o", output}, {"the checksum of -o", checksum}},
                                           inputs);
    basis::cli::check_output_place(output);
    basis::cli::check_output_place(checksum);
    DumpedImages dumped;
    if (!dump.empty()) {
      if (!std::filesystem::is_directory(dump))
        throw basis::FileError(dump + ": not a directory (--dump writes into an existing one)");
      const auto dumped_name = [](std::size_t index) {
        char name[32];
        std::snprintf(name, sizeof name, "capture_%05zu.exr", index);
        return std::string(name);
      };
      const auto dumped_path = [&](std::size_t index) {
        return (std::filesystem::path(dump) / dumped_name(index)).string();
      };
      // Images are new files only: one already there (an earlier run's, or an input) is kept,
      // and none is the output.
      std::error_code error;
      const std::filesystem::path output_at = std::filesystem::weakly_canonical(output, error);
      const std::filesystem::path dump_at = std::filesystem::weakly_canonical(dump, error);
      for (std::size_t k = 0; k < points.size(); ++k) {
        const std::string path = dumped_path(options.first_index + k);
        if (std::filesystem::exists(path))
          throw basis::FileError(path +
                                 ": already there; --dump writes only new images (empty "
                                 "the folder or choose another)");
        if (output_at == dump_at / dumped_name(options.first_index + k))
          throw UsageError("-o " + output + " is an image --dump writes: name another file");
      }
      options.on_grid = [&, dumped_path](std::size_t index, const basis::Grid& grid,
                                         std::span<const basis::DirectionalLight> lights) {
        basis::Grid texels = grid;
        basis::splat_lights(lights, texels);
        const std::string path = dumped_path(index);
        basis::write_image(path, basis::grid_to_image(texels));
        dumped.add(path);
      };
    }
    const auto arena = basis::cli::thread_arena(threads);
    basis::cli::ProgressBar progress("capture2qt", quiet);
    basis::CaptureTimings timings;
    const basis::CaptureSet set = arena->execute([&] {
      return basis::capture_set(environment, scene.get(), points, options, progress.control(),
                                &timings);
    });
    progress.finish();

    const auto bytes = basis::encode_capture_set(
        set.view(), recipe.projection,
        {"capture2qt", basis::kVersion, basis::capture_parameters(recipe), sources});
    if (recipe.shard)
      basis::write_shard_file(output, bytes);
    else
      basis::write_unsharded_file(output, bytes);
    dumped.keep();
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (quiet && !json) return;
    const std::size_t nodes = set.trees.view().total_nodes();
    if (json) {
      std::cout << basis::json_text(
                       nlohmann::ordered_json{{"output", output},
                                              {"captures", set.positions.size()},
                                              {"first_point", mine.first},
                                              {"total_points", total_points},
                                              {"nodes", nodes},
                                              {"environment_lights", environment.lights().size()},
                                              {"lights", set.lights.size()},
                                              {"bytes", bytes.size()},
                                              {"rays", timings.stats.rays},
                                              {"capture_seconds", timings.capture_seconds},
                                              {"projection_seconds", timings.projection_seconds},
                                              {"seconds", seconds}})
                << "\n";
      return;
    }
    std::printf(
        "%s: %zu captures of %d x %d texels (%d rays each), %zu nodes (%.1f per "
        "capture), %zu directional lights kept apart over the captures (from %zu compact lights in "
        "the environment%s), %.2f MiB; %.2f M rays, "
        "projection %.1f %% of capture time, %.2f s\n",
        output.c_str(), set.positions.size(), res, res, spp, nodes,
        double(nodes) / double(set.positions.size()), set.lights.size(),
        environment.lights().size(), splat ? ", splatted" : "", double(bytes.size()) / (1 << 20),
        double(timings.stats.rays) * 1e-6,
        100 * timings.projection_seconds / std::max(1e-12, timings.capture_seconds), seconds);
  });
}
