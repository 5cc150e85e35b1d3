#!/usr/bin/env bash
# Set-up, Release build and the whole test suite; then the same suite under AddressSanitizer and
# UndefinedBehaviorSanitizer; then every fuzz target for a bounded time (BASIS_FUZZ_SECONDS,
# default 60). Skip the second or third pass locally with BASIS_SKIP_SANITIZERS=1 or
# BASIS_SKIP_FUZZ=1.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh build
ctest --test-dir build --output-on-failure -j "$(nproc)"

if [ "${BASIS_SKIP_SANITIZERS:-0}" != 1 ]; then
  scripts/setup.sh build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DBASIS_SANITIZE=ON
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
    ctest --test-dir build-asan --output-on-failure -j "$(nproc)"
fi

if [ "${BASIS_SKIP_FUZZ:-0}" != 1 ]; then
  scripts/fuzz.sh
fi
