#!/usr/bin/env bash
# Set-up, Release build, and the main job on the bundled data. Results go to ./out.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh build
mkdir -p out
echo "== convolution and projection kernels: quadtree against dense textures (medians of 5)"
build/bin/basis_bench --benchmark_min_time=0.05 --benchmark_repetitions=5 \
  --benchmark_report_aggregates_only=true \
  --benchmark_filter='(convolve/(quadtree|dense_naive|dense_simd)/phong100/)|project/' \
  --benchmark_out=out/basis_bench.json --benchmark_out_format=json |
  grep -E 'median|Benchmark'
