// qtrender: direct lighting from an HDR environment, with visibility, over a scene of OBJ meshes
// with per-material BRDFs: by Monte Carlo, or through a radiance cache of hemisphere captures
// stored as quadtrees or as dense grids.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "basis/core/version.h"
#include "basis/io/image_file.h"
#include "basis/io/json_text.h"
#include "basis/render/image_comparison.h"
#include "basis/render/renderer.h"
#include "cli.h"

namespace {

// The PNG beside an EXR: tone-mapped by `average` (the mean luminance it is shown at).
basis::Image tone_mapped(const basis::Image& image, double average) {
  basis::Image out(image.width, image.height, 3);
  for (std::size_t i = 0; i < out.pixels.size(); ++i)
    out.pixels[i] = basis::tone_map(image.pixels[i / 3 * image.channels + i % 3], float(average));
  return out;
}

double mean_luminance(const basis::Image& image, std::span<const std::uint8_t> covered) {
  double sum = 0;
  std::size_t n = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      if (covered[std::size_t(y) * image.width + x]) {
        sum += 0.2126 * image.at(x, y, 0) + 0.7152 * image.at(x, y, 1) + 0.0722 * image.at(x, y, 2);
        ++n;
      }
  return n ? std::max(1e-6, sum / double(n)) : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "Render direct lighting from an environment map with visibility, the integral of "
      "f(wi, wo) Li(wi) V(x, wi) cos(theta_i) over the hemisphere of every visible point (no "
      "interreflection), for a scene file (JSON: camera, environment, meshes with materials; "
      "README). One camera ray through each pixel's centre.\n\n"
      "Methods:\n"
      "  mc           Monte Carlo: --spp samples per pixel, each an environment draw (in "
      "proportion to the map's pixels, sun included) and a BRDF draw combined by multiple "
      "importance sampling, behind Embree shadow rays; or as many as fit in --time-budget.\n"
      "  cache        a radiance cache: records are hemisphere captures (compact lights kept "
      "apart) stored as quadtrees, valid within a radius from the harmonic mean distance of "
      "their occluders, placed in passes over finer and finer pixel grids, found through a "
      "k-d tree and interpolated (up to --records, Tabellion's weights), each shaded through "
      "the material's table tilted to the point's normal (rotation compensation), its lights "
      "turned exactly.\n"
      "  cache-dense  the same records stored as dense grids, shaded with dense products.\n\n"
      "Materials given as BRDF specs are tabulated with brdf2qt's defaults on first use and "
      "cached beside the spec as NAME.table.qt.\n"
      "Writes a linear EXR and a tone-mapped PNG beside it (the same name, .png).",
      "qtrender");
  std::string scene_path, output, method = "cache", compare, tilt = "compensated";
  int spp = 16, threads = 0, first_spacing = 32;
  double time_budget = 0;
  std::uint64_t seed = 1;
  bool json = false, quiet = false;
  basis::CacheOptions cache;
  app.add_option("scene", scene_path, "scene file (JSON)")->required();
  app.add_option("--method", method, "mc, cache (default) or cache-dense")
      ->check(CLI::IsMember({"mc", "cache", "cache-dense"}));
  app.add_option("--spp", spp, "mc: samples per pixel (default 16)")->check(CLI::Range(1, 1 << 20));
  app.add_option("--time-budget", time_budget,
                 "mc: render as many whole samples per pixel as fit in this many seconds "
                 "(loading excluded; at most a week, 604800)")
      ->check(basis::cli::positive_number())
      ->check(CLI::Range(0.0, 604800.0));
  app.add_option("-o,--output", output, "output EXR (default SCENE_METHOD.exr)");
  app.add_option("--compare", compare,
                 "reference EXR of the same size: report relative MSE and RMSE over the pixels "
                 "that hit geometry; the PNG is then tone-mapped as the reference would be");
  app.add_option("--seed", seed, "seed of the samples and of the records' jitter (default 1)")
      ->check(basis::cli::unsigned_number());
  app.add_option("--record-res", cache.resolution,
                 "cache: record texels per side, a power of two (default 32)");
  app.add_option("--record-spp", cache.strata,
                 "cache: rays per record texel along each axis, squared (default 1)")
      ->check(CLI::Range(1, 16));
  app.add_option("--tolerance", cache.tolerance,
                 "cache: projection tolerance of the records, relative to their mean (default "
                 "0.05)")
      ->check(basis::cli::non_negative_number());
  app.add_option("--radius-scale", cache.radius_scale,
                 "cache: validity radius as a multiple of the harmonic mean occluder distance "
                 "(default 1)")
      ->check(basis::cli::positive_number());
  app.add_option("--min-spacing", cache.min_spacing,
                 "cache: smallest validity radius, in pixels (default 1.5)")
      ->check(basis::cli::positive_number());
  app.add_option("--max-spacing", cache.max_spacing,
                 "cache: largest validity radius, in pixels (default 6)")
      ->check(basis::cli::positive_number());
  app.add_option("--max-normal", cache.max_normal_degrees,
                 "cache: normals further apart than this many degrees share no record (default "
                 "15)")
      ->check(basis::cli::finite_number())
      ->check(CLI::Range(0.1, 90.0));
  app.add_option("--records", cache.max_records,
                 "cache: records interpolated per pixel, at most (default 4)")
      ->check(CLI::Range(1, 16));
  app.add_option("--lookup-accuracy", cache.lookup_accuracy,
                 "cache: stop each lookup's descent once its certified bound is within this "
                 "fraction of the value (default 0: to the leaves)")
      ->check(basis::cli::finite_number())
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--first-spacing", first_spacing,
                 "cache: pixel spacing of the first placement pass (default 32)")
      ->check(CLI::Range(1, 4096));
  app.add_option("--tilt", tilt,
                 "cache: how records serve tilted normals: compensated (default), "
                 "reparametrised or none")
      ->check(CLI::IsMember({"compensated", "reparametrised", "none"}));
  app.add_option("--threads", threads, "worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  app.add_flag("--json", json, "print the summary as JSON");
  app.add_flag("-q,--quiet", quiet, "no progress bar, notes or summary (--json still prints)");
  app.set_version_flag("--version", basis::kVersion);

  return basis::cli::run(app, argc, argv, [&] {
    using basis::cli::UsageError;
    // Flags of the other method would be ignored: said rather than silently dropped.
    for (const char* flag : {"--spp", "--time-budget"})
      if (method != "mc" && app.count(flag) > 0)
        throw UsageError(std::string(flag) + " is for --method mc");
    for (const char* flag : {"--record-res", "--record-spp", "--tolerance", "--radius-scale",
                             "--min-spacing", "--max-spacing", "--max-normal", "--records",
                             "--lookup-accuracy", "--first-spacing", "--tilt"})
      if (method == "mc" && app.count(flag) > 0)
        throw UsageError(std::string(flag) + " is for --method cache or cache-dense");
    if (app.count("--spp") > 0 && app.count("--time-budget") > 0)
      throw UsageError("--spp and --time-budget exclude each other");
    if (!basis::is_valid_resolution(cache.resolution))
      throw UsageError("--record-res must be a power of two from 2 to 512, got " +
                       std::to_string(cache.resolution));
    if (cache.min_spacing > cache.max_spacing)
      throw UsageError("--min-spacing must not exceed --max-spacing");
    cache.tilt = tilt == "none"             ? basis::TiltCompensation::none
                 : tilt == "reparametrised" ? basis::TiltCompensation::reparametrised
                                            : basis::TiltCompensation::compensated;
    if (output.empty())
      output = std::filesystem::path(scene_path).stem().string() + "_" + method + ".exr";
    if (std::filesystem::path(output).extension() != ".exr")
      throw UsageError("-o names an EXR file (.exr), got " + output);
    const std::string png = std::filesystem::path(output).replace_extension(".png").string();
    basis::cli::check_outputs_spare_inputs({{"-o", output}, {"its PNG", png}},
                                           {{"scene", scene_path}, {"--compare", compare}});
    basis::cli::check_output_place(output);

    const basis::SceneFile file = basis::read_scene_file(scene_path);
    // The files the scene names (its map, meshes and materials) are inputs too.
    std::vector<basis::cli::NamedPath> named = {{scene_path, file.environment.map}};
    for (const basis::SceneFile::MeshSpec& mesh : file.meshes) {
      named.push_back({scene_path, mesh.obj});
      named.push_back({scene_path, mesh.material});
    }
    basis::cli::check_outputs_spare_inputs({{"-o", output}, {"its PNG", png}}, named);
    basis::Image reference;
    if (!compare.empty()) {
      reference = basis::read_image(compare);
      if (reference.width != file.camera.width || reference.height != file.camera.height ||
          reference.channels < 3)
        throw basis::FileError(compare + ": " + std::to_string(reference.width) + " x " +
                               std::to_string(reference.height) + " with " +
                               std::to_string(reference.channels) +
                               " channels, the scene renders " + std::to_string(file.camera.width) +
                               " x " + std::to_string(file.camera.height) + " RGB");
      if (const std::size_t invalid = basis::non_finite_rgb_values(reference); invalid > 0)
        throw basis::FileError(compare + ": " + std::to_string(invalid) +
                               " NaN or infinite RGB values; a reference must be finite");
    }
    const auto arena = basis::cli::thread_arena(threads);
    basis::SceneLoadOptions load;
    load.tables = method != "mc";
    if (!quiet)
      load.note = [](const std::string& line) {
        std::fprintf(stderr, "qtrender: %s\n", line.c_str());
      };
    const auto load_start = std::chrono::steady_clock::now();
    basis::RenderScene scene;
    {
      basis::cli::ProgressBar progress("qtrender: tabulating", quiet);
      load.control = progress.control();
      // The meshes' material files (mtllib) are inputs too, checked before any work on them.
      load.before_materials = [&](const std::vector<std::string>& files) {
        std::vector<basis::cli::NamedPath> material_files;
        for (const std::string& path : files)
          material_files.push_back(
              {scene_path, path, "a material file a mesh of " + scene_path + " names"});
        basis::cli::check_outputs_spare_inputs({{"-o", output}, {"its PNG", png}}, material_files);
      };
      scene = arena->execute([&] { return basis::load_render_scene(file, load); });
    }
    const double load_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();

    basis::RenderOptions options;
    options.method = method == "mc"      ? basis::RenderMethod::monte_carlo
                     : method == "cache" ? basis::RenderMethod::cache
                                         : basis::RenderMethod::cache_dense;
    options.spp = spp;
    options.time_budget = time_budget;
    options.seed = seed;
    options.cache = cache;
    options.coarsest_spacing = first_spacing;
    basis::cli::ProgressBar progress("qtrender", quiet);
    basis::RenderResult result;
    try {
      result = arena->execute([&] { return basis::render(scene, options, progress.control()); });
    } catch (const std::invalid_argument& e) {
      throw UsageError(e.what());
    }
    progress.finish();

    std::optional<basis::ImageErrors> errors;
    if (!compare.empty()) errors = basis::compare_images(result.image, reference, result.covered);
    const double average =
        mean_luminance(compare.empty() ? result.image : reference, result.covered);
    const basis::Image picture = tone_mapped(result.image, average);
    basis::write_images({{output, &result.image}, {png, &picture}});
    if (quiet && !json) return;
    const basis::RenderTimings& t = result.timings;
    if (json) {
      nlohmann::ordered_json j = {{"scene", scene_path},        {"method", method},
                                  {"output", output},           {"png", png},
                                  {"width", file.camera.width}, {"height", file.camera.height},
                                  {"load_s", load_seconds},     {"total_s", t.total},
                                  {"primary_s", t.primary}};
      if (method == "mc") {
        j["shading_s"] = t.shading;
        j["spp"] = result.spp;
      } else {
        j["record_tracing_s"] = t.record_tracing;
        j["projection_s"] = t.projection;
        j["convolution_s"] = t.lookup;
        j["interpolation_s"] = t.interpolation;
        j["records"] = result.records;
        j["record_bytes"] = result.record_bytes;
      }
      if (errors) {
        j["relmse"] = errors->relative_mse;
        j["rmse"] = errors->rmse;
        j["p99_relerr"] = errors->p99_relative_error;
        j["compared_pixels"] = errors->pixels;
      }
      std::cout << basis::json_text(j) << "\n";
      return;
    }
    std::printf("%s: %d x %d, %s, %.2f s (primary %.2f", output.c_str(), file.camera.width,
                file.camera.height, method.c_str(), t.total, t.primary);
    if (method == "mc")
      std::printf(", shading %.2f s; %d samples per pixel)\n", t.shading, result.spp);
    else
      std::printf(
          ", records %.2f, projection %.2f, convolution %.2f, interpolation %.2f s; "
          "%zu records, %.1f MiB)\n",
          t.record_tracing, t.projection, t.lookup, t.interpolation, result.records,
          double(result.record_bytes) / (1 << 20));
    if (errors)
      std::printf(
          "against %s: relative MSE %.3g, RMSE %.3g, 99th percentile of the relative "
          "error %.3g, over %zu pixels\n",
          compare.c_str(), errors->relative_mse, errors->rmse, errors->p99_relative_error,
          errors->pixels);
  });
}
