"""Lookups on real scenes, trees against dense grids: for each scene and map, 1000 captures at the
defaults, the main job's Phong and copper GGX tables at the main job's directions and off the
grid's rows, and qtconvolve --dense --time (the trees and the vectorised dense products of their
reconstructions timed in one run, per lookup), at full depth and with an --accuracy target; plus the capture sets' size against dense grids and,
with --reference, the lookups' error against full-resolution references.

Usage: lookup_study.py [--quick] [--reference] OUT_DIR
Prints a Markdown table and writes OUT_DIR/lookup_study.json. Needs build/bin (scripts/setup.sh)
and the maps of Debian's blender-data and the bunny of glmark2-data; the probes of
../shared/data are used when present."""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "build", "bin")
WORLD = "/usr/share/blender/datafiles/studiolights/world"
BUNNY = "/usr/share/glmark2/models/bunny.obj"
SCENE = os.path.join(ROOT, "data", "scene.obj")
PROBES = os.path.join(ROOT, "..", "shared", "data", "probes")

# (name, OBJ, map): the main job first, then scenes and maps it has not seen.
CASES = [
    ("main job: scene.obj, sunrise", SCENE, f"{WORLD}/sunrise.exr"),
    ("bunny, forest", BUNNY, f"{WORLD}/forest.exr"),
    ("bunny, city", BUNNY, f"{WORLD}/city.exr"),
    ("scene.obj, courtyard", SCENE, f"{WORLD}/courtyard.exr"),
    ("scene.obj, interior", SCENE, f"{WORLD}/interior.exr"),
    ("bunny, sunset", BUNNY, f"{WORLD}/sunset.exr"),
    ("scene.obj, uffizi probe", SCENE, f"{PROBES}/uffizi.hdr"),
    ("bunny, grace probe", BUNNY, f"{PROBES}/grace.hdr"),
]
# (label, table, wo): the main job's lookups, Phong at the normal (one entry) and GGX 30 degrees
# off it (two entries, folded), and both off the grid's rows, where a lookup reads four entries.
LOOKUPS = [("Phong normal", "phong", "0,0,1"), ("Phong off-grid", "phong", "0.3,0.2,0.93"),
           ("GGX 30°", "ggx", "0.5,0,0.866"), ("GGX off-grid", "ggx", "0.3,0.2,0.93")]
ACCURACIES = [0, 0.05]


def run(args, **kwargs):
    return subprocess.run(args, check=True, capture_output=True, text=True, **kwargs).stdout


def convolve(table, captures, wo, accuracy, dense, reference=False):
    args = [f"{BIN}/qtconvolve", table, captures, "--wo", wo, "--json", "-q"]
    if dense:
        args += ["--dense", "--time"]
    if accuracy:
        args += ["--accuracy", str(accuracy)]
    if reference:
        args += ["--reference"]
    return json.loads(run(args))


def errors(result):
    """Median and 99th percentile of |value - reference| / reference over points and channels."""
    e = sorted(abs(r["difference"][c]) / r["reference"][c] for r in result["results"]
               for c in range(3) if r["reference"][c] > 1e-4)
    return e[len(e) // 2], e[len(e) * 99 // 100]


def main():
    quick = "--quick" in sys.argv
    reference = "--reference" in sys.argv
    out = [a for a in sys.argv[1:] if not a.startswith("--")][0]
    os.makedirs(out, exist_ok=True)
    points = "200" if quick else "1000"
    tables = {}
    for _, name, _ in LOOKUPS:
        tables[name] = os.path.join(out, f"{name}.qt")
        if not os.path.exists(tables[name]):
            run([f"{BIN}/brdf2qt", os.path.join(ROOT, "data", f"{name}.json"), "-o", tables[name],
                 "-q"])
    rows = []
    for case, scene, env in CASES:
        if not (os.path.exists(scene) and os.path.exists(env)):
            print(f"{case}: skipped, {scene if not os.path.exists(scene) else env} is absent",
                  file=sys.stderr)
            continue
        captures = os.path.join(out, "captures.qt")
        summary = json.loads(run([f"{BIN}/capture2qt", "--env", env, "--scene", scene, "--sample",
                                  points, "--seed", "1", "-o", captures, "--json"]))
        dense_bytes = int(points) * 128 * 128 * 3 * 4
        row = {"case": case, "captures": int(points), "bytes": summary["bytes"],
               "nodes_per_capture": summary["nodes"] / int(points),
               "smaller": dense_bytes / summary["bytes"], "lookups": {}}
        for label, name, wo in LOOKUPS:
            for accuracy in ACCURACIES:
                r = convolve(tables[name], captures, wo, accuracy, True)
                entry = {"tree_ns": r["tree_ns_per_lookup"], "dense_ns": r["ns_per_lookup"],
                         "speedup": r["ns_per_lookup"] / r["tree_ns_per_lookup"]}
                if reference:
                    entry["error_p50"], entry["error_p99"] = errors(
                        convolve(tables[name], captures, wo, accuracy, False, True))
                row["lookups"][f"{label}@{accuracy}"] = entry
        rows.append(row)
        print(f"{case}: done", file=sys.stderr)
    with open(os.path.join(out, "lookup_study.json"), "w") as f:
        json.dump(rows, f, indent=1)
    head = "| scene, map | nodes per capture | smaller than dense |"
    rule = "|---|---|---|"
    for label, _, _ in LOOKUPS:
        for accuracy in ACCURACIES:
            head += f" {label} {'full' if accuracy == 0 else f'at {accuracy:g}'}: trees (dense) µs, ×|"
            rule += "---|"
    print(head)
    print(rule)
    for row in rows:
        line = f"| {row['case']} | {row['nodes_per_capture']:.0f} | {row['smaller']:.1f}× |"
        for label, _, _ in LOOKUPS:
            for accuracy in ACCURACIES:
                e = row["lookups"][f"{label}@{accuracy}"]
                line += f" {e['tree_ns'] / 1000:.2f} ({e['dense_ns'] / 1000:.1f}), {e['speedup']:.1f}×"
                if "error_p50" in e:
                    line += f", err {100 * e['error_p50']:.2f} / {100 * e['error_p99']:.2f} %"
                line += " |"
        print(line)


if __name__ == "__main__":
    main()
