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
#include <numbers>
#include <span>

#include "basis/brdf/table_lookup.h"
#include "basis/core/dense.h"
#include "basis/core/projection.h"
#include "basis/lighting/shading.h"
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

// First-order trees of the table's grid at wo and of every capture's grid, built once before
// timing as the dense grids are: arguments table (0 Phong, 1 GGX), accuracy in thousandths,
// form (0: the slopes dropped, means alone; 1: planes; 2: planes, the captures' trees compact;
// 3 and 4: as 0 and 2, built from the packed trees, the table's entries around wo weighted as a
// lookup weights them, so that the bound covers the data the files were made from; 5 and 6: the
// captures' trees cut from their texels as projection cuts them, at the captures' tolerance, on
// planes (compact) or on means, the table's as in 1 and 0) and hot (1: capture 0 repeated). The
// lookups leave out the captures' sun (one BRDF evaluation each, which the rows above include).
// Counters, computed once beside the timing: pairs of blocks per lookup, and over every capture and
// channel whose value exceeds 1e-3 of the largest, the error against the grids' product
// (dense_convolve_naive) and the certified bound, median and p99, in % of the value (forms 3 and 4:
// a bound that covers the data, and so more than the grids need).
struct FirstOrderCaptures {
  std::vector<Grid> grids;
  std::vector<FirstOrderTree> planes, means, certified_means, cut_means;
  std::vector<CompactFirstOrderTree> compact_planes, certified_compact_planes, cut_planes;
  double cut_planes_blocks = 0, cut_means_blocks = 0;  // per capture
};

// The texels' tolerances of a capture cut at `tolerance` of its mean, its lights' share
// included, as capture2qt cuts it.
std::array<double, 3> capture_tolerances(const Grid& texels,
                                         std::span<const DirectionalLight> lights,
                                         double tolerance) {
  std::array<double, 3> mean{};
  for (int c = 0; c < 3; ++c) {
    for (int y = 0; y < texels.resolution; ++y)
      for (int x = 0; x < texels.resolution; ++x)
        mean[std::size_t(c)] += texels.at(0, c, x, y);
    mean[std::size_t(c)] /= double(texels.resolution) * texels.resolution;
    for (const DirectionalLight& light : lights)
      mean[std::size_t(c)] += light.energy[c] * light.direction.z() / std::numbers::pi;
  }
  for (double& m : mean)
    m = tolerance * std::abs(m);
  return mean;
}

const FirstOrderCaptures& first_order_captures() {
  static FirstOrderCaptures captures;
  if (captures.grids.empty()) {
    const CaptureSetView set = main_job_file("captures").captures();
    for (std::size_t k = 0; k < set.size(); ++k) {
      captures.grids.push_back(reconstruct(set.trees.tree(k)));
      captures.planes.push_back(first_order_tree(captures.grids.back()));
      captures.means.push_back(without_slopes(captures.planes.back()));
      captures.compact_planes.push_back(compact(captures.planes.back()));
      const FirstOrderTree certified = first_order_tree(set.trees.tree(k));
      captures.certified_means.push_back(without_slopes(certified));
      captures.certified_compact_planes.push_back(compact(certified));
    }
    const CaptureSetView uncut = main_job_file("captures_texels").captures();
    const double tolerance = ProjectionOptions{}.tolerance;
    for (std::size_t k = 0; k < uncut.size(); ++k) {
      const Grid texels = reconstruct(uncut.trees.tree(k));
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
  const Lookup lookup = main_job_lookup(int(state.range(0)));
  const double accuracy = double(state.range(1)) / 1000;
  const int form = int(state.range(2));
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
  const FirstOrderTree table_tree = form == 0 || form == 6
                                        ? without_slopes(first_order_tree(table.grid))
                                    : form < 3 || form == 5 ? first_order_tree(table.grid)
                                    : form == 3 ? without_slopes(first_order_tree(terms))
                                                : first_order_tree(terms);
  const std::size_t count = captures.grids.size();
  const auto lookup_at = [&](std::size_t k) {
    switch (form) {
      case 0:
        return convolve_first_order(table_tree, captures.means[k], accuracy);
      case 1:
        return convolve_first_order(table_tree, captures.planes[k], accuracy);
      case 2:
        return convolve_first_order(table_tree, captures.compact_planes[k], accuracy);
      case 3:
        return convolve_first_order(table_tree, captures.certified_means[k], accuracy);
      case 4:
        return convolve_first_order(table_tree, captures.certified_compact_planes[k], accuracy);
      case 5:
        return convolve_first_order(table_tree, captures.cut_planes[k], accuracy);
      default:
        return convolve_first_order(table_tree, captures.cut_means[k], accuracy);
    }
  };
  {
    std::vector<double> errors, bounds;
    std::vector<Rgb> exact;
    double largest = 0, pairs = 0;
    for (const Grid& grid : captures.grids) {
      exact.push_back(dense_convolve_naive(table.grid, grid));
      for (const float e : exact.back())
        largest = std::max(largest, double(e));
    }
    for (std::size_t k = 0; k < count; ++k) {
      const FirstOrderConvolution r = lookup_at(k);
      pairs += double(r.pairs);
      for (int c = 0; c < 3; ++c)
        if (exact[k][c] > 1e-3 * largest) {
          errors.push_back(std::abs(double(r.convolution.value[c]) - exact[k][c]) / exact[k][c]);
          bounds.push_back(double(r.convolution.bound[c]) / exact[k][c]);
        }
    }
    std::sort(errors.begin(), errors.end());
    std::sort(bounds.begin(), bounds.end());
    const auto percentile = [](const std::vector<double>& v, double p) {
      return v.empty() ? 0.0 : 100 * v[std::min(v.size() - 1, std::size_t(p * double(v.size())))];
    };
    state.counters["pairs"] = pairs / double(count);
    state.counters["error_median_pct"] = percentile(errors, 0.5);
    state.counters["error_p99_pct"] = percentile(errors, 0.99);
    state.counters["bound_median_pct"] = percentile(bounds, 0.5);
    state.counters["bound_p99_pct"] = percentile(bounds, 0.99);
    if (form >= 5)
      state.counters["blocks"] = form == 5 ? captures.cut_planes_blocks : captures.cut_means_blocks;
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
