// basis_first_order_counts: the study of first-order trees (study/first_order_tree.h) on any
// scene. A table's lookups at one wo against captures traced uncut (capture2qt --tolerance 0),
// each capture cut from its texels at a tolerance on means (as projection cuts today) and on
// planes: blocks per capture, and at each accuracy pairs per lookup, errors and certified bounds
// against the texels, and the values whose error exceeded their bound.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "basis/core/dense.h"
#include "basis/core/vector.h"
#include "basis/format/qt_file.h"
#include "basis/lighting/shading.h"
#include "basis/study/first_order_lookups.h"
#include "basis/study/first_order_tree.h"

int main(int argc, char** argv) {
  CLI::App app{
      "Pairs, errors and bounds of first-order lookups: a table at one wo against captures "
      "traced uncut (capture2qt --tolerance 0), each cut from its texels on means and on "
      "planes."};
  std::string table_path, captures_path;
  std::vector<double> wo = {0.5, 0, 0.866};
  std::vector<double> accuracies = {0, 0.005, 0.01, 0.02};
  double tolerance = 0.05;
  app.add_option("table", table_path, "BRDF table (.qt)")->required()->check(CLI::ExistingFile);
  app.add_option("captures", captures_path, "capture set traced with --tolerance 0 (.qt)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--wo", wo, "outgoing direction in the table's frame (default 30 degrees)")
      ->expected(3)
      ->delimiter(',');
  app.add_option("--tolerance", tolerance, "relative tolerance of the cut (default 0.05)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--accuracy", accuracies, "accuracy targets (default 0,0.005,0.01,0.02)")
      ->delimiter(',')
      ->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  try {
    const basis::QtFile table_file = basis::QtFile::load(table_path);
    const basis::QtFile captures_file = basis::QtFile::load(captures_path);
    const basis::DenseLookup table =
        basis::dense_lookup(table_file.brdf_table(), basis::Vec3(wo[0], wo[1], wo[2]));
    const basis::FirstOrderTree table_planes = basis::first_order_tree(table.grid);
    const basis::FirstOrderTree table_means = basis::without_slopes(table_planes);
    const basis::CaptureSetView captures = captures_file.captures();
    std::vector<basis::CompactFirstOrderTree> planes;
    std::vector<basis::FirstOrderTree> means;
    std::vector<basis::Rgb> references;
    double plane_blocks = 0, mean_blocks = 0;
    for (std::size_t k = 0; k < captures.size(); ++k) {
      const basis::Grid texels = basis::reconstruct(captures.trees.tree(k));
      const std::array<double, 3> tolerances =
          basis::capture_tolerances(texels, captures.lights_of(k), tolerance);
      const basis::FirstOrderTree cut_planes =
          basis::first_order_tree(texels, tolerances, basis::FirstOrderCut::planes);
      means.push_back(basis::without_slopes(
          basis::first_order_tree(texels, tolerances, basis::FirstOrderCut::means)));
      planes.push_back(basis::compact(cut_planes));
      plane_blocks += double(cut_planes.blocks.size());
      mean_blocks += double(means.back().blocks.size());
      references.push_back(basis::dense_convolve_naive(table.grid, texels));
    }
    const double n = double(captures.size());
    std::printf("%zu captures cut at %g: blocks per capture %.0f on means, %.0f on planes\n",
                captures.size(), tolerance, mean_blocks / n, plane_blocks / n);
    std::printf("%-8s %-7s %9s %22s %22s %9s\n", "accuracy", "cut", "pairs", "error median / p99",
                "bound median / p99", "failures");
    for (const double accuracy : accuracies)
      for (const bool on_planes : {false, true}) {
        const basis::FirstOrderLookupCounts counts =
            basis::count_first_order_lookups(references, [&](std::size_t k) {
              return on_planes ? basis::convolve_first_order(table_planes, planes[k], accuracy)
                               : basis::convolve_first_order(table_means, means[k], accuracy);
            });
        std::printf("%-8g %-7s %9.1f %9.3f / %7.3f %% %9.3f / %7.3f %% %9zu\n", accuracy,
                    on_planes ? "planes" : "means", counts.pairs, counts.error_median,
                    counts.error_p99, counts.bound_median, counts.bound_p99, counts.bound_failures);
      }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "basis_first_order_counts: %s\n", e.what());
    return 1;
  }
  return 0;
}
