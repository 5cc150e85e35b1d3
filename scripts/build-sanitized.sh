#!/usr/bin/env bash
# The sanitizer build in ./build-asan, after the set-up (which installs clang): clang,
# AddressSanitizer + UndefinedBehaviorSanitizer on everything, and the libFuzzer targets (the
# readers' sources carry fuzzer coverage). Without AVX-512 and AVX2: the convolution takes the
# SSE4.1 path of CPUs that lack them, which the Release build (AVX-512 or AVX2, whichever the
# machine has) does not. The tests run from it (scripts/test.sh) and so do the fuzz targets
# (scripts/fuzz.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
# Line tables only: reports keep file and line, and the build is faster than with full -g.
# Benchmarks are not built here: timings under the sanitizers mean nothing.
scripts/setup.sh build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" \
  -DBASIS_SANITIZE=ON -DBASIS_FUZZ=ON -DBASIS_BUILD_BENCHMARKS=OFF -DBASIS_AVX512=OFF -DBASIS_AVX2=OFF
