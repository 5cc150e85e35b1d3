// Loading .qt files: read and verify (structure and semantics) a capture set of 100,000 trees,
// packed as other trees (read in place) or as capture2qt packs them (exact texels in
// shared-exponent words, the values of fully refined nodes restored on loading).
#include <benchmark/benchmark.h>

#include <filesystem>
#include <random>

#include "basis/core/projection.h"
#include "basis/format/qt_file.h"
#include "bench_scenes.h"

namespace basis::bench {
namespace {

// 100,000 captures at 32 x 32, RGB, 5 %: 64 distinct skies (the sun moves) repeated.
std::string make_capture_file(bool exact_texels) {
  const std::string name =
      exact_texels ? "basis_bench_100k_exact_captures.qt" : "basis_bench_100k_captures.qt";
  const std::string p = (std::filesystem::temp_directory_path() / name).string();
  {
    std::vector<PackedTree> distinct;
    for (int k = 0; k < 64; ++k) {
      const Quadtree tree = project(sky_grid(32, 0.1 * k), {});
      distinct.push_back(exact_texels ? pack_exact_texels(tree) : pack(tree));
    }
    CaptureSet set;
    set.trees = TreeSet(distinct[0].shape);
    for (int i = 0; i < 100000; ++i) {
      set.trees.append(distinct[i % 64].view());
      set.positions.push_back({0.01 * i, 0, 0});
      set.normals.push_back({0, 0, 1});
      set.tangents.push_back({1, 0, 0});
    }
    write_qt(p, encode_capture_set(set.view(), {}, {"basis_bench", "", "{}", {}}));
  }
  return p;
}

// Each file made once per process.
std::string capture_file(bool exact_texels) {
  static const std::string in_place = make_capture_file(false), restored = make_capture_file(true);
  return exact_texels ? restored : in_place;
}

void BM_LoadCaptureSet(benchmark::State& state) {
  const std::string path = capture_file(state.range(0) != 0);
  std::size_t bytes = 0, trees = 0;
  bool in_place = false;
  for (auto _ : state) {
    const QtFile file = QtFile::load(path);
    bytes = file.byte_size();
    trees = file.trees().size();
    in_place = file.zero_copy();
    benchmark::DoNotOptimize(file.trees().words().data());
  }
  state.SetBytesProcessed(std::int64_t(bytes) * state.iterations());
  state.counters["trees"] = double(trees);
  state.counters["file_MiB"] = double(bytes) / (1 << 20);
  state.counters["in_place"] = in_place;
}
BENCHMARK(BM_LoadCaptureSet)
    ->Name("load/capture_set/100000")
    ->ArgName("exact_texels")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5);

}  // namespace
}  // namespace basis::bench
