// qtconvolve: convolve .qt files. Two trees give their integral; a BRDF table and captures give
// the reflected radiance at every capture; two capture sets give their products point by point.
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "basis/core/version.h"
#include "basis/format/qt_convolution.h"
#include "basis/format/qt_manifest.h"
#include "basis/io/atomic_file.h"
#include "basis/io/image_file.h"
#include "basis/io/json_text.h"
#include "basis/io/picture.h"
#include "basis/lighting/mesh.h"
#include "basis/study/lookup_reference.h"
#include "basis/study/timing.h"
#include "cli.h"

namespace {

using basis::cli::UsageError;

// Blocks of at most this many results are computed at a time, so that memory stays bounded
// whatever the input: a manifest's shards are read block by block, and --dense reconstructs
// one block's grids at a time (192 KiB per 128^2 RGB capture, 768 MiB a block at most).
constexpr std::size_t kBlock = 4096;
// --time stops timing after the block that reaches this many results.
constexpr std::uint64_t kMostTimedResults = 65536;

struct Row {
  std::uint64_t index = 0;
  basis::Convolution result;
  std::optional<basis::Rgb> reference;
  bool bound = true;  // whether result.bound was computed (not --no-bound)
};

// The times of five runs over the batch (each at least 0.1 s), summed over blocks; per-lookup
// figures take the median run.
struct Timing {
  basis::RunTimes runs_ns{};  // over all results timed
  std::uint64_t results = 0;
  int convolutions_per_result = 1;
  double ns_per_lookup() const {
    return basis::median_of(runs_ns) / double(std::max<std::uint64_t>(1, results));
  }
  double ns_per_convolution() const { return ns_per_lookup() / convolutions_per_result; }
  void add(const basis::RunTimes& runs, const basis::FileConvolution& convolution) {
    for (std::size_t r = 0; r < runs.size(); ++r)
      runs_ns[r] += runs[r];
    results += convolution.size();
    convolutions_per_result = convolution.convolutions_per_result();
  }
};

// Whether the trees were timed beside the dense products on some results (not a shard without
// results).
bool timed_beside(const std::optional<Timing>& trees) {
  return trees && trees->results > 0;
}

// How many times faster the second timing's runs were than the first's: the median of the
// ratios of runs taken in pairs (time_in_turn), steadier than the medians' ratio.
double speedup(const Timing& slow, const Timing& fast) {
  basis::RunTimes ratios;
  for (std::size_t r = 0; r < ratios.size(); ++r)
    ratios[r] = slow.runs_ns[r] / fast.runs_ns[r];
  return basis::median_of(ratios);
}

// One pass over a block's results, summed into `sink` so that it is not optimised away.
std::function<void()> summing_pass(const basis::FileConvolution& convolution, float& sink) {
  return [&convolution, &sink] {
    for (std::size_t k = 0; k < convolution.size(); ++k)
      sink += convolution(k).value[0];
  };
}

void time_results(const basis::FileConvolution& convolution, Timing& timing) {
  float sink = 0;
  timing.add(basis::run_times_ns(summing_pass(convolution, sink), 0.1), convolution);
  if (sink == -1) std::cerr << "";
}

// Both evaluations of a block timed in pairs of runs, so that each pair meets the same moment of
// the machine (alternating_run_times_ns swaps which comes first from pair to pair).
void time_in_turn(const basis::FileConvolution& dense, const basis::FileConvolution& trees,
                  Timing& dense_timing, Timing& tree_timing) {
  float sink = 0;
  const basis::AlternatingRuns runs =
      basis::alternating_run_times_ns(summing_pass(dense, sink), summing_pass(trees, sink), 0.1);
  dense_timing.add(runs.a_ns, dense);
  tree_timing.add(runs.b_ns, trees);
  if (sink == -1) std::cerr << "";
}

// "N ns per convolution (M ns per lookup)" for the results, and for the trees beside them.
std::string timing_text(const Timing& time, const std::optional<Timing>& trees) {
  char text[256];
  if (!timed_beside(trees)) {
    std::snprintf(text, sizeof text, "%.1f ns per convolution (%.1f ns per lookup)",
                  time.ns_per_convolution(), time.ns_per_lookup());
  } else {
    std::snprintf(text, sizeof text,
                  "dense %.1f ns per convolution (%.1f ns per lookup); trees %.1f ns (%.1f ns); "
                  "trees %.1fx faster",
                  time.ns_per_convolution(), time.ns_per_lookup(), trees->ns_per_convolution(),
                  trees->ns_per_lookup(), speedup(time, *trees));
  }
  return text;
}

// Results as text, written block by block: to stdout, or to a file put in place once complete.
class Output {
 public:
  explicit Output(const std::string& path) {
    if (!path.empty()) file_.emplace(path);
  }
  void write(const std::string& text) {
    if (file_)
      file_->write(text);
    else
      basis::cli::write_standard_output(text);
  }
  void commit() {
    if (file_)
      file_->commit();
    else
      basis::cli::flush_standard_output();
  }

 private:
  std::optional<basis::AtomicFileWriter> file_;
};

std::string json_row(const Row& row) {
  nlohmann::ordered_json r = {{"index", row.index}, {"value", row.result.value}};
  if (row.bound) r["bound"] = row.result.bound;
  if (row.reference) {
    basis::Rgb d;
    for (int c = 0; c < 3; ++c)
      d[c] = row.result.value[c] - (*row.reference)[c];
    r["reference"] = *row.reference;
    r["difference"] = d;
  }
  return basis::json_text(r);
}

// printf into a string of at most 255 characters.
[[gnu::format(printf, 1, 2)]] std::string printed(const char* format, ...) {
  char text[256];
  std::va_list args;
  va_start(args, format);
  std::vsnprintf(text, sizeof text, format, args);
  va_end(args);
  return text;
}

std::string csv_row(const Row& row) {
  const auto& r = row.result;
  std::string line = printed("%llu,%.7g,%.7g,%.7g", static_cast<unsigned long long>(row.index),
                             r.value[0], r.value[1], r.value[2]);
  if (row.bound) line += printed(",%.4g,%.4g,%.4g", r.bound[0], r.bound[1], r.bound[2]);
  if (row.reference) {
    const auto& f = *row.reference;
    line += printed(",%.7g,%.7g,%.7g", f[0], f[1], f[2]);
  }
  return line + "\n";
}

std::string text_row(const Row& row) {
  const auto& r = row.result;
  std::string line = printed("%llu  %.6g %.6g %.6g", static_cast<unsigned long long>(row.index),
                             r.value[0], r.value[1], r.value[2]);
  if (row.bound) line += printed("  +- %.3g %.3g %.3g", r.bound[0], r.bound[1], r.bound[2]);
  if (row.reference) {
    const auto& f = *row.reference;
    line += printed("  ref %.6g %.6g %.6g  diff %.3g %.3g %.3g", f[0], f[1], f[2],
                    r.value[0] - f[0], r.value[1] - f[1], r.value[2] - f[2]);
  }
  return line + "\n";
}

// The one result of two single trees.
std::string integral_row(const Row& row) {
  const auto& r = row.result;
  std::string line = printed("integral %.7g %.7g %.7g", r.value[0], r.value[1], r.value[2]);
  if (row.bound) line += printed("  +- %.3g %.3g %.3g", r.bound[0], r.bound[1], r.bound[2]);
  return line + "\n";
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
      "used, not of the BRDF between entries; nor of the texels against the continuous "
      "integral, nor of a sun's disc against its centre direction: these grow towards the "
      "horizon, see README, Accuracy), unless --no-bound asks for the values alone. "
      "Trees of different resolutions convolve as the piecewise-constant functions they are.\n"
      "A capture set may also be given as a manifest listing the shard files of a sharded run "
      "(qtmerge --manifest): it is read shard by shard, in bounded memory, each shard checked "
      "against the manifest (size, checksum, which shard it is) as it is reached; a missing or "
      "altered shard stops the run with one line naming it (results printed before it stay "
      "printed; -o writes nothing then).\n"
      "Captures may carry directional lights (a sun kept apart by capture2qt): a table shades "
      "them with f at their direction (--lights); a product of captures counts each in the "
      "texel it falls in.",
      "qtconvolve");
  std::string a_path, b_path, wo_text = "0,0,1", normal_text, tilt_mode = "compensated", png,
                              lights_from = "brdf", interpolation = "hermite";
  std::string shard_text, output;
  bool json = false, csv = false, reference = false, time = false, quiet = false, dense = false;
  bool no_bound = false;
  double accuracy = 0;
  int threads = 0;
  app.add_option("a", a_path, "first .qt file, or a manifest of a capture set's shards")
      ->required();
  app.add_option("b", b_path, "second .qt file, or a manifest of a capture set's shards")
      ->required();
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
  app.add_flag("--json", json,
               "print {\"results\": [{\"index\", \"value\", \"bound\"[, \"reference\", "
               "\"difference\"]}, ...]} and, with --time, \"ns_per_convolution\" and "
               "\"ns_per_lookup\" (with --dense the dense side's, and the trees' as "
               "\"tree_ns_per_convolution\", \"tree_ns_per_lookup\", \"tree_speedup\"); no "
               "\"bound\" with --no-bound or --dense");
  app.add_flag("--csv", csv,
               "print CSV: index,r,g,b,bound_r,bound_g,bound_b[,reference...] (no bound columns "
               "with --no-bound or --dense)");
  app.add_flag(
      "--no-bound", no_bound,
      "values alone: the trees are descended as without it, to the same values (to "
      "the bit), but the certified bound is not computed, which saves the descent "
      "a fifth to two fifths of its time; no bound is printed (CSV "
      "index,r,g,b[,reference...], JSON without \"bound\"). Not with --accuracy, which stops "
      "on the bound");
  app.add_flag("--reference", reference,
               "also compute the full-resolution product per point (table re-tabulated from "
               "its stored spec, captures re-traced from their recorded inputs) and the "
               "difference");
  app.add_option("--accuracy", accuracy,
                 "accuracy-targeted descents (lookups and products): stop descending a pair of "
                 "quadrants once its certified bound is at most this fraction of its "
                 "contribution, so that the reported bound stays within about this fraction of "
                 "the value (default 0: to the leaves)")
      ->check(basis::cli::finite_number())
      ->check(CLI::Range(0.0, 1.0));
  app.add_flag("--time", time,
               "report the median time per convolution over repeated runs (of the first 65,536 "
               "results at most)");
  app.add_flag(
      "--dense", dense,
      "compute the same results with vectorised dense products of every tree's "
      "full-resolution reconstruction (built before timing, 4,096 captures at a time; untilted "
      "lookups; they certify nothing, so no bound is printed); with --time, the trees are timed "
      "in the same run, five runs of each in pairs (the order swapped from pair to pair), and "
      "both are reported with the median of the pairs' ratios");
  app.add_option("--png", png, "draw the capture points from above, coloured by their values");
  app.add_option("--threads", threads, "worker threads for --reference (default: all cores)")
      ->check(CLI::Range(1, 1024));
  app.add_option("--shard", shard_text,
                 "compute only shard I of N of the results (I from 0, e.g. "
                 "$SLURM_ARRAY_TASK_ID/8): results [floor(I P / N), floor((I + 1) P / N)) of P, "
                 "with their indices in the whole set; the header (CSV, text) comes with shard 0 "
                 "only, so that the shards' outputs concatenated in order are the whole output "
                 "(hence not with --json; --time with --csv only); --png draws the shard's "
                 "points");
  app.add_option("-o,--output", output,
                 "write the results to this file, put in place only once complete, instead of "
                 "printing them");
  app.add_flag("-q,--quiet", quiet, "no progress bar");
  app.set_version_flag("--version", basis::kVersion);

  return basis::cli::run(app, argc, argv, [&] {
    using basis::QtKind;
    if (json && csv) throw UsageError("--json and --csv exclude each other");
    basis::cli::check_outputs_spare_inputs({{"-o", output}, {"--png", png}},
                                           {{"a", a_path}, {"b", b_path}});
    basis::cli::check_output_place(output);
    basis::cli::check_output_place(png);
    basis::cli::check_png_name(png, "--png");
    if (no_bound && accuracy > 0)
      throw UsageError("--accuracy stops on the certified bound: not with --no-bound");
    // The dense product sums every texel: a target applies to the trees --time runs beside it.
    for (const char* flag : {"--accuracy", "--no-bound"})
      if (dense && !time && app.count(flag) > 0)
        throw UsageError(std::string(flag) +
                         " shapes the trees' descent: with --dense, only beside --time");
    basis::CaptureSource a = basis::CaptureSource::open(a_path);
    basis::CaptureSource b = basis::CaptureSource::open(b_path);
    if (reference) {
      // What a reference reads again (the map, the scene, the spec the files record) is an
      // input too.
      std::vector<basis::cli::NamedPath> recorded;
      for (basis::CaptureSource* source : {&a, &b})
        if (source->size() > 0)
          for (const std::string& file : source->shard(0).provenance().sources) {
            recorded.push_back({"--reference", file});
            // A scene's material files (mtllib), which tracing reads with it. A scene that does
            // not read is the reference's error, which names the captures that recorded it.
            if (basis::cli::lower_case_extension(file) != ".obj") continue;
            try {
              for (const std::string& material : basis::read_obj(file).material_files)
                recorded.push_back({"--reference", material, "a material file " + file + " names"});
            } catch (const basis::FileError&) {
            }
          }
      basis::cli::check_outputs_spare_inputs({{"-o", output}, {"--png", png}}, recorded);
    }
    basis::ShadingOptions shading;
    shading.wo = basis::cli::parse_direction(wo_text, "--wo");
    if (shading.wo.z() < 0) throw UsageError("--wo is below the horizon (z < 0)");
    shading.convolution.accuracy = accuracy;
    shading.convolution.bound = !no_bound;
    shading.interpolation = interpolation == "bilinear" ? basis::WoInterpolation::bilinear
                                                        : basis::WoInterpolation::hermite;
    if (!normal_text.empty()) {
      shading.normal = basis::cli::parse_direction(normal_text, "--normal");
      shading.tilt_mode = tilt_mode == "none"             ? basis::TiltCompensation::none
                          : tilt_mode == "reparametrised" ? basis::TiltCompensation::reparametrised
                                                          : basis::TiltCompensation::compensated;
    }
    const basis::LightBrdf light_brdf =
        lights_from == "brdf" ? basis::LightBrdf::spec : basis::LightBrdf::table;
    if (dense && shading.normal) throw UsageError("--dense takes untilted lookups (no --normal)");
    // The dense product certifies nothing: its results print without a bound.
    const bool certified = !no_bound && !dense;
    const bool has_table = a.kind() == QtKind::brdf_table || b.kind() == QtKind::brdf_table;
    const QtKind shaded_kind = a.kind() == QtKind::brdf_table ? b.kind() : a.kind();
    const bool shades_captures = has_table && shaded_kind == QtKind::capture_set;
    if (!has_table && (!normal_text.empty() || wo_text != "0,0,1"))
      throw UsageError("--wo and --normal apply to a BRDF table and captures");
    if (!normal_text.empty() && !shades_captures)
      throw UsageError("--normal tilts captures' frames: give a BRDF table and captures");
    if (app.count("--tilt") > 0 && normal_text.empty())
      throw UsageError("--tilt says how --normal's tilt is handled: give --normal");
    if (!has_table && (app.count("--lights") > 0 || app.count("--interpolation") > 0))
      throw UsageError("--lights and --interpolation apply to a BRDF table's lookups");
    if (reference && (!shades_captures || shading.normal))
      throw UsageError("--reference compares an untilted BRDF table lookup with captures");
    const bool two_sets = a.kind() == QtKind::capture_set && b.kind() == QtKind::capture_set;
    if (!png.empty() && !shades_captures && !two_sets)
      throw UsageError("--png draws capture points: give captures");

    if (!shard_text.empty() && json)
      throw UsageError("--shard writes results that concatenate in order: CSV or text, not --json");
    if (!shard_text.empty() && time && !csv)
      throw UsageError("--shard with --time needs --csv (the timing then goes to stderr)");
    // The results this process computes: all, or its shard's.
    const std::uint64_t total = basis::result_count(a, b);
    basis::PointRange range{0, total};
    if (!shard_text.empty()) {
      range =
          basis::shard_range(total, basis::cli::parse_shard_option(shard_text, total, "results"));
    }
    const bool manifests = a.is_manifest() || b.is_manifest();

    Output out(output);
    const bool single = total == 1 && !has_table && !json && !csv;
    // Written once the first block's results are computed, so that an error prints nothing.
    const auto write_header = [&] {
      const std::string title =
          std::string(has_table ? "reflected radiance at each capture" : "integral at each point") +
          (shading.normal ? " (tilted normal)" : "");
      if (json) {
        out.write("{\"results\": [");
      } else if (range.first == 0 && csv) {  // shards after the first continue the first's
        out.write(std::string("index,r,g,b") + (certified ? ",bound_r,bound_g,bound_b" : "") +
                  (reference ? ",reference_r,reference_g,reference_b" : "") + "\n");
      } else if (range.first == 0 && !single) {
        out.write("# " + title + (certified ? ", RGB value +- certified bound" : ", RGB value") +
                  (reference ? "; full-resolution reference; difference" : "") + "\n");
      }
    };

    std::optional<Timing> timing, tree_timing;
    if (time) timing.emplace();
    if (time && dense) tree_timing.emplace();
    std::vector<basis::Vec3> positions;
    std::vector<basis::Rgb> values;
    const auto arena = basis::cli::thread_arena(threads);
    basis::cli::ProgressBar progress(reference ? "qtconvolve --reference" : "qtconvolve",
                                     quiet || (!reference && !manifests));
    bool first_block = true;
    bool warned_tilt = false;
    std::uint64_t done = 0;
    basis::for_each_block(a, b, range, kBlock, [&](const basis::ConvolutionBlock& blk) {
      progress.control().check();
      const basis::FileConvolution trees(blk.a, blk.b, shading, light_brdf,
                                         basis::Evaluation::trees, blk.ranges);
      std::optional<basis::FileConvolution> dense_products;
      if (dense)
        dense_products.emplace(blk.a, blk.b, shading, light_brdf, basis::Evaluation::dense,
                               blk.ranges);
      const basis::FileConvolution& convolution = dense ? *dense_products : trees;
      std::vector<Row> rows(convolution.size());
      for (std::size_t k = 0; k < rows.size(); ++k) {
        rows[k].index = blk.first + k;
        try {
          rows[k].result = convolution(k);
        } catch (const std::invalid_argument& e) {  // a capture tilted past 90 degrees
          if (!shading.normal) throw;
          throw basis::FileError(convolution.shaded().name() + ": capture " +
                                 std::to_string(rows[k].index) + " under --normal " + normal_text +
                                 ": " + e.what());
        } catch (const std::overflow_error& e) {  // radiance beyond what floats hold
          throw basis::FileError(convolution.shaded().name() + ": capture " +
                                 std::to_string(rows[k].index) + ": " + e.what());
        }
        rows[k].bound = certified;
      }
      // Each block is timed for at least 0.1 s: a long run is timed on its first blocks.
      const bool timed = timing && timing->results < kMostTimedResults;
      if (timed && tree_timing)
        time_in_turn(convolution, trees, *timing, *tree_timing);
      else if (timed)
        time_results(convolution, *timing);
      if (reference) {
        basis::TaskControl control = progress.control();
        control.progress = [&](std::size_t d, std::size_t) {
          progress.control().report(std::size_t(done) + d, std::size_t(range.count));
        };
        const std::vector<basis::Rgb> references = arena->execute([&] {
          return basis::reference_lookups(*convolution.table(), convolution.shaded(),
                                          convolution.shaded_range(), shading.wo,
                                          convolution.light_brdf(), shading.interpolation, control);
        });
        for (std::size_t k = 0; k < rows.size(); ++k)
          rows[k].reference = references[k];
      }
      if (!png.empty()) {
        const basis::CaptureSetView& points = has_table ? convolution.shaded_captures()
                                              : a.kind() == QtKind::capture_set
                                                  ? convolution.captures_a()
                                                  : convolution.captures_b();
        positions.insert(positions.end(), points.positions.begin(), points.positions.end());
        for (const Row& row : rows)
          values.push_back(row.result.value);
      }
      // The header follows the first block's results and references: a capture that cannot
      // be shaded (a tilt past 90 degrees) or a reference whose inputs are gone stops the run
      // with nothing printed.
      if (first_block) {
        write_header();
        // Always said, -q or not: the lights lose accuracy (see --lights).
        if (!convolution.warning().empty())
          progress.print_line("qtconvolve: warning: " + convolution.warning());
      }
      // Said once, after the first block that tilts a capture past the supported tilt.
      if (shading.normal && !warned_tilt && shades_captures) {
        const double tilt =
            basis::largest_tilt_degrees(convolution.shaded_captures(), *shading.normal);
        if (tilt > basis::kSupportedTiltDegrees) {
          warned_tilt = true;
          progress.print_line(printed(
              "qtconvolve: warning: --normal tilts captures by up to %.1f degrees; tilts are "
              "supported to %.0f (within about 2 %% there), and the bound does not cover the "
              "tilt's error",
              tilt, basis::kSupportedTiltDegrees));
        }
      }
      std::string text;
      for (const Row& row : rows) {
        if (json)
          text += (row.index == range.first ? "\n " : ",\n ") + json_row(row);
        else if (csv)
          text += csv_row(row);
        else if (single)
          text += integral_row(row);
        else
          text += text_row(row);
      }
      out.write(text);
      done += rows.size();
      if (!reference) progress.control().report(std::size_t(done), std::size_t(range.count));
      first_block = false;
    });
    progress.finish();
    // Interrupted after the last block (while timing, say): nothing is written.
    progress.control().check();
    if (first_block) write_header();  // a shard without results

    if (!png.empty())
      basis::write_image(png, basis::draw_points_from_above(positions, values, 768));
    if (json) {
      nlohmann::ordered_json times;
      if (timing) {
        times["ns_per_convolution"] = timing->ns_per_convolution();
        times["ns_per_lookup"] = timing->ns_per_lookup();
      }
      if (tree_timing) {
        times["tree_ns_per_convolution"] = tree_timing->ns_per_convolution();
        times["tree_ns_per_lookup"] = tree_timing->ns_per_lookup();
        if (timed_beside(tree_timing)) times["tree_speedup"] = speedup(*timing, *tree_timing);
      }
      std::string tail = "\n]";
      for (const auto& [key, value] : times.items())
        tail += ",\n \"" + key + "\": " + basis::json_text(value);
      out.write(tail + "\n}\n");
    } else if (timing && csv) {
      std::fprintf(stderr, "qtconvolve: %s\n", timing_text(*timing, tree_timing).c_str());
    } else if (timing) {
      out.write("# " + timing_text(*timing, tree_timing) +
                (timed_beside(tree_timing)
                     ? ", medians of five runs, the two taken in pairs of runs\n"
                     : ", medians of repeated runs\n"));
    }
    out.commit();
  });
}
