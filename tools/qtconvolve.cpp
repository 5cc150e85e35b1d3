// qtconvolve: convolve .qt files. Two trees give their integral; a BRDF table and captures give
// the reflected radiance at every capture; two capture sets give their products point by point.
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "basis/core/version.h"
#include "basis/format/qt_convolution.h"
#include "basis/io/image_file.h"
#include "basis/io/picture.h"
#include "basis/study/lookup_reference.h"
#include "basis/study/timing.h"
#include "cli.h"

namespace {

using basis::cli::UsageError;

struct Row {
  basis::Convolution result;
  std::optional<basis::Rgb> reference;
};

// Median times over the whole batch, repeated for at least 0.1 s per run.
struct Timing {
  double ns_per_lookup = -1;  // per result
  double ns_per_convolution = -1;
};

Timing time_results(const basis::FileConvolution& convolution) {
  float sink = 0;
  const double ns = basis::median_time_ns(
      [&] {
        for (std::size_t k = 0; k < convolution.size(); ++k)
          sink += convolution(k).value[0];
      },
      0.1);
  if (sink == -1) std::cerr << "";
  const double per_result = ns / double(convolution.size());
  return {per_result, per_result / convolution.convolutions_per_result()};
}

// "N ns per convolution (M ns per lookup)" for the results, and for the trees beside them.
std::string timing_text(const Timing& time, const std::optional<Timing>& trees) {
  char text[256];
  if (!trees) {
    std::snprintf(text, sizeof text, "%.1f ns per convolution (%.1f ns per lookup)",
                  time.ns_per_convolution, time.ns_per_lookup);
  } else {
    std::snprintf(text, sizeof text,
                  "dense %.1f ns per convolution (%.1f ns per lookup); trees %.1f ns (%.1f ns); "
                  "trees %.1fx faster",
                  time.ns_per_convolution, time.ns_per_lookup, trees->ns_per_convolution,
                  trees->ns_per_lookup, time.ns_per_lookup / trees->ns_per_lookup);
  }
  return text;
}

void print_json(const std::vector<Row>& rows, const std::optional<Timing>& time,
                const std::optional<Timing>& trees) {
  nlohmann::ordered_json j;
  j["results"] = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < rows.size(); ++k) {
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
    j["ns_per_convolution"] = time->ns_per_convolution;
    j["ns_per_lookup"] = time->ns_per_lookup;
  }
  if (trees) {
    j["tree_ns_per_convolution"] = trees->ns_per_convolution;
    j["tree_ns_per_lookup"] = trees->ns_per_lookup;
  }
  std::cout << j.dump(1) << "\n";
}

void print_csv(const std::vector<Row>& rows, bool reference) {
  std::printf("index,r,g,b,bound_r,bound_g,bound_b%s\n",
              reference ? ",reference_r,reference_g,reference_b" : "");
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const auto& r = rows[k].result;
    std::printf("%zu,%.7g,%.7g,%.7g,%.4g,%.4g,%.4g", k, r.value[0], r.value[1], r.value[2],
                r.bound[0], r.bound[1], r.bound[2]);
    if (rows[k].reference)
      std::printf(",%.7g,%.7g,%.7g", (*rows[k].reference)[0], (*rows[k].reference)[1],
                  (*rows[k].reference)[2]);
    std::printf("\n");
  }
}

void print_text(const std::vector<Row>& rows, const std::string& title, bool reference) {
  std::printf("# %s, RGB value +- certified bound%s\n", title.c_str(),
              reference ? "; full-resolution reference; difference" : "");
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const auto& r = rows[k].result;
    std::printf("%zu  %.6g %.6g %.6g  +- %.3g %.3g %.3g", k, r.value[0], r.value[1], r.value[2],
                r.bound[0], r.bound[1], r.bound[2]);
    if (rows[k].reference) {
      const auto& f = *rows[k].reference;
      std::printf("  ref %.6g %.6g %.6g  diff %.3g %.3g %.3g", f[0], f[1], f[2], r.value[0] - f[0],
                  r.value[1] - f[1], r.value[2] - f[2]);
    }
    std::printf("\n");
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "Convolve .qt files, by simultaneous descent of their quadtrees, with a certified bound.\n"
      "  TREE x TREE: the hemisphere integral of A B cos (pi times their product's integral "
      "over the cosine-weighted map).\n"
      "  TABLE x CAPTURES (either order): the reflected radiance Lo(wo) at every capture point, "
      "the four table entries around wo convolved and interpolated (--interpolation); TABLE x "
      "TREE: the same for one capture image.\n"
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
                              lights_from = "brdf", interpolation = "hermite";
  bool json = false, csv = false, reference = false, time = false, quiet = false, dense = false;
  double accuracy = 0;
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
  app.add_option("--interpolation", interpolation,
                 "between table entries: hermite (default; from the entries' derivatives over "
                 "wo, which brdf2qt tabulates, so that a lobe moves with wo instead of blending "
                 "the four neighbours; bilinear for tables without them) or bilinear")
      ->check(CLI::IsMember({"hermite", "bilinear"}));
  app.add_flag("--json", json, "print {\"results\": [{\"index\", \"value\", \"bound\"}, ...]}");
  app.add_flag("--csv", csv, "print CSV: index,r,g,b,bound_r,bound_g,bound_b[,reference...]");
  app.add_flag("--reference", reference,
               "also compute the full-resolution product per point (table re-tabulated from "
               "its stored spec, captures re-traced from their recorded inputs) and the "
               "difference");
  app.add_option("--accuracy", accuracy,
                 "accuracy-targeted lookups: stop descending a pair of quadrants once its "
                 "certified bound is at most this fraction of its contribution, so that the "
                 "reported bound stays within about this fraction of the value (default 0: to "
                 "the leaves)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_flag("--time", time, "report the median time per convolution over repeated runs");
  app.add_flag("--dense", dense,
               "compute the same results with vectorised dense products of every tree's "
               "full-resolution reconstruction (built before timing; untilted lookups); with "
               "--time, the trees are timed in the same run and both are reported");
  app.add_option("--png", png, "draw the capture points from above, coloured by their values");
  app.add_option("--threads", threads, "worker threads for --reference (default: all cores)")
      ->check(CLI::Range(1, 1024));
  app.add_flag("-q,--quiet", quiet, "no progress bar");
  app.set_version_flag("--version", basis::kVersion);

  return basis::cli::run(app, argc, argv, [&] {
    using basis::QtKind;
    if (json && csv) throw UsageError("--json and --csv exclude each other");
    const basis::QtFile a = basis::QtFile::load(a_path);
    const basis::QtFile b = basis::QtFile::load(b_path);
    basis::ShadingOptions shading;
    shading.wo = basis::cli::parse_triple(wo_text, "--wo");
    if (!(shading.wo.norm() > 1e-12)) throw UsageError("--wo must not be zero");
    if (shading.wo.z() < 0) throw UsageError("--wo is below the horizon (z < 0)");
    shading.wo.normalize();
    shading.convolution.accuracy = accuracy;
    shading.interpolation = interpolation == "bilinear" ? basis::WoInterpolation::bilinear
                                                        : basis::WoInterpolation::hermite;
    if (!normal_text.empty()) {
      const basis::Vec3 normal = basis::cli::parse_triple(normal_text, "--normal");
      if (!(normal.norm() > 1e-12)) throw UsageError("--normal must not be zero");
      shading.normal = normal.normalized();
      shading.tilt_mode = tilt_mode == "none"             ? basis::TiltCompensation::none
                          : tilt_mode == "reparametrised" ? basis::TiltCompensation::reparametrised
                                                          : basis::TiltCompensation::compensated;
    }
    const basis::LightBrdf light_brdf =
        lights_from == "brdf" ? basis::LightBrdf::spec : basis::LightBrdf::table;
    if (dense && shading.normal) throw UsageError("--dense takes untilted lookups (no --normal)");
    const basis::FileConvolution trees(a, b, shading, light_brdf);
    std::optional<basis::FileConvolution> dense_products;
    if (dense) dense_products.emplace(a, b, shading, light_brdf, basis::Evaluation::dense);
    const basis::FileConvolution& convolution = dense ? *dense_products : trees;
    // Always said, -q or not: the lights lose accuracy (see --lights).
    if (!convolution.warning().empty())
      std::fprintf(stderr, "qtconvolve: warning: %s\n", convolution.warning().c_str());
    const basis::QtFile* table = convolution.table();
    const bool shades_captures = table && convolution.shaded().kind() == QtKind::capture_set;
    if (!table && (!normal_text.empty() || wo_text != "0,0,1"))
      throw UsageError("--wo and --normal apply to a BRDF table and captures");
    if (reference && (!shades_captures || shading.normal))
      throw UsageError("--reference compares an untilted BRDF table lookup with captures");
    const bool two_sets = a.kind() == QtKind::capture_set && b.kind() == QtKind::capture_set;
    if (!png.empty() && !shades_captures && !two_sets)
      throw UsageError("--png draws capture points: give captures");

    std::vector<Row> rows(convolution.size());
    for (std::size_t k = 0; k < rows.size(); ++k)
      rows[k].result = convolution(k);

    std::optional<Timing> timing, tree_timing;
    if (time) timing = time_results(convolution);
    if (time && dense) tree_timing = time_results(trees);

    if (reference) {
      const auto arena = basis::cli::thread_arena(threads);
      basis::cli::ProgressBar progress("qtconvolve --reference", quiet);
      const std::vector<basis::Rgb> references = arena->execute([&] {
        return basis::reference_lookups(*table, convolution.shaded(), shading.wo,
                                        convolution.light_brdf(), shading.interpolation,
                                        progress.control());
      });
      progress.finish();
      for (std::size_t k = 0; k < rows.size(); ++k)
        rows[k].reference = references[k];
    }

    if (!png.empty()) {
      std::vector<basis::Rgb> values(rows.size());
      for (std::size_t k = 0; k < rows.size(); ++k)
        values[k] = rows[k].result.value;
      const basis::CaptureSetView points = convolution.shaded().captures();
      basis::write_image(png, basis::draw_points_from_above(points.positions, values, 768));
    }

    if (json) return print_json(rows, timing, tree_timing);
    if (csv) {
      print_csv(rows, reference);
      if (timing)
        std::fprintf(stderr, "qtconvolve: %s\n", timing_text(*timing, tree_timing).c_str());
      return;
    }
    if (rows.size() == 1 && !table) {
      const auto& r = rows[0].result;
      std::printf("integral %.7g %.7g %.7g  +- %.3g %.3g %.3g\n", r.value[0], r.value[1],
                  r.value[2], r.bound[0], r.bound[1], r.bound[2]);
    } else {
      print_text(
          rows,
          std::string(table ? "reflected radiance at each capture" : "integral at each point") +
              (shading.normal ? " (tilted normal)" : ""),
          reference);
    }
    if (timing)
      std::printf("# %s, medians of repeated runs\n", timing_text(*timing, tree_timing).c_str());
  });
}
