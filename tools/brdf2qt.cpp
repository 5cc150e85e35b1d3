// brdf2qt: tabulate a BRDF spec into a parabolic table of quadtrees (a .qt BRDF table).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "basis/brdf/brdf_spec.h"
#include "basis/brdf/brdf_table.h"
#include "basis/core/file_error.h"
#include "basis/core/projection.h"
#include "basis/core/version.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_recipe.h"
#include "basis/io/json_text.h"
#include "cli.h"

int main(int argc, char** argv) {
  CLI::App app(
      "Tabulate a BRDF into a .qt table: an M x M parabolic grid over the outgoing direction, "
      "each entry a quadtree over the incoming direction in the cosine-weighted concentric map "
      "holding texel averages of f(wi, wo) (supersampled until stable), plus two channel groups "
      "of tilt derivatives for rotation compensation.\n\n"
      "SPEC.json: {\"model\": NAME, ...} with models lambert (albedo), phong and blinn-phong "
      "(kd, ks, exponent), ward (kd, ks, alpha), ggx (kd, f0, alpha), merl (file: a MERL "
      "binary), rgl (file: an RGL EPFL .bsdf tensor file). Colours are "
      "[r, g, b] or one number. An optional \"table\": {\"wo_res\", \"wi_res\", \"tolerance\"} "
      "block sets defaults that flags override.",
      "brdf2qt");
  std::string spec_path, output, bounds = "l2";
  int wo_res = 0, wi_res = 0, threads = 0;
  double tolerance = -1, tolerance_floor = 0.2;
  bool absolute = false, quiet = false, no_tilt = false, no_wo_derivatives = false, json = false;
  app.add_option("spec", spec_path, "the BRDF spec (JSON)")->required();
  app.add_option("-o,--output", output,
                 "output .qt file (default: the spec's name with .qt); a .qt file holds at most "
                 "2 GiB, tabulation stops with an error beyond");
  app.add_option("--wo-res", wo_res,
                 "entries per side of the parabolic grid over wo (default: from the width of "
                 "the BRDF's lobe, 33 for Phong 30 and wider, 57 for Phong 100, 81 for Phong "
                 "200, up to 129; see README)")
      ->check(CLI::Range(2, 256));
  app.add_option(
         "--wi-res", wi_res,
         "texels per side of each entry over the incoming direction, a power of two up to 512 "
         "(default 128). Lookups multiply an entry's texels with a capture's, so the finer of the "
         "two resolutions limits what a sharp lobe resolves: glossy reflections of a low sun erred "
         "by up to 1.3 % with 64 and 3.3 % with 32 (see README)")
      ->check(CLI::Range(2, 512));
  app.add_option("--tolerance", tolerance,
                 "refine while a quadrant's error bound exceeds this fraction of its own value, "
                 "or of --tolerance-floor times the entry's mean where that is larger (default "
                 "0.05; at most 1e6)")
      ->check(basis::cli::number_between(0, 1e6));
  app.add_option("--tolerance-floor", tolerance_floor,
                 "the floor of the locally relative tolerance, a fraction of the entry's mean "
                 "(default 0.2; 0 makes --tolerance relative to the entry's mean everywhere; at "
                 "most 1e6)")
      ->check(basis::cli::number_between(0, 1e6));
  app.add_flag("--absolute", absolute, "read --tolerance as an absolute value (1/sr)");
  app.add_option("--bounds", bounds,
                 "what the stored bounds bound: l2 (default), each quadrant's RMS deviation, "
                 "for the tightest certified lookups; or linf, its largest deviation from every "
                 "texel")
      ->check(CLI::IsMember({"l2", "linf"}));
  app.add_flag("--no-tilt", no_tilt, "leave out the tilt derivatives (rotation compensation)");
  app.add_flag("--no-wo-derivatives", no_wo_derivatives,
               "leave out each entry's derivatives over wo: smaller tables, but lookups between "
               "entries interpolate bilinearly and blend the neighbours' lobes (errors of tens "
               "of percent for sharp lobes under high-contrast light, see README)");
  app.add_option("--threads", threads, "worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  app.add_flag("--json", json, "print the summary as JSON");
  app.add_flag("-q,--quiet", quiet, "no progress bar or summary (--json still prints)");
  app.set_version_flag("--version", basis::kVersion);

  return basis::cli::run(app, argc, argv, [&] {
    if (output.empty())
      output = std::filesystem::path(spec_path).replace_extension(".qt").filename().string();
    basis::cli::check_outputs_spare_inputs({{"-o", output}}, {{"spec", spec_path}});
    basis::cli::check_output_place(output);
    const basis::BrdfSpec spec = basis::read_brdf_spec(spec_path);
    basis::cli::check_outputs_spare_inputs({{"-o", output}}, {{"spec's \"file\"", spec.data_file}});
    basis::BrdfTableOptions options = basis::table_options(spec);
    if (wo_res) options.wo_resolution = wo_res;
    if (wi_res) options.wi_resolution = wi_res;
    if (!basis::is_valid_resolution(options.wi_resolution))
      throw basis::cli::UsageError("--wi-res must be a power of two from 2 to 512, got " +
                                   std::to_string(options.wi_resolution));
    if (tolerance >= 0) options.projection.tolerance = tolerance;
    options.projection.local_floor = tolerance_floor;
    if (absolute) options.projection.mode = basis::ProjectionOptions::Mode::absolute;
    options.tilt_derivatives = !no_tilt;
    options.wo_derivatives = !no_wo_derivatives;
    options.bounds = bounds == "linf" ? basis::BoundKind::linf : basis::BoundKind::l2;
    for (const std::string& warning : basis::table_resolution_warnings(spec.brdf, options))
      std::fprintf(stderr, "brdf2qt: warning: %s: %s\n", spec_path.c_str(), warning.c_str());

    const auto arena = basis::cli::thread_arena(threads);
    basis::cli::ProgressBar progress("brdf2qt", quiet);
    const auto start = std::chrono::steady_clock::now();
    const basis::BrdfTable table = arena->execute([&] {
      try {
        return basis::tabulate_brdf(spec.brdf, options, progress.control());
      } catch (const std::overflow_error& e) {
        throw basis::FileError(spec_path + ": " + e.what());
      }
    });
    progress.finish();
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    const auto bytes = basis::encode_brdf_table(
        table.view(), spec.model, spec.text, options.projection,
        {"brdf2qt", basis::kVersion, basis::table_parameters(options, spec.brdf), {spec_path}});
    basis::write_qt(output, bytes);
    if (quiet && !json) return;
    const std::size_t nodes = table.trees.view().total_nodes();
    if (json) {
      std::cout << basis::json_text(nlohmann::ordered_json{{"output", output},
                                                           {"entries", table.trees.size()},
                                                           {"nodes", nodes},
                                                           {"bytes", bytes.size()},
                                                           {"seconds", seconds}})
                << "\n";
      return;
    }
    std::printf(
        "%s: %s, %d x %d entries of %d x %d texels, %zu nodes (%.1f per entry), "
        "%.2f MiB, %.2f s\n",
        output.c_str(), spec.model.c_str(), options.wo_resolution, options.wo_resolution,
        options.wi_resolution, options.wi_resolution, nodes,
        double(nodes) / double(table.trees.size()), double(bytes.size()) / (1 << 20), seconds);
  });
}
