"""Draws qtbench's charts from the numbers it wrote. Usage: plot_bench.py DIR
DIR/results.csv -> DIR/chart.png (convolution time against error) and DIR/storage.png (bytes of
the light's representation against error), one panel per BRDF, one row of panels per light;
DIR/rotation.csv -> DIR/rotation.png (error against the tilt of the surface);
DIR/lookups.csv -> DIR/lookups.png (error of lookups against the outgoing direction's offset from
the nearest table entry, first-version tables and bilinear against default tables and Hermite);
DIR/summary.md also gets DIR/lookup_sources.csv as a table."""
import csv
import math
import os
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STYLE = {"quadtree": "tab:green", "quadtree_targeted": "tab:olive", "dense_naive": "tab:gray",
         "dense_simd": "black", "sh": "tab:blue", "haar": "tab:purple"}


def publish(path, write):
    """Writes a file whole or not at all: write(binary file) fills a temporary in the same
    folder, which then replaces path, so an error or an interrupt leaves any older file as it
    was."""
    folder, name = os.path.split(path)
    handle, temporary = tempfile.mkstemp(prefix="." + name + ".", dir=folder or ".")
    try:
        with os.fdopen(handle, "wb") as out:
            write(out)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(temporary, 0o666 & ~mask)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def save_figure(figure, path, dpi):
    publish(path, lambda out: figure.savefig(out, format="png", dpi=dpi))
    plt.close(figure)


def series(rows):
    """Curves per method: quadtree one per resolution (tolerance varies), accuracy-targeted
    quadtrees one per resolution at the default 5 % tolerance (the target varies), others by
    param."""
    curves = {}
    for r in rows:
        if r["method"] == "quadtree":
            n, tol = r["param"].split("@")
            curves.setdefault(f"quadtree {n}²", []).append((float(tol), r))
        elif r["method"] == "quadtree_targeted":
            tree, accuracy = r["param"].split("~")
            n, tol = tree.split("@")
            if float(tol) == 0.05:
                curves.setdefault(f"quadtree_targeted {n}²", []).append((float(accuracy), r))
        else:
            curves.setdefault(r["method"], []).append((float(r["param"]), r))
    return {k: [r for _, r in sorted(v, key=lambda p: p[0])] for k, v in curves.items()}


def panel_grid(rows, x_key, x_label, path):
    brdfs = list(dict.fromkeys(r["brdf"] for r in rows))
    lights = list(dict.fromkeys(r["light"] for r in rows))
    figure, axes = plt.subplots(len(lights), len(brdfs), figsize=(3.6 * len(brdfs), 3.3 * len(lights)),
                                squeeze=False, sharex=True, sharey=True)
    for i, light in enumerate(lights):
        for j, brdf in enumerate(brdfs):
            axis = axes[i][j]
            for name, curve in series([r for r in rows if r["brdf"] == brdf and r["light"] == light]).items():
                method = name.split()[0]
                xs = [float(r[x_key]) for r in curve]
                ys = [max(float(r["rel_error"]), 1e-6) * 100 for r in curve]
                alpha = 1.0 if not method.startswith("quadtree") else 0.5 + 0.5 * (name.endswith("128²") or name.endswith("256²"))
                axis.plot(xs, ys, marker="o", markersize=3, color=STYLE.get(method, "tab:red"),
                          alpha=alpha, label=name, linestyle="--" if method == "dense_naive" else "-")
            axis.set_xscale("log")
            axis.set_yscale("log")
            axis.grid(True, which="both", alpha=0.25)
            axis.set_title(f"{brdf}, {light}", fontsize=9)
            if i == len(lights) - 1:
                axis.set_xlabel(x_label, fontsize=8)
            if j == 0:
                axis.set_ylabel("relative error (%)", fontsize=8)
    handles, labels = axes[0][0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="lower center", ncol=min(8, len(labels)), fontsize=8)
    figure.tight_layout(rect=(0, 0.07, 1, 1))
    save_figure(figure, path, 90)


def rotation(path_csv, path_png):
    rows = list(csv.DictReader(open(path_csv)))
    brdfs = list(dict.fromkeys(r["brdf"] for r in rows))
    colours = {"none": "tab:red", "reparametrised": "tab:orange", "compensated": "tab:green"}
    figure, axes = plt.subplots(1, len(brdfs), figsize=(5.5 * len(brdfs), 4), squeeze=False)
    for axis, brdf in zip(axes[0], brdfs):
        methods = list(dict.fromkeys(r["method"] for r in rows if r["brdf"] == brdf))
        for method in methods:
            points = sorted((float(r["tilt_degrees"]), float(r["rel_error"])) for r in rows
                            if r["brdf"] == brdf and r["method"] == method)
            colour = colours.get(method, "tab:blue")
            style = ":" if method.startswith("sh") and "8" in method else "-"
            axis.plot([p[0] for p in points], [max(p[1], 1e-6) * 100 for p in points], marker="o",
                      markersize=3, color=colour, linestyle=style,
                      label=method.replace("_", " ").replace("sh", "SH order ") if method.startswith("sh") else method)
        axis.set_title(f"Lambert 0.5 + {brdf} (ks 0.4), map {rows[0]['map']}", fontsize=10)
        axis.set_xlabel("tilt of the surface against the capture (degrees)")
        axis.set_yscale("log")
        axis.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("mean relative error (%)")
    axes[0][0].legend(fontsize=8)
    figure.tight_layout()
    save_figure(figure, path_png, 100)


def lookups(path_csv, path_png):
    rows = list(csv.DictReader(open(path_csv)))
    brdfs = list(dict.fromkeys(r["brdf"] for r in rows))
    maps = list(dict.fromkeys(r["map"] for r in rows))
    colours = {"bilinear": "tab:red", "hermite": "tab:green"}
    figure, axes = plt.subplots(1, len(brdfs), figsize=(5 * len(brdfs), 4), squeeze=False)
    for axis, brdf in zip(axes[0], brdfs):
        for method in ("bilinear", "hermite"):
            mine = [r for r in rows if r["brdf"] == brdf and r["method"] == method]
            if not mine:
                continue
            offsets = sorted({float(r["offset"]) for r in mine})
            mean = [sum(float(r["mean_error"]) for r in mine if float(r["offset"]) == o) /
                    len(maps) for o in offsets]
            worst = [max(float(r["max_error"]) for r in mine if float(r["offset"]) == o)
                     for o in offsets]
            m = mine[0]["wo_resolution"]
            label = (f"first version: {m}² entries, bilinear" if method == "bilinear" else
                     f"default: {m}² entries with derivatives, Hermite")
            axis.plot(offsets, [max(v, 1e-6) * 100 for v in mean], marker="o", markersize=3,
                      color=colours[method], label=label + " (mean)")
            axis.plot(offsets, [max(v, 1e-6) * 100 for v in worst], linestyle=":",
                      color=colours[method], label="largest")
        axis.set_title(f"{brdf}, maps: {', '.join(maps)}", fontsize=9)
        axis.set_xlabel("offset from the nearest entry along s and t (grid steps)")
        axis.set_yscale("log")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=7)
    axes[0][0].set_ylabel("relative error against the map (%)")
    figure.tight_layout()
    save_figure(figure, path_png, 100)


def main(folder):
    results = os.path.join(folder, "results.csv")
    if os.path.exists(results):
        rows = list(csv.DictReader(open(results)))
        panel_grid(rows, "convolve_ns", "time per convolution (ns)", os.path.join(folder, "chart.png"))
        panel_grid(rows, "bytes", "bytes of the light's representation", os.path.join(folder, "storage.png"))
    rotation_csv = os.path.join(folder, "rotation.csv")
    if os.path.exists(rotation_csv):
        rotation(rotation_csv, os.path.join(folder, "rotation.png"))
    lookups_csv = os.path.join(folder, "lookups.csv")
    if os.path.exists(lookups_csv):
        lookups(lookups_csv, os.path.join(folder, "lookups.png"))


def summary(folder):
    """DIR/summary.md: per panel, each method's best error, and the fastest convolution (and
    its storage) reaching 1 %, 2 % and 5 % error."""
    results = os.path.join(folder, "results.csv")
    rows = list(csv.DictReader(open(results))) if os.path.exists(results) else []
    methods = list(dict.fromkeys(r["method"] for r in rows))
    lines = []
    if rows:  # a full run's panels; a --lookups-only run has none
        lines = ["| BRDF | light | method | best error | ns at ≤1 % | ns at ≤2 % | ns at ≤5 % | bytes at ≤2 % |",
                 "|---|---|---|---|---|---|---|---|"]
    for brdf in dict.fromkeys(r["brdf"] for r in rows):
        for light in dict.fromkeys(r["light"] for r in rows):
            for method in methods:
                mine = [r for r in rows if r["brdf"] == brdf and r["light"] == light and r["method"] == method]
                if not mine:
                    continue
                best = min(float(r["rel_error"]) for r in mine)

                def fastest(limit, key="convolve_ns"):
                    ok = [r for r in mine if float(r["rel_error"]) <= limit]
                    if not ok:
                        return "—"
                    r = min(ok, key=lambda r: float(r["convolve_ns"]))
                    return f"{float(r[key]):.0f} ({r['param']})" if key == "convolve_ns" else f"{float(r[key]):.0f}"
                lines.append(f"| {brdf} | {light} | {method} | {100 * best:.2f} % | {fastest(0.01)} | "
                             f"{fastest(0.02)} | {fastest(0.05)} | {fastest(0.02, 'bytes')} |")
    sources = os.path.join(folder, "lookup_sources.csv")
    if os.path.exists(sources):
        lines += [""] if lines else []
        lines += ["Lookups between table entries, largest relative error (%) by source:", "",
                  "| BRDF | entries | texels | table tree | capture tree | interpolation | total | "
                  "bilinear total |", "|---|---|---|---|---|---|---|---|"]
        for r in csv.DictReader(open(sources)):
            lines.append(f"| {r['brdf']} | {r['wo_resolution']}² | " + " | ".join(
                f"{100 * float(r[k]):.2f}" for k in ("texels", "table_tree", "capture_tree",
                                                     "interpolation", "total", "bilinear_total"))
                + " |")
    text = "\n".join(lines) + "\n"
    publish(os.path.join(folder, "summary.md"), lambda out: out.write(text.encode()))


if __name__ == "__main__":
    main(sys.argv[1])
    summary(sys.argv[1])
