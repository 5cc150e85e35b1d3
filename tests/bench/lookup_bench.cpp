// Lookups on real data, cold: the main job's tables against its 1000 captures read from a file
// (main_job_data.h), by the trees (full descents and accuracy targets) and by vectorised dense
// products of the trees' reconstructions, side by side. Also one capture repeated (hot), to
// tell the cost of the descent from the cost of reaching memory.
#include <benchmark/benchmark.h>

#include "basis/lighting/shading.h"
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

// Arguments: table (0 Phong, 1 GGX), accuracy in thousandths, hot (1: capture 0 repeated).
void BM_TreeLookups(benchmark::State& state) {
  const Lookup lookup = main_job_lookup(int(state.range(0)));
  const BrdfTableView table = main_job_file(lookup.table).brdf_table();
  const CaptureSetView captures = main_job_file("captures").captures();
  ShadingOptions options;
  options.wo = lookup.wo;
  options.convolution.accuracy = double(state.range(1)) / 1000;
  const bool hot = state.range(2) != 0;
  for (auto _ : state)
    for (std::size_t k = 0; k < captures.size(); ++k)
      benchmark::DoNotOptimize(shade(table, captures, hot ? 0 : k, options));
  state.SetItemsProcessed(std::int64_t(state.iterations() * captures.size()));
}
BENCHMARK(BM_TreeLookups)
    ->Name("lookup/trees")
    ->ArgNames({"ggx", "accuracy_permille", "hot"})
    ->ArgsProduct({{0, 1}, {0, 10, 50, 100}, {0, 1}})
    ->Unit(benchmark::kMillisecond);

void BM_DenseLookups(benchmark::State& state) {
  const Lookup lookup = main_job_lookup(int(state.range(0)));
  const DenseLookup table = dense_lookup(main_job_file(lookup.table).brdf_table(), lookup.wo);
  const CaptureSetView captures = main_job_file("captures").captures();
  static std::vector<Grid> grids;
  if (grids.empty())
    for (std::size_t k = 0; k < captures.size(); ++k)
      grids.push_back(reconstruct(captures.trees.tree(k)));
  const bool hot = state.range(1) != 0;
  for (auto _ : state)
    for (std::size_t k = 0; k < captures.size(); ++k) {
      const std::size_t i = hot ? 0 : k;
      benchmark::DoNotOptimize(shade_dense(table, grids[i], captures.lights_of(i), nullptr));
    }
  state.SetItemsProcessed(std::int64_t(state.iterations() * captures.size()));
}
BENCHMARK(BM_DenseLookups)
    ->Name("lookup/dense")
    ->ArgNames({"ggx", "hot"})
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace basis::bench
