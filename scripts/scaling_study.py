"""The scaling model of sharded runs, measured on this machine: capture and lookup throughput
per core, bytes per point, and what splitting a run into 1, 2 and 4 shards adds (each shard's
process start, map and scene loading, checksums; the manifest and the join), then projected to
large runs on a cluster.

Usage: scaling_study.py [--points P] [--cores C] [--nodes N] [--fs-gbs B] OUT_DIR
  --points P   points of the measured run (default 1000, the main job's)
  --cores C    cores per cluster node in the projection (default 32)
  --nodes N    cluster nodes in the projection (default 100)
  --fs-gbs B   the cluster file system's aggregate read bandwidth in GB/s (default 20), which
               bounds the lookup array and the manifest step, both reading every capture
Prints Markdown tables and writes OUT_DIR/scaling.json. Needs build/bin (scripts/setup.sh), the
sunrise map of Debian's blender-data and the bundled scene. Every process runs on one thread,
one after another, so that the figures are per core."""
import json
import math
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "build", "bin")
ENV = "/usr/share/blender/datafiles/studiolights/world/sunrise.exr"
SCENE = os.path.join(ROOT, "data", "scene.obj")
MAX_FILE = (1 << 31) - 1  # one .qt file
MAX_POINTS_PER_FILE = 10_000_000


def run(args):
    """Runs a command; returns its wall time in seconds and its standard output."""
    start = time.perf_counter()
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    return time.perf_counter() - start, out


def median_time(args, runs=5):
    return sorted(run(args)[0] for _ in range(runs))[runs // 2]


def option(name, default):
    if name in sys.argv:
        return type(default)(sys.argv[sys.argv.index(name) + 1])
    return default


def main():
    points = option("--points", 1000)
    cores = option("--cores", 32)
    nodes = option("--nodes", 100)
    fs_bytes_per_s = option("--fs-gbs", 20.0) * 1e9
    values = {sys.argv[i + 1] for i, a in enumerate(sys.argv[:-1]) if a.startswith("--")}
    out = [a for a in sys.argv[1:] if not a.startswith("--") and a not in values][0]
    os.makedirs(out, exist_ok=True)
    capture = [f"{BIN}/capture2qt", "--env", ENV, "--scene", SCENE, "--sample", str(points),
               "--seed", "1", "--threads", "1", "-q"]
    table = os.path.join(out, "phong.qt")
    if not os.path.exists(table):
        run([f"{BIN}/brdf2qt", os.path.join(ROOT, "data", "phong.json"), "-o", table, "-q"])

    # One process: capture, then look up every point (whole commands, loading included), and
    # the lookups' own time per point (qtconvolve --time).
    single = os.path.join(out, "single.qt")
    t_capture, _ = run(capture + ["-o", single])
    size = os.path.getsize(single)
    t_lookup, _ = run([f"{BIN}/qtconvolve", table, single, "--csv", "-o",
                       os.path.join(out, "single.csv")])
    _, timed = run([f"{BIN}/qtconvolve", table, single, "--json", "--time", "-q"])
    ns_per_lookup = json.loads(timed)["ns_per_lookup"]
    result = {"points": points, "capture_s": t_capture, "bytes": size,
              "lookup_command_s": t_lookup, "lookup_ns": ns_per_lookup, "shards": {}}

    for shards in (1, 2, 4):
        folder = os.path.join(out, f"shards{shards}")
        os.makedirs(folder, exist_ok=True)
        files = [os.path.join(folder, f"captures.{k}.qt") for k in range(shards)]
        for f in files:
            for stale in (f, f + ".xxh128"):
                if os.path.exists(stale):
                    os.remove(stale)
        t_shards = [run(capture + ["--shard", f"{k}/{shards}", "-o", files[k]])[0]
                    for k in range(shards)]
        manifest = os.path.join(folder, "captures.qtm")
        t_manifest, _ = run([f"{BIN}/qtmerge", *files, "--manifest", manifest, "-q"])
        joined = os.path.join(folder, "joined.qt")
        t_join, _ = run([f"{BIN}/qtmerge", *files, "-o", joined, "-q"])
        with open(single, "rb") as a, open(joined, "rb") as b:
            identical = a.read() == b.read()
        csv = os.path.join(folder, "lookups.csv")
        t_lookup_manifest, _ = run([f"{BIN}/qtconvolve", table, manifest, "--csv", "-o", csv])
        t_lookup_shards = [run([f"{BIN}/qtconvolve", table, manifest, "--csv", "--shard",
                                f"{k}/{shards}", "-o", f"{csv}.{k}"])[0] for k in range(shards)]
        with open(os.path.join(out, "single.csv")) as a, open(csv) as b:
            same_lookups = a.read() == b.read()
        result["shards"][shards] = {
            "capture_s": sum(t_shards), "capture_overhead_s": sum(t_shards) - t_capture,
            "manifest_s": t_manifest, "join_s": t_join, "identical": identical,
            "lookup_manifest_s": t_lookup_manifest, "lookup_shards_s": sum(t_lookup_shards),
            "same_lookups": same_lookups}
        print(f"{shards} shards: done", file=sys.stderr)

    # The fixed cost of one shard's process, measured directly (medians of 5): a capture task of
    # one point (process start, map, scene and its ray-tracing structure, writing, checksum),
    # a lookup task over one point (process start, the table loaded and verified), and the
    # start of a merge that reads nothing; the manifest's reading and checking per byte.
    tiny = os.path.join(out, "tiny.qt")
    per_shard = median_time(capture[:5] + ["--sample", "1", "--threads", "1", "-q", "-o", tiny])
    per_lookup_shard = median_time([f"{BIN}/qtconvolve", table, tiny, "--csv", "-o",
                                    os.path.join(out, "tiny.csv")])
    merge_start = median_time([f"{BIN}/qtmerge", "--version"])
    four_files = [os.path.join(out, "shards4", f"captures.{k}.qt") for k in range(4)]
    t_manifest = median_time([f"{BIN}/qtmerge", *four_files, "--manifest",
                              os.path.join(out, "shards4", "captures.qtm"), "-q"])
    manifest_per_byte = max(1e-12, t_manifest - merge_start) / size
    capture_rate = points / max(1e-9, t_capture - per_shard)
    lookup_rate = 1e9 / ns_per_lookup
    bytes_per_point = size / points
    result["model"] = {"capture_points_per_s_per_core": capture_rate,
                       "lookup_points_per_s_per_core": lookup_rate,
                       "bytes_per_point": bytes_per_point, "capture_shard_overhead_s": per_shard,
                       "lookup_shard_overhead_s": per_lookup_shard,
                       "manifest_s_per_byte": manifest_per_byte,
                       "manifest_bytes_per_s": 1 / max(1e-30, manifest_per_byte)}

    # Projection: shards as large as one file allows (2 GiB, 10^7 points), a cluster of
    # nodes x cores running one shard per core.
    projections = []
    for total in (10**6, 10**8):
        per_file = min(MAX_POINTS_PER_FILE, int(0.9 * MAX_FILE / bytes_per_point))
        shards = max(nodes * cores, math.ceil(total / per_file))
        per_task = math.ceil(total / shards)
        waves = math.ceil(shards / (nodes * cores))
        capture_wall = waves * (per_task / capture_rate + per_shard)
        disk = total * bytes_per_point
        # Lookups: each task's arithmetic, or the file system's reading of every capture.
        lookup_wall = max(waves * (per_task / lookup_rate + per_lookup_shard),
                          disk / fs_bytes_per_s)
        core_seconds = total / capture_rate + shards * per_shard
        projections.append({"points": total, "shards": shards, "points_per_shard": per_task,
                            "capture_wall_s": capture_wall, "lookup_wall_s": lookup_wall,
                            "manifest_s": max(disk * manifest_per_byte, disk / fs_bytes_per_s),
                            "disk_bytes": disk,
                            "core_hours": core_seconds / 3600,
                            "nodes_for_one_hour": math.ceil(core_seconds / 3600 / cores)})
    result["projection"] = {"nodes": nodes, "cores_per_node": cores,
                            "fs_bytes_per_s": fs_bytes_per_s, "runs": projections}
    with open(os.path.join(out, "scaling.json"), "w") as f:
        json.dump(result, f, indent=1)

    print(f"Measured: {points} points at the defaults (128^2, 4 rays per texel, 5 %), one core.\n")
    print("| per core | value |\n|---|---|")
    print(f"| capture | {capture_rate:.1f} points/s ({t_capture:.1f} s for {points}) |")
    print(f"| lookups (Phong table) | {lookup_rate:.0f} points/s ({ns_per_lookup / 1000:.2f} µs "
          f"each; the whole command over {points} points {t_lookup:.2f} s) |")
    print(f"| bytes per point | {bytes_per_point / 1024:.1f} KiB |")
    print(f"| fixed cost of a capture task (one point) | {per_shard:.2f} s |")
    print(f"| fixed cost of a lookup task (table loaded) | {per_lookup_shard:.2f} s |")
    print(f"| manifest: shards read and checked | {1e-9 / max(1e-30, manifest_per_byte):.1f} "
          "GB/s (page cache) |\n")
    print("| shards | capture, summed | added by sharding | manifest | join | lookups via "
          "manifest | lookup shards, summed | joined = one process | lookups equal |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n, s in result["shards"].items():
        print(f"| {n} | {s['capture_s']:.1f} s | {s['capture_overhead_s']:+.1f} s | "
              f"{s['manifest_s']:.2f} s | {s['join_s']:.2f} s | {s['lookup_manifest_s']:.2f} s | "
              f"{s['lookup_shards_s']:.2f} s | {'yes' if s['identical'] else 'NO'} | "
              f"{'yes' if s['same_lookups'] else 'NO'} |")
    print(f"\nProjected on {nodes} nodes x {cores} cores, one shard per core, a file system "
          f"reading {fs_bytes_per_s / 1e9:g} GB/s in all:\n")
    print("| points | shards | points per shard | capture wall | lookup wall | manifest | "
          f"disk | core-hours of capture | {cores}-core nodes to capture in 1 h |")
    print("|---|---|---|---|---|---|---|---|---|")
    for p in projections:
        print(f"| {p['points']:.0e} | {p['shards']} | {p['points_per_shard']} | "
              f"{p['capture_wall_s'] / 60:.1f} min | {p['lookup_wall_s']:.0f} s | "
              f"{p['manifest_s']:.0f} s | {p['disk_bytes'] / 2**30:.1f} GiB | "
              f"{p['core_hours']:.0f} | {p['nodes_for_one_hour']} |")


if __name__ == "__main__":
    main()
