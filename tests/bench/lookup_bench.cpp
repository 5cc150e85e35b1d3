// Lookups on real data, cold: the main job's tables against its 1000 captures read from a file
// (main_job_data.h), by the trees (full descents, values without the bound, and accuracy
// targets) and by vectorised dense products of the trees' reconstructions, side by side. Also
// one capture repeated (hot), to tell the cost of the descent from the cost of reaching memory;
// and lookups between entries, Hermite against bilinear in the same tables and against the
// first version's tables. And the study of first-order trees (first_order_tree.h): planes
// against means in one unpacked layout, their pairs, errors and times.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "basis/brdf/table_lookup.h"
#include "basis/core/dense.h"
#include "basis/core/projection.h"
#include "basis/lighting/shading.h"
#include "basis/study/first_order_lookups.h"
#include "basis/study/first_order_tree.h"
#include "main_job_data.h"

namespace basis::bench {
namespace {

struct Lookup {
  const char* table;
  Vec3 wo;
};

// The main job's directions: Phong at the normal, copper GGX 30 degrees off it.
Lookup main_job_lookup(int which) {
  return which == 0 ? Lookup{"phong", Vec3(0, 0, 1)}
                    : Lookup{"ggx", Vec3(0.5, 0, 0.866).normalized()};
}

// Arguments: table (0 Phong, 1 GGX), accuracy in thousandths, hot (1: capture 0 repeated),
// where the captures' sun takes f from: 0 the table's BRDF evaluated (what qtconvolve does by
// default), 1 the table's texels (qtconvolve --lights table), and values_only (1: without the
// bound, qtconvolve --no-bound).
void BM_TreeLookups(benchmark::State& state) {
  const Lookup lookup = main_job_lookup(int(state.range(0)));
  const BrdfTableView table = main_job_file(lookup.table).brdf_table();
  const CaptureSetView captures = main_job_file("captures").captures();
  const BrdfSpec spec = table_brdf(main_job_file(lookup.table));
  ShadingOptions options;
  options.wo = lookup.wo;
  options.convolution.accuracy = double(state.range(1)) / 1000;
  options.light_brdf = state.range(3) == 0 ? &spec.brdf : nullptr;
  options.convolution.bound = state.range(4) == 0;
  const bool hot = state.range(2) != 0;
  // The entries around wo, found and folded once as the dense lookup builds its grid once.
  const EntriesAtWo entries =
      entries_at(table, options.wo, options.interpolation, options.light_brdf == nullptr);
  for (auto _ : state)
    for (std::size_t k = 0; k < captures.size(); ++k)
      benchmark::DoNotOptimize(shade(table, entries, captures, hot ? 0 : k, options));
  state.SetItemsProcessed(std::int64_t(state.iterations() * captures.size()));
}
BENCHMARK(BM_TreeLookups)
    ->Name("lookup/trees")
    ->ArgNames({"ggx", "accuracy_permille", "hot", "table_lights", "values_only"})
    ->ArgsProduct({{0, 1}, {0, 10, 50, 100}, {0, 1}, {0}, {0}})
    ->ArgsProduct({{0, 1}, {0}, {0, 1}, {0}, {1}})
    ->Args({0, 0, 0, 1, 0})
    ->Args({1, 0, 0, 1, 0})
    ->Args({1, 100, 0, 1, 0})
    ->Unit(benchmark::kMillisecond);

// The captures' sun takes f from the table's BRDF, as qtconvolve --dense does by default.
void BM_DenseLookups(benchmark::State& state) {
  const Lookup lookup = main_job_lookup(int(state.range(0)));
  const DenseLookup table = dense_lookup(main_job_file(lookup.table).brdf_table(), lookup.wo);
  const BrdfSpec spec = table_brdf(main_job_file(lookup.table));
  const CaptureSetView captures = main_job_file("captures").captures();
  static std::vector<Grid> grids;
  if (grids.empty())
    for (std::size_t k = 0; k < captures.size(); ++k)
      grids.push_back(reconstruct(captures.trees.tree(k)));
  const bool hot = state.range(1) != 0;
  for (auto _ : state)
    for (std::size_t k = 0; k < captures.size(); ++k) {
      const std::size_t i = hot ? 0 : k;
      benchmark::DoNotOptimize(shade_dense(table, grids[i], captures.lights_of(i), &spec.brdf));
    }
  state.SetItemsProcessed(std::int64_t(state.iterations() * captures.size()));
}
BENCHMARK(BM_DenseLookups)
    ->Name("lookup/dense")
    ->ArgNames({"ggx", "hot"})
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->Unit(benchmark::kMillisecond);

// The forms of first-order trees the rows below compare: built from the grids (the table's at
// wo and the captures' reconstructions), the bound then against them; built from the files'
// trees (the table's entries around wo weighted as a lookup weights them), the bound then
// covering the data the files were made from; and the captures cut from their texels as
// projection cuts them, at their tolerance, the bound covering those texels.
enum class FirstOrderForm {
  grid_means = 0,
  grid_planes = 1,
  grid_compact_planes = 2,  // the captures' trees compact
  file_means = 3,
  file_compact_planes = 4,
  cut_compact_planes = 5,  // the table's as grid_planes
  cut_means = 6,           // the table's as grid_means
};

// First-order trees of the table at wo and of every capture, built once before timing as the
// dense grids are: arguments table (0 Phong, 1 GGX), accuracy in thousandths, form
// (FirstOrderForm) and hot (1: capture 0 repeated). The lookups leave out the captures' sun (one
// BRDF evaluation each, which the rows above include). Counters, computed once beside the
// timing: pairs of blocks per lookup; over every capture and channel whose value exceeds 1e-3 of
// the largest, the error and the certified bound, median and p99, in % of the value; and over
// every capture and channel, the values whose error exceeds their bound. The reference is the
// table's grid against the captures' reconstructions for the forms built from the grids, and
// against their texels (traced again uncut, as the file of tolerance 0 holds them) for the others.
// Forms cut from the texels also count their blocks per capture.
struct FirstOrderCaptures {
  std::vector<Grid> grids, texels;
  std::vector<FirstOrderTree> planes, means, file_means, cut_means;
  std::vector<CompactFirstOrderTree> compact_planes, file_compact_planes, cut_planes;
  double cut_planes_blocks = 0, cut_means_blocks = 0;  // per capture
};

const FirstOrderCaptures& first_order_captures() {
  static FirstOrderCaptures captures;
  if (captures.grids.empty()) {
    const CaptureSetView set = main_job_file("captures").captures();
    for (std::size_t k = 0; k < set.size(); ++k) {
      captures.grids.push_back(reconstruct(set.trees.tree(k)));
      captures.planes.push_back(first_order_tree(captures.grids.back()));
      captures.means.push_back(without_slopes(captures.planes.back()));
      captures.compact_planes.push_back(compact(captures.planes.back()));
      const FirstOrderTree from_file = first_order_tree(set.trees.tree(k));
      captures.file_means.push_back(without_slopes(from_file));
      captures.file_compact_planes.push_back(compact(from_file));
    }
    const CaptureSetView uncut = main_job_file("captures_texels").captures();
    const double tolerance = ProjectionOptions{}.tolerance;
    for (std::size_t k = 0; k < uncut.size(); ++k) {
      const Grid& texels = captures.texels.emplace_back(reconstruct(uncut.trees.tree(k)));
      const std::array<double, 3> tolerances =
          capture_tolerances(texels, uncut.lights_of(k), tolerance);
      const FirstOrderTree planes = first_order_tree(texels, tolerances, FirstOrderCut::planes);
      captures.cut_planes.push_back(compact(planes));
      captures.cut_means.push_back(
          without_slopes(first_order_tree(texels, tolerances, FirstOrderCut::means)));
      captures.cut_planes_blocks += double(planes.blocks.size()) / double(uncut.size());
      captures.cut_means_blocks +=
          double(captures.cut_means.back().blocks.size()) / double(uncut.size());
    }
  }
  return captures;
}

void BM_FirstOrderLookups(benchmark::State& state) {
  using Form = FirstOrderForm;
  const Lookup lookup = main_job_lookup(int(state.range(0)));
  const double accuracy = double(state.range(1)) / 1000;
  const Form form = Form(state.range(2));
  const bool hot = state.range(3) != 0;
  const DenseLookup table = dense_lookup(main_job_file(lookup.table).brdf_table(), lookup.wo);
  const FirstOrderCaptures& captures = first_order_captures();
  // The entries around wo, weighted as a lookup weights them.
  const BrdfTableView entries = main_job_file(lookup.table).brdf_table();
  std::vector<WeightedTerm> terms;
  for (const TableTap& tap : lookup_taps(entries, lookup.wo, WoInterpolation::hermite))
    if (tap.reads_anything())
      terms.push_back({entries.entry(tap.i, tap.j),
                       {float(tap.weights[0]), float(tap.weights[1]), float(tap.weights[2])},
                       tap.groups_read()});
  const bool from_file = form == Form::file_means || form == Form::file_compact_planes;
  const bool means =
      form == Form::grid_means || form == Form::file_means || form == Form::cut_means;
  const FirstOrderTree table_planes =
      from_file ? first_order_tree(terms) : first_order_tree(table.grid);
  const FirstOrderTree table_tree = means ? without_slopes(table_planes) : table_planes;
  const std::size_t count = captures.grids.size();
  const auto lookup_at = [&](std::size_t k) {
    switch (form) {
      case Form::grid_means:
        return convolve_first_order(table_tree, captures.means[k], accuracy);
      case Form::grid_planes:
        return convolve_first_order(table_tree, captures.planes[k], accuracy);
      case Form::grid_compact_planes:
        return convolve_first_order(table_tree, captures.compact_planes[k], accuracy);
      case Form::file_means:
        return convolve_first_order(table_tree, captures.file_means[k], accuracy);
      case Form::file_compact_planes:
        return convolve_first_order(table_tree, captures.file_compact_planes[k], accuracy);
      case Form::cut_compact_planes:
        return convolve_first_order(table_tree, captures.cut_planes[k], accuracy);
      case Form::cut_means:
        return convolve_first_order(table_tree, captures.cut_means[k], accuracy);
    }
    throw std::logic_error("no such form");
  };
  {
    std::vector<Rgb> references;
    const bool against_texels = int(form) >= int(Form::file_means);
    for (const Grid& grid : against_texels ? captures.texels : captures.grids)
      references.push_back(dense_convolve_naive(table.grid, grid));
    const FirstOrderLookupCounts counts = count_first_order_lookups(references, lookup_at);
    state.counters["pairs"] = counts.pairs;
    state.counters["error_median_pct"] = counts.error_median;
    state.counters["error_p99_pct"] = counts.error_p99;
    state.counters["bound_median_pct"] = counts.bound_median;
    state.counters["bound_p99_pct"] = counts.bound_p99;
    state.counters["bound_failures"] = double(counts.bound_failures);
    if (form == Form::cut_compact_planes) state.counters["blocks"] = captures.cut_planes_blocks;
    if (form == Form::cut_means) state.counters["blocks"] = captures.cut_means_blocks;
  }
  for (auto _ : state)
    for (std::size_t k = 0; k < count; ++k)
      benchmark::DoNotOptimize(lookup_at(hot ? 0 : k));
  state.SetItemsProcessed(std::int64_t(state.iterations() * count));
}
BENCHMARK(BM_FirstOrderLookups)
    ->Name("lookup/first_order")
    ->ArgNames({"ggx", "accuracy_permille", "form", "hot"})
    ->ArgsProduct({{0, 1}, {0, 5, 10, 20}, {0, 1, 2, 3, 4, 5, 6}, {0}})
    ->ArgsProduct({{0, 1}, {10}, {1, 2}, {1}})
    ->Unit(benchmark::kMillisecond);

// Finding and folding the entries around one wo, what a batch of lookups at that wo pays once:
// arguments table (0 Phong, 1 GGX) and direction (0: 30 degrees off the normal on a row of the
// grid, two entries; 1: off the rows, four entries).
void BM_FoldEntries(benchmark::State& state) {
  const BrdfTableView table = main_job_file(state.range(0) == 0 ? "phong" : "ggx").brdf_table();
  const Vec3 wo =
      state.range(1) == 0 ? Vec3(0.5, 0, 0.866).normalized() : Vec3(0.3, 0.2, 0.93).normalized();
  for (auto _ : state)
    benchmark::DoNotOptimize(entries_at(table, wo, WoInterpolation::hermite));
}
BENCHMARK(BM_FoldEntries)
    ->Name("lookup/fold")
    ->ArgNames({"ggx", "off_rows"})
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->Unit(benchmark::kMicrosecond);

// Lookups between entries (wo 21 degrees off the normal, off every grid line): arguments table
// (0 Phong, 1 GGX) and method (0: the first version's table, bilinear; 1: the default table,
// bilinear; 2: the default table, Hermite).
void BM_BetweenEntries(benchmark::State& state) {
  const bool ggx = state.range(0) != 0;
  const int method = int(state.range(1));
  const std::string name = std::string(ggx ? "ggx" : "phong") + (method == 0 ? "_first" : "");
  const BrdfTableView table = main_job_file(name).brdf_table();
  const CaptureSetView captures = main_job_file("captures").captures();
  const BrdfSpec spec = table_brdf(main_job_file(name));
  ShadingOptions options;
  options.wo = Vec3(0.3, 0.2, 0.93).normalized();
  options.light_brdf = &spec.brdf;
  options.interpolation = method == 2 ? WoInterpolation::hermite : WoInterpolation::bilinear;
  for (auto _ : state)
    for (std::size_t k = 0; k < captures.size(); ++k)
      benchmark::DoNotOptimize(shade(table, captures, k, options));
  state.SetItemsProcessed(std::int64_t(state.iterations() * captures.size()));
}
BENCHMARK(BM_BetweenEntries)
    ->Name("lookup/between_entries")
    ->ArgNames({"ggx", "method"})
    ->ArgsProduct({{0, 1}, {0, 1, 2}})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace basis::bench
