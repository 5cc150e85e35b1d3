#!/usr/bin/env bash
# Builds the libFuzzer targets (scripts/build-sanitized.sh: clang, AddressSanitizer + UBSan) and
# runs each for a bounded time on its seed corpus (tests/fuzz/corpus, plus small .qt files made
# by ./build's tools and an RGL file from ../shared/data/rgl-bsdf when those exist). Fails on
# any crash, leak or sanitizer report.
# Usage: scripts/fuzz.sh [seconds per target, default BASIS_FUZZ_SECONDS or 15]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-${BASIS_FUZZ_SECONDS:-15}}
targets=(fuzz_qt_file fuzz_brdf_spec fuzz_measured fuzz_scene_files fuzz_render_scene fuzz_manifest)
# A ./build-asan whose cache lacks the fuzz targets or the sanitizers (a folder configured by
# hand) is configured again as the sanitizer build configures it, and built, first. Only those two
# options are checked.
sanitized() {
  grep -qx 'BASIS_FUZZ:BOOL=ON' build-asan/CMakeCache.txt 2>/dev/null &&
    grep -qx 'BASIS_SANITIZE:BOOL=ON' build-asan/CMakeCache.txt
}
if ! sanitized || [ ! -x build-asan/bin/fuzz_scene_files ]; then scripts/build-sanitized.sh; fi
cmake --build build-asan -j "$(nproc)" --target "${targets[@]}"

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
for target in "${targets[@]}"; do
  mkdir -p "$scratch/$target"
  cp tests/fuzz/corpus/$target/* "$scratch/$target/" 2>/dev/null || true
done
# Seeds made now, so they follow the current format: a tiny table and tiny capture sets.
if [ -x build/bin/brdf2qt ] && [ -x build/bin/capture2qt ]; then
  echo '{"model": "phong", "kd": 0.5, "ks": 0.4, "exponent": 20, "table": {"wo_res": 2, "wi_res": 4}}' \
    >"$scratch/tiny.json"
  build/bin/brdf2qt "$scratch/tiny.json" -o "$scratch/fuzz_qt_file/table.qt" >/dev/null
  build/bin/capture2qt --env-constant 1,0.8,0.6 --scene data/scene.obj --sample 3 --res 8 -q \
    -o "$scratch/fuzz_qt_file/captures.qt"
  # Under a sky at 16², nodes refined over all four quadrants, which files hold as links alone.
  if [ -f /usr/share/blender/datafiles/studiolights/world/sunrise.exr ]; then
    build/bin/capture2qt --env /usr/share/blender/datafiles/studiolights/world/sunrise.exr \
      --scene data/scene.obj --sample 3 --res 16 -q -o "$scratch/fuzz_qt_file/detail.qt"
  fi
  sunrise=/usr/share/blender/datafiles/studiolights/world/sunrise.exr
  if [ -f "$sunrise" ]; then  # a capture set that keeps a sun apart (format version 2)
    build/bin/capture2qt --env "$sunrise" --points <(printf '0,0,0,0.3,-0.6,0.74\n0,0,0,0,0,1\n') \
      --res 8 -q -o "$scratch/fuzz_qt_file/sun.qt"
  fi
fi
# The first input byte picks the reader in fuzz_measured: even bytes mean RGL.
rgl=$(ls -S ../shared/data/rgl-bsdf/*.bsdf 2>/dev/null | tail -1 || true)
if [ -n "$rgl" ]; then
  { printf '\x00'; cat "$rgl"; } >"$scratch/fuzz_measured/real.bsdf"
fi

# One target for the given time; its log and exit status land in the scratch folder.
run_target() {
  local target=$1 status=0
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:intercept_tls_get_addr=0 \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    "build-asan/bin/$target" -max_total_time="$seconds" -rss_limit_mb=4096 \
    -max_len=1048576 -print_final_stats=1 -artifact_prefix="build-asan/$target-" \
    "$scratch/$target" >"$scratch/$target.log" 2>&1 || status=$?
  echo "$status" >"$scratch/$target.status"
}

# As many targets at once as there are cores.
jobs=$(nproc)
echo "fuzz: ${#targets[@]} targets, ${seconds} s each, ${jobs} at a time"
for target in "${targets[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
  run_target "$target" &
done
wait

failed=0
for target in "${targets[@]}"; do
  status=$(cat "$scratch/$target.status")
  runs=$(grep -oP '^stat::number_of_executed_units: \K[0-9]+' "$scratch/$target.log" || echo '?')
  echo "== $target: $(ls "$scratch/$target" | wc -l) corpus inputs, $runs runs, exit $status"
  if [ "$status" -ne 0 ]; then
    tail -40 "$scratch/$target.log" >&2
    echo "fuzz: $target failed (exit $status); the input is in build-asan/$target-*" >&2
    failed=1
  fi
done
[ "$failed" -eq 0 ] || exit 1
echo "fuzz: every target ran ${seconds} s without a report"
