#!/usr/bin/env bash
# The installed package as a dependency: installs BUILD_DIR into a staging prefix, builds the
# consumer project against it with find_package(libbasis) and, separately, a one-file program
# with pkg-config, runs both on files the tools make, and checks their results against
# qtconvolve's. Usage: run.sh BUILD_DIR WORK_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
work=$2
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" >/dev/null
test -f "$work/prefix/lib/cmake/libbasis/libbasisConfig.cmake"
test -x "$work/prefix/bin/qtconvolve"

cmake -S "$here" -B "$work/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$work/prefix" >/dev/null
cmake --build "$work/consumer" >/dev/null

PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig" pkg-config --exists --print-errors libbasis
test "$(PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig" pkg-config --modversion libbasis)" = \
  "$(sed -n 's/^project(libbasis VERSION \([0-9.]*\).*/\1/p' "$here/../../CMakeLists.txt")"
# shellcheck disable=SC2046
c++ -O1 -o "$work/pkg_consumer" "$here/consumer.cpp" \
  $(PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig" pkg-config --cflags --libs libbasis)

cd "$work"
cat >phong.json <<'SPEC'
{"model": "phong", "kd": 0.5, "ks": 0.4, "exponent": 40, "table": {"wo_res": 9, "wi_res": 16}}
SPEC
"$work/prefix/bin/brdf2qt" phong.json -o table.qt -q
mkdir dumped
"$work/prefix/bin/capture2qt" --env-constant 0.2,0.5,1 --at 0,0,0 --res 16 -o captures.qt -q \
  --dump dumped
# The installed tools write and read images through the installed image module (PREFIX/lib).
test -f "$work/prefix/lib/libbasis_image_codec.so"
"$work/prefix/bin/capture2qt" --image dumped/capture_00000.exr -o image.qt -q
test -s image.qt
# A program built elsewhere finds the module of a package installed away from its configured
# prefix (as here) on its library path.
test "$(LD_LIBRARY_PATH="$work/prefix/lib" "$work/consumer/consumer" --image dumped/capture_00000.exr)" = "16 16 3"
test "$(LD_LIBRARY_PATH="$work/prefix/lib" "$work/pkg_consumer" --image dumped/capture_00000.exr)" = "16 16 3"
"$work/consumer/consumer" table.qt captures.qt >cmake.txt
"$work/pkg_consumer" table.qt captures.qt >pkg.txt
"$work/prefix/bin/qtconvolve" table.qt captures.qt --csv | tail -n +2 | cut -d, -f1-4 | tr , ' ' >tool.txt
# Same numbers, to the digits printed (7 significant).
python3 - cmake.txt pkg.txt tool.txt <<'PY'
import sys
rows = [[list(map(float, line.split())) for line in open(f)] for f in sys.argv[1:]]
assert rows[0] and len(rows[0]) == len(rows[2]) == len(rows[1]), rows
for a, b, c in zip(*rows):
    for x, y, z in zip(a, b, c):
        assert abs(x - z) <= 1e-6 * max(1, abs(z)) and abs(y - z) <= 1e-6 * max(1, abs(z)), (a, b, c)
print("consumer: the installed package gives qtconvolve's results,", len(rows[0]), "captures")
PY
