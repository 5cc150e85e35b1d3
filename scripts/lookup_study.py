"""Lookups on real scenes, trees against dense grids: for each scene and map, 1000 captures at the
defaults, the main job's Phong and copper GGX tables at the main job's directions and off the
grid's rows, and qtconvolve --dense --time (the trees and the vectorised dense products of their
reconstructions timed in pairs of runs in one process, per lookup), at full depth and with an
--accuracy target; plus the capture sets' size against dense grids and, with --reference, the
lookups' error and certified bound against full-resolution references (the study then exits
with an error if a bound does not hold). With --no-bound, the full descents with their bound and
without it (qtconvolve --no-bound), in place of the full and targeted ones.

With --main-job ROUNDS, instead: the main job's own files (scripts/demo.sh's out/phong.qt,
out/ggx.qt and out/captures.qt), each lookup of the README's first table (the two tables at their
directions, full depth, full depth without the bound and at accuracy targets) timed in ROUNDS
rounds, the rounds one after another, and its error and certified bound against full-resolution
references once; it prints the README's table (ROUNDS odd, so that the median round is one of
them) and exits with an error if a bound does not hold, or if the values without the bound are
not the full descent's.

With --rounds N (odd), the lookups are timed in N rounds, each round over every scene (the
captures are traced first, one file per scene), and the table gives each lookup's median
round's times and ratio, with the ratios' range over the rounds.

Usage: lookup_study.py [--quick] [--reference] [--rounds N] [--no-bound] OUT_DIR
       lookup_study.py --main-job ROUNDS
The study prints a Markdown table and writes OUT_DIR/lookup_study.json, beside the two tables
and one capture set per scene (captures_K.qt, about 20-65 MB each). Needs build/bin
(scripts/setup.sh) and the maps of Debian's blender-data and the bunny of glmark2-data; the
probes of ../shared/data are used when present."""
import argparse
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
# An "accuracy" that stands for the full descent without its bound (qtconvolve --no-bound).
ALONE = "values alone"
ACCURACIES = [0, 0.05]
# The main job's lookups in the README's first table: (label, table, wo, entries, accuracies).
MAIN_JOB = [("Phong at the normal", "phong", "0,0,1", 1, [0, ALONE, 0.05, 0.1]),
            ("Phong 30°", "phong", "0.5,0,0.866", 2, [0, ALONE, 0.05, 0.1]),
            ("Phong off the rows", "phong", "0.3,0.2,0.93", 4, [0, ALONE, 0.05, 0.1]),
            ("copper GGX 30°", "ggx", "0.5,0,0.866", 2, [0, ALONE, 0.05, 0.1, 0.2]),
            ("copper GGX off the rows", "ggx", "0.3,0.2,0.93", 4, [0, ALONE, 0.05, 0.1, 0.2])]


def run(args, **kwargs):
    return subprocess.run(args, check=True, capture_output=True, text=True, **kwargs).stdout


def convolve(table, captures, wo, accuracy, dense, reference=False):
    args = [f"{BIN}/qtconvolve", table, captures, "--wo", wo, "--json", "-q"]
    if dense:
        args += ["--dense", "--time"]
    if accuracy == ALONE:
        args += ["--no-bound"]
    elif accuracy:
        args += ["--accuracy", str(accuracy)]
    if reference:
        args += ["--reference"]
    return json.loads(run(args))


def how(accuracy):
    """How a lookup descends, for tables: "full", "values alone" or "at R"."""
    return "full" if accuracy == 0 else accuracy if accuracy == ALONE else f"at {accuracy:g}"


def middle(values, key=None):
    """The middle one of values (odd in number) in the order of key."""
    return sorted(values, key=key)[len(values) // 2]


def percentiles(values):
    """Median and 99th percentile."""
    v = sorted(values)
    return v[len(v) // 2], v[len(v) * 99 // 100]


def errors(result, floor=1e-4):
    """Median and 99th percentile of |value - reference| / reference over the points and channels
    whose reference exceeds floor."""
    return percentiles(abs(r["difference"][c]) / r["reference"][c] for r in result["results"]
                       for c in range(3) if r["reference"][c] > floor)


def certified(result, floor=1e-3):
    """Whether every bound holds, and the bounds' median and 99th percentile relative to the
    reference, over the points and channels whose reference exceeds floor; and how many."""
    rows = [(r, c) for r in result["results"] for c in range(3) if r["reference"][c] > floor]
    held = all(abs(r["difference"][c]) <= r["bound"][c] for r in result["results"]
               for c in range(3))
    return held, percentiles(r["bound"][c] / r["reference"][c] for r, c in rows), len(rows)


def span(values, digits):
    """'lo–hi' of values (one figure when they round alike)."""
    lo, hi = f"{min(values):.{digits}f}", f"{max(values):.{digits}f}"
    return lo if lo == hi else f"{lo}–{hi}"


def main_job(rounds):
    out = os.path.join(ROOT, "out")
    captures = os.path.join(out, "captures.qt")
    for path in [captures] + [os.path.join(out, f"{name}.qt") for _, name, _, _, _ in MAIN_JOB]:
        if not os.path.exists(path):
            sys.exit(f"lookup_study: {path} is absent; run scripts/demo.sh first")
    cases = [(label, os.path.join(out, f"{name}.qt"), wo, entries, accuracy)
             for label, name, wo, entries, accuracies in MAIN_JOB for accuracy in accuracies]
    times = {case: [] for case in cases}
    for round_index in range(rounds):
        for case in cases:
            _, table, wo, _, accuracy = case
            r = convolve(table, captures, wo, accuracy, True)
            times[case].append((r["tree_ns_per_lookup"], r["ns_per_lookup"], r["tree_speedup"]))
        print(f"round {round_index + 1} of {rounds}: done", file=sys.stderr)
    print("| lookup | entries | trees | dense | trees faster | median of the rounds | "
          "error, median / p99 | certified bound, median / p99 |")
    print("|---|---|---|---|---|---|---|---|")
    full = {}  # each lookup's full descent with its reference
    for case in cases:
        label, table, wo, entries, accuracy = case
        trees = [t / 1000 for t, _, _ in times[case]]
        dense = [d / 1000 for _, d, _ in times[case]]
        ratios = [ratio for _, _, ratio in times[case]]
        timing = (f"| {entries} | {span(trees, 2)} µs | {span(dense, 1)} µs | "
                  f"{span(ratios, 1)}× | {middle(ratios):.1f}× |")
        if accuracy == ALONE:
            # The same descent without the bound: the full descent's values, hence its errors.
            r = convolve(table, captures, wo, ALONE, False)
            if [v["value"] for v in r["results"]] != [v["value"] for v in full[label]["results"]]:
                sys.exit(f"lookup_study: {label}: the values without the bound are not the full "
                         "descent's")
            e50, e99 = errors(full[label], 1e-3)
            print(f"| {label}, full descent, values alone (`--no-bound`) {timing} "
                  f"{100 * e50:.3f} % / {100 * e99:.2f} % (the full descent's values) | none |")
            print(f"{label} without the bound: the full descent's values", file=sys.stderr)
            continue
        r = convolve(table, captures, wo, accuracy, False, True)
        if accuracy == 0:
            full[label] = r
        e50, e99 = errors(r, 1e-3)
        held, (b50, b99), count = certified(r)
        if not held:
            sys.exit(f"lookup_study: a certified bound did not hold: {label} at {accuracy:g}")
        descent = "full descent" if accuracy == 0 else f"`--accuracy {accuracy:g}`"
        print(f"| {label}, {descent} {timing} {100 * e50:.3f} % / {100 * e99:.2f} % | "
              f"{100 * b50:.2f} % / {100 * b99:.2f} % |")
        print(f"{label} at {accuracy:g}: {count} values, every bound held", file=sys.stderr)


def main():
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], epilog="\n\n".join(__doc__.split("\n\n")[1:]),
        formatter_class=argparse.RawDescriptionHelpFormatter,
        usage="%(prog)s [--quick] [--reference] [--rounds N] [--no-bound] OUT_DIR | "
              "%(prog)s --main-job ROUNDS")
    parser.add_argument("out", nargs="?", metavar="OUT_DIR", help="where the study's files go")
    parser.add_argument("--quick", action="store_true", help="200 captures a scene, not 1000")
    parser.add_argument("--reference", action="store_true",
                        help="also the lookups' error and certified bound against full-resolution "
                             "references (an error exit if a bound does not hold)")
    parser.add_argument("--rounds", type=int, metavar="N",
                        help="time the lookups in N rounds, each over every scene (odd; default 1)")
    parser.add_argument("--no-bound", action="store_true",
                        help="time the full descents with their bound and without it (qtconvolve "
                             "--no-bound) in place of the full and targeted ones")
    parser.add_argument("--main-job", type=int, metavar="ROUNDS",
                        help="time the main job's own lookups in ROUNDS rounds instead")
    args = parser.parse_args()
    if args.main_job is not None:
        if args.main_job < 1 or args.main_job % 2 == 0:
            parser.error("--main-job needs an odd number of rounds (1, 3, 5, ...)")
        if args.out or args.quick or args.reference or args.rounds is not None or args.no_bound:
            parser.error("--main-job takes no OUT_DIR, --quick, --reference, --rounds or "
                         "--no-bound (it reads out/ and times every kind of lookup)")
        main_job(args.main_job)
        return
    if args.out is None:
        parser.error("OUT_DIR is required (or --main-job ROUNDS)")
    if args.rounds is None:
        args.rounds = 1
    if args.rounds < 1 or args.rounds % 2 == 0:
        parser.error("--rounds needs an odd number (1, 3, 5, ...)")
    quick, reference, out = args.quick, args.reference, args.out
    accuracies = [0, ALONE] if args.no_bound else ACCURACIES
    os.makedirs(out, exist_ok=True)
    points = "200" if quick else "1000"
    tables = {}
    for _, name, _ in LOOKUPS:
        tables[name] = os.path.join(out, f"{name}.qt")
        if not os.path.exists(tables[name]):
            run([f"{BIN}/brdf2qt", os.path.join(ROOT, "data", f"{name}.json"), "-o", tables[name],
                 "-q"])
    # Every scene's captures first, then the rounds, each over every scene, so that a slow moment
    # of the machine falls on one round of several scenes rather than on every round of one.
    rows, capture_files = [], []
    for case, scene, env in CASES:
        if not (os.path.exists(scene) and os.path.exists(env)):
            print(f"{case}: skipped, {scene if not os.path.exists(scene) else env} is absent",
                  file=sys.stderr)
            continue
        captures = os.path.join(out, f"captures_{len(rows)}.qt")
        summary = json.loads(run([f"{BIN}/capture2qt", "--env", env, "--scene", scene, "--sample",
                                  points, "--seed", "1", "-o", captures, "--json"]))
        dense_bytes = int(points) * 128 * 128 * 3 * 4
        rows.append({"case": case, "captures": int(points), "bytes": summary["bytes"],
                     "nodes_per_capture": summary["nodes"] / int(points),
                     "smaller": dense_bytes / summary["bytes"], "lookups": {}})
        capture_files.append(captures)
        print(f"{case}: traced", file=sys.stderr)
    timed = [{(label, accuracy): [] for label, _, _ in LOOKUPS for accuracy in accuracies}
             for _ in rows]
    for round_index in range(args.rounds):
        for times, captures in zip(timed, capture_files):
            for label, name, wo in LOOKUPS:
                for accuracy in accuracies:
                    r = convolve(tables[name], captures, wo, accuracy, True)
                    times[label, accuracy].append(
                        {"tree_ns": r["tree_ns_per_lookup"], "dense_ns": r["ns_per_lookup"],
                         "speedup": r["tree_speedup"]})
        print(f"round {round_index + 1} of {args.rounds}: done", file=sys.stderr)
    failures = []
    for row, times, captures in zip(rows, timed, capture_files):
        for label, name, wo in LOOKUPS:
            for accuracy in accuracies:
                entry = dict(middle(times[label, accuracy], key=lambda t: t["speedup"]))
                entry["speedups"] = [t["speedup"] for t in times[label, accuracy]]
                if reference:
                    r = convolve(tables[name], captures, wo, accuracy, False, True)
                    entry["error_p50"], entry["error_p99"] = errors(r, 1e-3)
                    if accuracy != ALONE:
                        held, (entry["bound_p50"], entry["bound_p99"]), entry["values"] = \
                            certified(r)
                        entry["bound_held"] = held
                        if not held:
                            failures.append(f"{row['case']}, {label} {how(accuracy)}")
                row["lookups"][f"{label}@{accuracy}"] = entry
    with open(os.path.join(out, "lookup_study.json"), "w") as f:
        json.dump(rows, f, indent=1)
    head = "| scene, map | nodes per capture | smaller than dense |"
    rule = "|---|---|---|"
    for label, _, _ in LOOKUPS:
        for accuracy in accuracies:
            head += f" {label} {how(accuracy)}: trees (dense) µs, ×|"
            rule += "---|"
    print(head)
    print(rule)
    for row in rows:
        line = f"| {row['case']} | {row['nodes_per_capture']:.0f} | {row['smaller']:.1f}× |"
        for label, _, _ in LOOKUPS:
            for accuracy in accuracies:
                e = row["lookups"][f"{label}@{accuracy}"]
                line += f" {e['tree_ns'] / 1000:.2f} ({e['dense_ns'] / 1000:.1f}), {e['speedup']:.1f}×"
                if len(e["speedups"]) > 1:
                    line += f" ({span(e['speedups'], 1)}×)"
                if "error_p50" in e:
                    line += f", error {100 * e['error_p50']:.3f} / {100 * e['error_p99']:.2f} %"
                if "bound_p50" in e:
                    line += (f", bound {100 * e['bound_p50']:.2f} / {100 * e['bound_p99']:.2f} % "
                             f"({e['values']} values)")
                line += " |"
        print(line)
    if failures:
        sys.exit("lookup_study: a certified bound did not hold: " + "; ".join(failures))


if __name__ == "__main__":
    main()
