// qtconvolve: convolve .qt files. Two trees give their integral; a BRDF table and captures give
// the reflected radiance at every capture; two capture sets give their products point by point.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "basis/core/dense.h"
#include "basis/core/hemisphere.h"
#include "basis/core/version.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_recipe.h"
#include "basis/io/image_file.h"
#include "basis/io/picture.h"
#include "basis/lighting/embree_scene.h"
#include "basis/lighting/shading.h"
#include "cli.h"

namespace {

using basis::cli::UsageError;

struct Row {
  basis::Convolution result;
  std::optional<basis::Rgb> reference;
};

// Full-resolution references for a table and captures (untilted): the four entries' texel
// grids re-tabulated from the stored spec and every capture re-traced from its recipe, then
// multiplied texel by texel.
std::vector<basis::Rgb> references(const basis::QtFile& table_file,
                                   const basis::QtFile& captures_file, const basis::Vec3& wo,
                                   const basis::Brdf* light_brdf,
                                   const basis::cli::ProgressBar& progress) {
  const basis::BrdfTableView table = table_file.brdf_table();
  const basis::CaptureSetView captures = captures_file.captures();
  const basis::BrdfSpec spec = basis::table_brdf(table_file);
  const basis::CaptureRecipe recipe = basis::capture_recipe(captures_file);
  if (recipe.options.resolution != table.trees.shape().resolution)
    throw UsageError("--reference needs the table and the captures at one resolution (" +
                     std::to_string(table.trees.shape().resolution) + " and " +
                     std::to_string(recipe.options.resolution) + ")");
  const basis::Environment environment =
      recipe.environment.empty()
          ? basis::Environment::constant(recipe.constant)
          : basis::Environment(basis::read_image(recipe.environment), recipe.rotate_z_degrees);
  std::unique_ptr<basis::EmbreeScene> scene;
  if (!recipe.scene.empty())
    scene = std::make_unique<basis::EmbreeScene>(basis::read_obj(recipe.scene));
  // The four entries around wo, as the lookup weighs them.
  basis::BrdfTableOptions options;
  options.wo_resolution = table.wo_resolution;
  options.wi_resolution = table.trees.shape().resolution;
  std::vector<std::pair<double, basis::Grid>> entries;
  for (const basis::TableTap& tap : basis::table_taps(table.wo_resolution, wo))
    entries.emplace_back(
        tap.weight,
        basis::tabulate_entry(spec.brdf, basis::table_outgoing(tap.i, tap.j, options.wo_resolution),
                              options));
  const bool lights_apart = !captures.light_offsets.empty();
  std::vector<basis::Rgb> out(captures.size());
  for (std::size_t k = 0; k < captures.size(); ++k) {
    progress.control().check();
    basis::CaptureOptions options = recipe.options;
    options.compact_lights = lights_apart ? basis::CaptureOptions::CompactLights::apart
                                          : basis::CaptureOptions::CompactLights::splatted;
    const basis::Capture c = basis::capture(environment, scene.get(), captures.positions[k],
                                            captures.frame(k), options, k);
    const basis::Grid& grid = c.texels;
    const std::vector<basis::DirectionalLight>& lights = c.lights;
    basis::Rgb sum{0, 0, 0};
    for (const auto& [weight, entry] : entries) {
      const basis::Rgb d = basis::dense_convolve_naive(entry, grid);
      for (int c = 0; c < 3; ++c)
        sum[c] += float(weight * std::numbers::pi * d[c]);
    }
    // Directional lights: f at the light (the BRDF itself, or the entries' texels there).
    for (const basis::DirectionalLight& light : lights) {
      const basis::Vec3& wi = light.direction;
      basis::Color f{0, 0, 0};
      if (light_brdf) {
        f = basis::evaluate(*light_brdf, wi, wo);
      } else {
        for (const auto& [weight, entry] : entries) {
          const auto [x, y] = basis::cosine_hemisphere_texel(wi, entry.resolution);
          for (int c = 0; c < 3; ++c)
            f[c] += weight * entry.at(0, std::min(c, entry.channels - 1), x, y);
        }
      }
      for (int c = 0; c < 3; ++c)
        sum[c] += float(f[c] * light.energy[c] * wi.z());
    }
    out[k] = sum;
    progress.control().report(k + 1, captures.size());
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "Convolve .qt files, by simultaneous descent of their quadtrees, with a certified bound.\n"
      "  TREE x TREE: the hemisphere integral of A B cos (pi times their product's integral "
      "over the cosine-weighted map).\n"
      "  TABLE x CAPTURES (either order): the reflected radiance Lo(wo) at every capture point, "
      "four table entries around wo convolved and interpolated bilinearly; TABLE x TREE: the "
      "same for one capture image.\n"
      "  CAPTURES x CAPTURES: the integral of their product at every point (the sets must hold "
      "the same points).\n"
      "Values are RGB (a grey file counts for all three); each comes with a bound on its "
      "difference to the product of the full-resolution texels (for tables: of the four entries "
      "used, not of the BRDF between entries). Trees of different resolutions convolve as the "
      "piecewise-constant functions they are.\n"
      "Captures may carry directional lights (a sun kept apart by capture2qt): a table shades "
      "them with f at their direction (--lights); a product of captures counts each in the "
      "texel it falls in.",
      "qtconvolve");
  std::string a_path, b_path, wo_text = "0,0,1", normal_text, tilt_mode = "compensated", png,
                              lights_from = "brdf";
  bool json = false, csv = false, reference = false, time = false, quiet = false;
  int threads = 0;
  app.add_option("a", a_path, "first .qt file")->required();
  app.add_option("b", b_path, "second .qt file")->required();
  app.add_option("--wo", wo_text,
                 "outgoing direction X,Y,Z in each capture's local frame (z the normal; default "
                 "the normal), z >= 0");
  app.add_option("--normal", normal_text,
                 "shade as if the surface normal at every point were this world direction: the "
                 "table is re-parametrised and compensated for the tilt (good to about 10 "
                 "degrees, see README); --wo is then in the tilted frame");
  app.add_option("--tilt", tilt_mode,
                 "tilt handling with --normal: none, reparametrised, "
                 "compensated (default)")
      ->check(CLI::IsMember({"none", "reparametrised", "compensated"}));
  app.add_option("--lights", lights_from,
                 "f for the captures' directional lights (a sun): brdf (default), the BRDF "
                 "whose spec the table stores, at the light's exact direction (a measured BRDF "
                 "needs its data file where the spec was; the table is used when it is "
                 "missing), or table, the table's texel where the light falls (less accurate "
                 "near the horizon, see README)")
      ->check(CLI::IsMember({"brdf", "table"}));
  app.add_flag("--json", json, "print {\"results\": [{\"index\", \"value\", \"bound\"}, ...]}");
  app.add_flag("--csv", csv, "print CSV: index,r,g,b,bound_r,bound_g,bound_b[,reference...]");
  app.add_flag("--reference", reference,
               "also compute the full-resolution product per point (table re-tabulated from "
               "its stored spec, captures re-traced from their recorded inputs) and the "
               "difference");
  app.add_flag("--time", time, "report the median time per convolution over repeated runs");
  app.add_option("--png", png, "draw the capture points from above, coloured by their values");
  app.add_option("--threads", threads, "worker threads for --reference (default: all cores)")
      ->check(CLI::Range(1, 1024));
  app.add_flag("-q,--quiet", quiet, "no progress bar");
  app.set_version_flag("--version", basis::kVersion);

  return basis::cli::run(app, argc, argv, [&] {
    if (json && csv) throw UsageError("--json and --csv exclude each other");
    const basis::QtFile a = basis::QtFile::load(a_path);
    const basis::QtFile b = basis::QtFile::load(b_path);
    const auto wo_triple = basis::cli::parse_triple(wo_text, "--wo");
    const basis::Vec3 wo(wo_triple[0], wo_triple[1], wo_triple[2]);
    if (!(wo.norm() > 1e-12)) throw UsageError("--wo must not be zero");
    if (wo.z() < 0) throw UsageError("--wo is below the horizon (z < 0)");
    basis::ShadingOptions shading;
    shading.wo = wo.normalized();
    if (!normal_text.empty()) {
      const auto n = basis::cli::parse_triple(normal_text, "--normal");
      const basis::Vec3 normal(n[0], n[1], n[2]);
      if (!(normal.norm() > 1e-12)) throw UsageError("--normal must not be zero");
      shading.normal = normal.normalized();
      shading.tilt_mode = tilt_mode == "none"             ? basis::TiltCompensation::none
                          : tilt_mode == "reparametrised" ? basis::TiltCompensation::reparametrised
                                                          : basis::TiltCompensation::compensated;
    }

    using basis::QtKind;
    const basis::QtFile* table = a.kind() == QtKind::brdf_table   ? &a
                                 : b.kind() == QtKind::brdf_table ? &b
                                                                  : nullptr;
    const basis::QtFile* other = table == &a ? &b : &a;
    if (table && other->kind() == QtKind::brdf_table)
      throw basis::FileError(b_path +
                             ": two BRDF tables cannot be convolved; give a table and "
                             "captures");
    if (!table && (!normal_text.empty() || wo_text != "0,0,1"))
      throw UsageError("--wo and --normal apply to a BRDF table and captures");
    if (reference && (!table || other->kind() != QtKind::capture_set || shading.normal))
      throw UsageError("--reference compares an untilted BRDF table lookup with captures");
    if (!png.empty() && (!table || other->kind() != QtKind::capture_set) &&
        !(a.kind() == QtKind::capture_set && b.kind() == QtKind::capture_set))
      throw UsageError("--png draws capture points: give captures");
    if (a.kind() == QtKind::capture_set && b.kind() == QtKind::capture_set) {
      const auto ca = a.captures(), cb = b.captures();
      if (ca.size() != cb.size() ||
          !std::equal(ca.positions.begin(), ca.positions.end(), cb.positions.begin()) ||
          !std::equal(ca.normals.begin(), ca.normals.end(), cb.normals.begin()))
        throw basis::FileError(b_path + ": the two capture sets do not hold the same points");
    }

    // The BRDF for directional lights, from the table's stored spec.
    std::optional<basis::BrdfSpec> light_spec;
    if (table && other->kind() == QtKind::capture_set && !other->captures().lights.empty() &&
        lights_from == "brdf") {
      try {
        light_spec = basis::table_brdf(*table);
        shading.light_brdf = &light_spec->brdf;
      } catch (const basis::FileError& e) {
        // Always said, -q or not: the lights lose accuracy (see --lights).
        std::fprintf(stderr, "qtconvolve: warning: %s; directional lights use the table's texels\n",
                     e.what());
      }
    }

    // One evaluation of everything: the convolutions the user asked for.
    const std::size_t count =
        table ? other->trees().size() : std::max(a.trees().size(), b.trees().size());
    auto as_captures = [](const basis::QtFile& f) {
      return f.kind() == QtKind::capture_set ? f.captures()
                                             : basis::CaptureSetView{{}, {}, {}, f.trees(), {}, {}};
    };
    auto evaluate = [&](std::size_t k) -> basis::Convolution {
      if (table) {
        if (other->kind() == QtKind::capture_set)
          return basis::shade(table->brdf_table(), other->captures(), k, shading);
        return basis::reflect(table->brdf_table(), other->tree(), shading.wo);
      }
      return basis::capture_product(as_captures(a), as_captures(b), k);
    };
    std::vector<Row> rows(count);
    for (std::size_t k = 0; k < count; ++k)
      rows[k].result = evaluate(k);

    double ns_per_convolution = -1, ns_per_lookup = -1;
    if (time) {
      // Repeat the whole batch until 0.2 s have passed (at least 5 runs); report the median.
      std::vector<double> runs;
      const auto begin = std::chrono::steady_clock::now();
      float sink = 0;
      while (runs.size() < 5 ||
             std::chrono::steady_clock::now() - begin < std::chrono::milliseconds(200)) {
        const auto t0 = std::chrono::steady_clock::now();
        for (std::size_t k = 0; k < count; ++k)
          sink += evaluate(k).value[0];
        runs.push_back(
            std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0)
                .count());
        if (runs.size() > 100000) break;
      }
      std::nth_element(runs.begin(), runs.begin() + runs.size() / 2, runs.end());
      ns_per_lookup = runs[runs.size() / 2] / double(count);
      const bool compensated =
          shading.normal && shading.tilt_mode == basis::TiltCompensation::compensated;
      ns_per_convolution = table ? ns_per_lookup / (compensated ? 8 : 4) : ns_per_lookup;
      if (sink == -1) std::cerr << "";
    }

    if (reference) {
      const auto arena = basis::cli::thread_arena(threads);
      basis::cli::ProgressBar progress("qtconvolve --reference", quiet || (!json && !csv && false));
      const auto refs = arena->execute(
          [&] { return references(*table, *other, shading.wo, shading.light_brdf, progress); });
      progress.finish();
      for (std::size_t k = 0; k < count; ++k)
        rows[k].reference = refs[k];
    }

    if (!png.empty()) {
      const basis::CaptureSetView c =
          other->kind() == QtKind::capture_set ? other->captures() : a.captures();
      std::vector<basis::Rgb> values(count);
      for (std::size_t k = 0; k < count; ++k)
        values[k] = rows[k].result.value;
      basis::write_image(png, basis::draw_points_from_above(c.positions, values, 768));
    }

    if (json) {
      nlohmann::ordered_json j;
      j["results"] = nlohmann::ordered_json::array();
      for (std::size_t k = 0; k < count; ++k) {
        nlohmann::ordered_json r = {
            {"index", k}, {"value", rows[k].result.value}, {"bound", rows[k].result.bound}};
        if (rows[k].reference) {
          basis::Rgb d;
          for (int c = 0; c < 3; ++c)
            d[c] = rows[k].result.value[c] - (*rows[k].reference)[c];
          r["reference"] = *rows[k].reference;
          r["difference"] = d;
        }
        j["results"].push_back(r);
      }
      if (time) {
        j["ns_per_convolution"] = ns_per_convolution;
        j["ns_per_lookup"] = ns_per_lookup;
      }
      std::cout << j.dump(1) << "\n";
      return;
    }
    if (csv) {
      std::printf("index,r,g,b,bound_r,bound_g,bound_b%s\n",
                  reference ? ",reference_r,reference_g,reference_b" : "");
      for (std::size_t k = 0; k < count; ++k) {
        const auto& r = rows[k].result;
        std::printf("%zu,%.7g,%.7g,%.7g,%.4g,%.4g,%.4g", k, r.value[0], r.value[1], r.value[2],
                    r.bound[0], r.bound[1], r.bound[2]);
        if (rows[k].reference)
          std::printf(",%.7g,%.7g,%.7g", (*rows[k].reference)[0], (*rows[k].reference)[1],
                      (*rows[k].reference)[2]);
        std::printf("\n");
      }
      if (time) std::fprintf(stderr, "qtconvolve: %.1f ns per convolution\n", ns_per_convolution);
      return;
    }
    if (count == 1 && !table) {
      const auto& r = rows[0].result;
      std::printf("integral %.7g %.7g %.7g  +- %.3g %.3g %.3g\n", r.value[0], r.value[1],
                  r.value[2], r.bound[0], r.bound[1], r.bound[2]);
    } else {
      std::printf("# %s%s, RGB value +- certified bound%s\n",
                  table ? "reflected radiance at each capture" : "integral at each point",
                  shading.normal ? " (tilted normal)" : "",
                  reference ? "; full-resolution reference; difference" : "");
      for (std::size_t k = 0; k < count; ++k) {
        const auto& r = rows[k].result;
        std::printf("%zu  %.6g %.6g %.6g  +- %.3g %.3g %.3g", k, r.value[0], r.value[1], r.value[2],
                    r.bound[0], r.bound[1], r.bound[2]);
        if (rows[k].reference) {
          const auto& f = *rows[k].reference;
          std::printf("  ref %.6g %.6g %.6g  diff %.3g %.3g %.3g", f[0], f[1], f[2],
                      r.value[0] - f[0], r.value[1] - f[1], r.value[2] - f[2]);
        }
        std::printf("\n");
      }
    }
    if (time)
      std::printf("# %.1f ns per convolution (%.1f ns per lookup), median of repeated runs\n",
                  ns_per_convolution, ns_per_lookup);
  });
}
