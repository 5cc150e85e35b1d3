"""Plots the rotation chart from basis_rotation_study's CSV: relative error of shading a tilted
surface against the tilt, per BRDF, for each method. Usage: plot_rotation.py IN.csv OUT.png"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(source, target):
    rows = list(csv.DictReader(open(source)))
    brdfs = sorted({r["brdf"] for r in rows}, key=lambda b: int(b[5:]))
    styles = {"none": ("tab:red", "o"), "reparametrised": ("tab:orange", "s"),
              "compensated": ("tab:green", "^"), "sh_rotated": ("tab:blue", "d")}
    figure, axes = plt.subplots(1, len(brdfs), figsize=(5 * len(brdfs), 4), sharey=True)
    for axis, brdf in zip(axes, brdfs):
        for method, (colour, marker) in styles.items():
            points = [(float(r["tilt_degrees"]), float(r["rel_error"])) for r in rows
                      if r["brdf"] == brdf and r["method"] == method]
            if not points:
                continue
            points.sort()
            axis.plot([p[0] for p in points], [100 * p[1] for p in points], marker=marker,
                      color=colour, label=method)
        axis.set_title(f"Lambert 0.5 + {brdf} (ks 0.4), map {rows[0]['map'].split('/')[-1]}")
        axis.set_xlabel("tilt of the surface against the capture (degrees)")
        axis.set_yscale("log")
        axis.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("mean relative error (%)")
    axes[0].legend()
    figure.tight_layout()
    figure.savefig(target, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
