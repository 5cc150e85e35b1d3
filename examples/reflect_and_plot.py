"""Tabulate a BRDF, trace a few captures, convolve them, and plot the reflected radiance and a
tree, from Python. Usage: reflect_and_plot.py [OUT_DIR] (default: current folder).
Uses the repository's data/phong.json and data/scene.obj, and the Poly Haven sunrise map of
Debian's blender-data when it is installed (a constant sky otherwise)."""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import basis  # noqa: E402

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
out = sys.argv[1] if len(sys.argv) > 1 else "."
os.makedirs(out, exist_ok=True)

brdf = basis.Brdf.from_file(os.path.join(root, "data", "phong.json"))
table = basis.tabulate(brdf, wi_res=64, tilt=False)  # outgoing grid from the lobe's width
print(f"table: {table.wo_resolution}^2 entries of {brdf.model}, lobe {np.degrees(brdf.lobe_width):.1f} deg")

# Points on the floor of the bundled scene, in a row through the boxes' shadows.
points = np.array([[x, 0.3, 0.001] for x in np.linspace(-1.8, 1.8, 12)])
normals = np.tile([0.0, 0.0, 1.0], (len(points), 1))
sunrise = "/usr/share/blender/datafiles/studiolights/world/sunrise.exr"
light = {"env": sunrise} if os.path.exists(sunrise) else {"constant": (0.4, 0.6, 1.0)}
captures = basis.capture(points, normals, scene=os.path.join(root, "data", "scene.obj"),
                         res=64, **light)
values, bounds = basis.shade(table, captures, wo=(0.0, 0.0, 1.0))
for p, v, b in zip(points, values, bounds):
    print(f"x {p[0]:+.2f}: radiance {v[0]:.4f} {v[1]:.4f} {v[2]:.4f}  +- {b.max():.2g}")
basis.write(os.path.join(out, "example_captures.qt"), captures)

figure, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
for c, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
    left.errorbar(points[:, 0], values[:, c], yerr=bounds[:, c], color=colour, marker="o")
left.set_xlabel("x on the floor")
left.set_ylabel("reflected radiance towards the normal")
left.set_title("Lambert 0.5 + Phong 100 on data/scene.obj")
tree = captures.tree(len(points) // 2)
image = tree.reconstruct()[0].transpose(1, 2, 0)
right.imshow(np.clip(image / (4 * image.mean()), 0, 1) ** (1 / 2.2), origin="upper")
right.set_title(f"a capture's tree: {tree.node_count} nodes over {tree.resolution}^2 texels")
figure.tight_layout()
figure.savefig(os.path.join(out, "example.png"), dpi=90)
print("wrote", os.path.join(out, "example.png"))
