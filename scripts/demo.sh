#!/usr/bin/env bash
# The main job: set-up, Release build, then the whole pipeline on the bundled data.
#   brdf2qt     data/phong.json (the paper's Lambert + Phong) and data/ggx.json (rough copper)
#   capture2qt  1000 points sampled on data/scene.obj under a Poly Haven sunrise (CC0, from
#               Debian's blender-data), traced with Embree
#   qtconvolve  reflected radiance of both BRDFs at every point, with bounds and timings
#   qtinfo      what each file holds, and pictures of a table entry and of a capture
#   qtrender    data/scene.json (the scene in Lambert + Phong 100 under the sunrise) through the
#               radiance cache, by Monte Carlo in the same time and by converged Monte Carlo,
#               with a side-by-side picture and enlarged insets (the paper's Figure 1) and the
#               cache's time split against a dense-grid cache (Figure 7)
# Results, pictures and a summary go to ./out.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh build >/dev/null
mkdir -p out
bin=build/bin
env_map=/usr/share/blender/datafiles/studiolights/world/sunrise.exr
summary=out/summary.txt
: >"$summary"

step() {  # step NAME command...: runs a command, records its wall time
  local name=$1
  shift
  local start end
  start=$(date +%s.%N)
  "$@"
  end=$(date +%s.%N)
  printf '%-44s %6.2f s\n' "$name" "$(echo "$end - $start" | bc)" >>"$summary"
}

step "brdf2qt phong.json (57x57 x 128x128)" $bin/brdf2qt data/phong.json -o out/phong.qt
step "brdf2qt ggx.json (33x33 x 128x128)" $bin/brdf2qt data/ggx.json -o out/ggx.qt
step "capture2qt 1000 points, 128x128, 4 spp" \
  $bin/capture2qt --env "$env_map" --scene data/scene.obj --sample 1000 --seed 1 -o out/captures.qt
step "qtconvolve phong x captures" \
  $bin/qtconvolve out/phong.qt out/captures.qt --time --csv --png out/phong_radiance.png \
  >out/phong_radiance.csv 2>out/phong_time.txt
step "qtconvolve ggx x captures (wo 30 deg)" \
  $bin/qtconvolve out/ggx.qt out/captures.qt --wo 0.5,0,0.866 --time --csv \
  --png out/ggx_radiance.png >out/ggx_radiance.csv 2>out/ggx_time.txt
step "qtrender cache, same-time mc, reference" \
  /usr/bin/python3 scripts/render_study.py --main-job out/render >out/render_summary.txt
$bin/qtinfo out/phong.qt --png out/phong_entry.png --entry 28,18 >out/phong_info.txt
$bin/qtinfo out/captures.qt --png out/capture.png --index 0 >out/captures_info.txt

{
  echo
  echo "phong:  $(cat out/phong_time.txt)"
  echo "ggx:    $(cat out/ggx_time.txt)"
  echo
  grep -E '^(kind|trees|nodes|storage|tilt)' out/phong_info.txt | sed 's/^/phong.qt     /'
  grep -E '^(kind|trees|nodes|storage|lights)' out/captures_info.txt | sed 's/^/captures.qt  /'
  echo
  echo "first points (index, r, g, b, bounds):"
  sed -n 2,4p out/phong_radiance.csv
  echo
  echo "render: $(cat out/render_summary.txt)"
  echo
  echo "pictures: out/phong_entry.png (a table entry), out/capture.png (a capture),"
  echo "          out/phong_radiance.png, out/ggx_radiance.png (the points seen from above),"
  echo "          out/render/figure1.png (cache, same-time Monte Carlo, reference; insets),"
  echo "          out/render/figure7.png (where the cache's time goes, trees against grids)"
} >>"$summary"
cat "$summary"
