// Convolution and projection kernels, quadtree against dense textures, on the same functions in
// one run: float trees (projection's output) and packed trees (what files hold). Names:
// convolve/<method>/<brdf>/<res>, project/<method>/<res>.
#include <benchmark/benchmark.h>

#include <memory>

#include "basis/core/convolution.h"
#include "basis/core/dense.h"
#include "basis/core/packed_tree.h"
#include "basis/core/projection.h"
#include "bench_scenes.h"

namespace basis::bench {
namespace {

struct Pair {
  Grid brdf, light;
  Quadtree brdf_tree, light_tree;
  PackedTree brdf_packed, light_packed;
};

std::shared_ptr<const Pair> make_pair(const std::string& brdf_name, int n) {
  auto p = std::make_shared<Pair>();
  p->brdf = brdf_grid(paper_brdf(brdf_name), paper_outgoing(), n);
  p->light = sky_grid(n);
  p->brdf_tree = project(p->brdf, {.tolerance = 0.05});
  p->light_tree = project(p->light, {.tolerance = 0.05});
  p->brdf_packed = pack(p->brdf_tree);
  p->light_packed = pack(p->light_tree);
  return p;
}

void add_counters(benchmark::State& state, const Pair& p) {
  state.counters["brdf_nodes"] = p.brdf_tree.node_count();
  state.counters["light_nodes"] = p.light_tree.node_count();
}

void register_all() {
  for (int n : {32, 64, 128}) {
    for (const std::string brdf : {"lambert", "phong10", "phong100", "phong1000"}) {
      const auto p = make_pair(brdf, n);
      const std::string suffix = "/" + brdf + "/" + std::to_string(n);
      benchmark::RegisterBenchmark(
          ("convolve/quadtree" + suffix).c_str(), [p](benchmark::State& state) {
            for (auto _ : state)
              benchmark::DoNotOptimize(convolve_value(p->brdf_tree.view(), p->light_tree.view()));
            add_counters(state, *p);
          });
      benchmark::RegisterBenchmark(
          ("convolve/quadtree_bound" + suffix).c_str(), [p](benchmark::State& state) {
            for (auto _ : state)
              benchmark::DoNotOptimize(convolve(p->brdf_tree.view(), p->light_tree.view()));
            add_counters(state, *p);
          });
      benchmark::RegisterBenchmark(
          ("convolve/packed_bound" + suffix).c_str(), [p](benchmark::State& state) {
            for (auto _ : state)
              benchmark::DoNotOptimize(convolve(p->brdf_packed.view(), p->light_packed.view()));
            add_counters(state, *p);
          });
      benchmark::RegisterBenchmark(
          ("convolve/dense_naive" + suffix).c_str(), [p](benchmark::State& state) {
            for (auto _ : state)
              benchmark::DoNotOptimize(dense_convolve_naive(p->brdf, p->light));
          });
      benchmark::RegisterBenchmark(
          ("convolve/dense_simd" + suffix).c_str(), [p](benchmark::State& state) {
            for (auto _ : state)
              benchmark::DoNotOptimize(dense_convolve_simd(p->brdf, p->light));
          });
    }
    auto light = std::make_shared<const Grid>(sky_grid(n));
    // Projection with the default exact bound and with the paper's bound.
    for (const auto bound : {ProjectionOptions::Bound::exact, ProjectionOptions::Bound::paper}) {
      const std::string name = bound == ProjectionOptions::Bound::exact
                                   ? "project/quadtree/"
                                   : "project/quadtree_paper_bound/";
      benchmark::RegisterBenchmark(
          (name + std::to_string(n)).c_str(), [light, bound](benchmark::State& state) {
            QuadtreeProjector projector;
            Quadtree tree;
            for (auto _ : state) {
              projector.project(*light, {.tolerance = 0.05, .bound = bound}, tree);
              benchmark::DoNotOptimize(tree.nodes.data());
            }
            state.counters["nodes"] = tree.node_count();
          });
    }
    // Projection followed by packing, as the tools write trees.
    benchmark::RegisterBenchmark(("project/packed/" + std::to_string(n)).c_str(),
                                 [light](benchmark::State& state) {
                                   QuadtreeProjector projector;
                                   Quadtree tree;
                                   for (auto _ : state) {
                                     projector.project(*light, {.tolerance = 0.05}, tree);
                                     benchmark::DoNotOptimize(pack(tree).words.data());
                                   }
                                   state.counters["nodes"] = tree.node_count();
                                 });
  }
}

}  // namespace
}  // namespace basis::bench

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  basis::bench::register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
}
