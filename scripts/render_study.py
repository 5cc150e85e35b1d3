"""The radiance cache against Monte Carlo, as in the paper's Figures 1, 7 and 8: for each scene
and map, qtrender renders a converged Monte Carlo reference, the quadtree cache, the dense-grid
cache (the same records) and Monte Carlo in the cache's time, and reports relative MSE against
the reference, the time split and the record counts. Then the cache's failure cases (a grazing
view, a thin occluder, a lobe sharper than the records resolve) against Monte Carlo alike.

Usage: render_study.py [--quick | --main-job | --redraw] OUT_DIR
--quick: two scenes and one failure case, references of 1024 samples per pixel (else 2048);
--main-job: the bundled scene alone (data/scene.json), Figures 1 and 7 only; --redraw: the
charts and tables again from OUT_DIR/render_study.json.
Writes OUT_DIR/render_study.json, a Markdown table on stdout, and the charts
OUT_DIR/figure1.png (equal-time insets), OUT_DIR/figure7.png (time split), OUT_DIR/figure8.png
(render times). The scenes are made here: the bundled data/scene.obj, the bunny of Debian's
glmark2-data on a floor, and spheres with smooth vertex normals. Needs build/bin
(scripts/setup.sh) and the maps of Debian's blender-data."""
import argparse
import json
import math
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "build", "bin")
WORLD = "/usr/share/blender/datafiles/studiolights/world"
BUNNY = "/usr/share/glmark2/models/bunny.obj"
CAMERA = {"eye": [0, -9, 4], "look_at": [0, 0, 0.7], "up": [0, 0, 1], "fov": 40,
          "width": 320, "height": 240}


def run(args):
    return subprocess.run(args, check=True, capture_output=True, text=True).stdout


def render(scene, out, method, *extra):
    args = [f"{BIN}/qtrender", scene, "--method", method, "-o", out, "--json"] + list(extra)
    return json.loads(run(args))


def write_obj(path, vertices, faces, normals=None):
    with open(path, "w") as f:
        for v in vertices:
            f.write("v %.6f %.6f %.6f\n" % tuple(v))
        for n in normals or []:
            f.write("vn %.6f %.6f %.6f\n" % tuple(n))
        for a, b, c in faces:
            if normals:
                f.write(f"f {a + 1}//{a + 1} {b + 1}//{b + 1} {c + 1}//{c + 1}\n")
            else:
                f.write(f"f {a + 1} {b + 1} {c + 1}\n")


def floor(size=6.0):
    return [[-size, -size, 0], [size, -size, 0], [size, size, 0], [-size, size, 0]], \
        [(0, 1, 2), (0, 2, 3)]


def write_obj_on_floor(path, vertices, faces, normals):
    """Writes a mesh with vertex normals and the 12 x 12 floor (normal +z) under it."""
    fv, ff = floor()
    base = len(vertices)
    write_obj(path, vertices + fv, faces + [(a + base, b + base, c + base) for a, b, c in ff],
              normals + [[0, 0, 1]] * 4)


def make_bunny(path):
    """glmark2's bunny (y up, about 2 units tall) turned z up, on a 12 x 12 floor, with vertex
    normals averaged over the faces that share a position."""
    vertices, faces = [], []
    with open(BUNNY) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                x, y, z = map(float, p[1:4])
                vertices.append([1.2 * x, -1.2 * z, 1.2 * (y + 1)])
            elif p[0] == "f":
                faces.append(tuple(int(i.split("/")[0]) - 1 for i in p[1:4]))
    sums = {}
    key = lambda v: tuple(round(c, 5) for c in v)
    for a, b, c in faces:
        u = [vertices[b][k] - vertices[a][k] for k in range(3)]
        w = [vertices[c][k] - vertices[a][k] for k in range(3)]
        n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
        for i in (a, b, c):
            s = sums.setdefault(key(vertices[i]), [0, 0, 0])
            for k in range(3):
                s[k] += n[k]
    normals = []
    for v in vertices:
        s = sums[key(v)]
        length = math.sqrt(sum(c * c for c in s)) or 1
        normals.append([c / length for c in s])
    write_obj_on_floor(path, vertices, faces, normals)


def make_spheres(path):
    """Three UV spheres with smooth vertex normals on a 12 x 12 floor."""
    vertices, normals, faces = [], [], []
    for cx, cy, r in [(-2.2, 0.5, 1.0), (0.4, 1.5, 0.8), (2.3, -0.4, 0.6)]:
        base = len(vertices)
        rings, segments = 32, 64
        for i in range(rings + 1):
            t = math.pi * i / rings
            for j in range(segments):
                p = 2 * math.pi * j / segments
                n = [math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)]
                vertices.append([cx + r * n[0], cy + r * n[1], r + r * n[2]])
                normals.append(n)
        for i in range(rings):
            for j in range(segments):
                a = base + i * segments + j
                b = base + i * segments + (j + 1) % segments
                c, d = a + segments, b + segments
                if i > 0:
                    faces.append((a, c, b))
                if i < rings - 1:
                    faces.append((b, c, d))
    write_obj_on_floor(path, vertices, faces, normals)


def make_pole(path):
    """A thin pole (2 cm square, 1.5 m tall) over a floor: an occluder far thinner than the
    validity radius of the records around it."""
    fv, ff = floor()
    s, h = 0.01, 1.5
    box = [[-s, -s, 0], [s, -s, 0], [s, s, 0], [-s, s, 0],
           [-s, -s, h], [s, -s, h], [s, s, h], [-s, s, h]]
    quads = [(0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7), (4, 5, 6, 7)]
    faces = list(ff)
    for a, b, c, d in quads:
        faces += [(a + 4, b + 4, c + 4), (a + 4, c + 4, d + 4)]
    write_obj(path, fv + box, faces)


def write_scene(path, obj, material, env, camera=CAMERA, rotate=0):
    with open(path, "w") as f:
        json.dump({"camera": camera, "environment": {"map": env, "rotate": rotate},
                   "meshes": [{"obj": obj, "material": material}]}, f, indent=1)


def study_case(out, name, scene, reference_spp):
    """Reference, quadtree cache, dense cache and equal-time Monte Carlo for one scene."""
    ref = os.path.join(out, f"{name}_reference.exr")
    r = render(scene, ref, "mc", "--spp", str(reference_spp))
    cache = render(scene, os.path.join(out, f"{name}_cache.exr"), "cache", "--compare", ref)
    dense = render(scene, os.path.join(out, f"{name}_cache_dense.exr"), "cache-dense",
                   "--compare", ref)
    mc = render(scene, os.path.join(out, f"{name}_mc.exr"), "mc", "--time-budget",
                str(cache["total_s"]), "--compare", ref)
    return {"name": name, "reference": r, "cache": cache, "dense": dense, "mc": mc}


def figure1(out, case):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    name = case["name"]
    panels = [("radiance cache (quadtree)", f"{name}_cache.png", case["cache"]),
              ("Monte Carlo, same time", f"{name}_mc.png", case["mc"]),
              ("reference", f"{name}_reference.png", None)]
    images = [plt.imread(os.path.join(out, p)) for _, p, _ in panels]
    h, w = images[0].shape[:2]
    # Insets: the edge of the sphere against a box's shadow, and a shadow's edge on the floor.
    insets = [(int(0.40 * h), int(0.58 * w)), (int(0.45 * h), int(0.33 * w))]
    size = h // 6
    fig = plt.figure(figsize=(10, 5.4))
    grid = fig.add_gridspec(2, 6, height_ratios=[2.2, 1])
    for col, ((title, _, result), image) in enumerate(zip(panels, images)):
        ax = fig.add_subplot(grid[0, 2 * col:2 * col + 2])
        ax.imshow(image)
        label = title
        if result:
            label += "\n%.2f s, relMSE %.2e" % (result["total_s"], result["relmse"])
        ax.set_title(label, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
        for k, (y, x) in enumerate(insets):
            ax.add_patch(plt.Rectangle((x, y), size, size, fill=False, color="yellow", lw=1))
            inset = fig.add_subplot(grid[1, 2 * col + k])
            inset.imshow(image[y:y + size, x:x + size], interpolation="nearest")
            inset.set_xticks([])
            inset.set_yticks([])
    fig.tight_layout()
    fig.savefig(os.path.join(out, "figure1.png"), dpi=110)


def figure7(out, case):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    parts = [("primary_s", "camera rays"), ("record_tracing_s", "record tracing"),
             ("projection_s", "projection"), ("convolution_s", "convolution + lookup"),
             ("interpolation_s", "interpolation")]
    fig, ax = plt.subplots(figsize=(9, 2.6))
    for row, (label, r) in enumerate([("quadtree records", case["cache"]),
                                      ("dense records", case["dense"])]):
        left = 0
        for k, (key, text) in enumerate(parts):
            ax.barh(row, r[key], left=left, color=f"C{k}", label=text if row == 0 else None)
            left += r[key]
        ax.text(left, row, " %.2f s" % r["total_s"], va="center", fontsize=9)
    ax.set_yticks([0, 1], ["quadtree records", "dense records"])
    ax.set_xlabel("render time, seconds (2 cores)")
    ax.legend(fontsize=8, ncol=5, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
    ax.set_xlim(0, 1.12 * max(case["cache"]["total_s"], case["dense"]["total_s"]))
    fig.tight_layout()
    fig.savefig(os.path.join(out, "figure7.png"), dpi=110)


def figure8(out, cases):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(9, 3.2))
    names = [c["name"] for c in cases]
    x = range(len(cases))
    ax.bar([i - 0.2 for i in x], [c["cache"]["total_s"] for c in cases], 0.4,
           label="quadtree cache")
    ax.bar([i + 0.2 for i in x], [c["dense"]["total_s"] for c in cases], 0.4,
           label="dense-grid cache (same records)")
    for i, c in enumerate(cases):
        ax.text(i - 0.2, c["cache"]["total_s"], "%.1fx" % (c["mc"]["relmse"] / c["cache"]["relmse"]),
                ha="center", va="bottom", fontsize=8)
    ax.set_title("render times (2 cores); over the bars: Monte Carlo's relative MSE in the "
                 "cache's time, as a multiple of the cache's", fontsize=9)
    ax.set_ylim(0, 1.15 * max(max(c["cache"]["total_s"], c["dense"]["total_s"]) for c in cases))
    ax.set_xticks(list(x), names, fontsize=8, rotation=15)
    ax.set_ylabel("seconds")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "figure8.png"), dpi=110)


def main():
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Writes OUT_DIR/render_study.json, a Markdown table on stdout and the charts\n"
               "figure1.png (equal-time insets), figure7.png (time split) and figure8.png\n"
               "(render times) in OUT_DIR; with --main-job, OUT_DIR/render_main_job.json and\n"
               "Figures 1 and 7, and a summary line on stdout. Needs build/bin (scripts/setup.sh) and the maps of\n"
               "Debian's blender-data; the charts need matplotlib (Debian's python3-matplotlib:\n"
               "run it with /usr/bin/python3).")
    modes = parser.add_mutually_exclusive_group()
    modes.add_argument("--quick", action="store_true",
                       help="two scenes and one failure case, references of 1024 samples per "
                            "pixel (else 2048)")
    modes.add_argument("--main-job", action="store_true",
                       help="the bundled scene alone (data/scene.json), Figures 1 and 7 only")
    modes.add_argument("--redraw", action="store_true",
                       help="the charts and tables again from OUT_DIR/render_study.json")
    parser.add_argument("out", metavar="OUT_DIR", help="where the study's files go")
    options = parser.parse_args()
    quick, main_job, redraw = options.quick, options.main_job, options.redraw
    out = os.path.abspath(options.out)
    if redraw:
        with open(os.path.join(out, "render_study.json")) as f:
            results = json.load(f)
        report(out, results["cases"], results["failures"])
        return
    os.makedirs(out, exist_ok=True)
    data = os.path.join(ROOT, "data")
    if main_job:
        case = study_case(out, "main_job", os.path.join(data, "scene.json"), 2048)
        figure1(out, case)
        figure7(out, case)
        with open(os.path.join(out, "render_main_job.json"), "w") as f:
            json.dump(case, f, indent=1)
        k, m, d = case["cache"], case["mc"], case["dense"]
        print("cache %.2f s, %d records, relMSE %.2e; Monte Carlo in that time: %d spp, relMSE "
              "%.2e (%.1fx the cache's); dense-grid cache %.2f s; convolution %.1f %% of the "
              "cache's time" % (k["total_s"], k["records"], k["relmse"], m["spp"], m["relmse"],
                                m["relmse"] / k["relmse"], d["total_s"],
                                100 * k["convolution_s"] / k["total_s"]))
        return
    make_bunny(os.path.join(out, "bunny.obj"))
    make_spheres(os.path.join(out, "spheres.obj"))
    make_pole(os.path.join(out, "pole.obj"))
    # Glossy materials from Phong 40 to 100 and GGX 0.1 to 0.2: the bundled specs and two more.
    materials = {"Phong 100 (data/phong.json)": os.path.join(data, "phong.json"),
                 "copper GGX 0.2 (data/ggx.json)": os.path.join(data, "ggx.json"),
                 "Phong 40": os.path.join(out, "phong40.json"),
                 "silver GGX 0.1": os.path.join(out, "ggx01.json")}
    with open(materials["Phong 40"], "w") as f:
        json.dump({"model": "phong", "kd": [0.3, 0.25, 0.2], "ks": 0.6, "exponent": 40}, f)
    with open(materials["silver GGX 0.1"], "w") as f:
        json.dump({"model": "ggx", "kd": 0.05, "f0": [0.9, 0.9, 0.9], "alpha": 0.1}, f)
    # (name, OBJ, material, map, rotation): the main job's scene first.
    scenes = [("scene, sunrise", os.path.join(data, "scene.obj"), "Phong 100 (data/phong.json)",
               "sunrise", 0),
              ("scene, courtyard", os.path.join(data, "scene.obj"), "Phong 100 (data/phong.json)",
               "courtyard", 0),
              ("bunny, sunrise", os.path.join(out, "bunny.obj"), "copper GGX 0.2 (data/ggx.json)",
               "sunrise", 60),
              ("bunny, forest", os.path.join(out, "bunny.obj"), "copper GGX 0.2 (data/ggx.json)",
               "forest", 0),
              ("spheres, sunrise", os.path.join(out, "spheres.obj"), "Phong 40", "sunrise", 0),
              ("spheres, city", os.path.join(out, "spheres.obj"), "silver GGX 0.1", "city", 0)]
    if quick:
        scenes = scenes[:2]
    reference_spp = 1024 if quick else 2048
    cases = []
    for name, obj, material, env, rotate in scenes:
        slug = name.replace(", ", "_").replace(" ", "_")
        scene = os.path.join(out, slug + ".json")
        write_scene(scene, obj, materials[material], f"{WORLD}/{env}.exr", rotate=rotate)
        print(f"render_study: {name}", file=sys.stderr)
        case = study_case(out, slug, scene, reference_spp)
        case["name"] = name
        case["material"] = material
        case["slug"] = slug
        cases.append(case)

    # Failure cases, each against Monte Carlo in the same time.
    sharp = os.path.join(out, "phong1000.json")
    with open(sharp, "w") as f:
        json.dump({"model": "phong", "kd": 0.1, "ks": 0.8, "exponent": 1000}, f)
    grazing = dict(CAMERA, eye=[0, -9, 0.35], look_at=[0, 0, 0.3])
    pole_camera = dict(CAMERA, eye=[0, -4, 2.5], look_at=[0, 0, 0.3])
    failures = [("grazing view", os.path.join(data, "scene.obj"), os.path.join(data, "phong.json"), grazing),
                ("thin occluder", os.path.join(out, "pole.obj"), os.path.join(data, "phong.json"), pole_camera),
                ("Phong 1000", os.path.join(data, "scene.obj"), sharp, CAMERA)]
    if quick:
        failures = failures[:1]
    failure_results = []
    for name, obj, material, camera in failures:
        slug = "failure_" + name.replace(" ", "_")
        scene = os.path.join(out, slug + ".json")
        write_scene(scene, obj, material, f"{WORLD}/sunrise.exr", camera=camera)
        print(f"render_study: {name}", file=sys.stderr)
        case = study_case(out, slug, scene, reference_spp)
        case["name"] = name
        failure_results.append(case)

    with open(os.path.join(out, "render_study.json"), "w") as f:
        json.dump({"cases": cases, "failures": failure_results}, f, indent=1)
    report(out, cases, failure_results)


def report(out, cases, failure_results):
    """Figures 1, 7 and 8 and the Markdown tables from the study's results."""
    figure1(out, dict(cases[0], name=cases[0]["slug"]))
    figure7(out, cases[0])
    figure8(out, cases)

    print("| scene, map | material | records | cache s | relMSE cache | relMSE MC, same time | "
          "MC / cache | p99 error cache / MC | dense-cache s | convolution share, trees / dense |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for c in cases:
        k, d, m = c["cache"], c["dense"], c["mc"]
        print("| %s | %s | %d | %.2f | %.2e | %.2e (%d spp) | %.1fx | %.1f %% / %.1f %% | %.2f | "
              "%.1f %% / %.1f %% |" % (
                  c["name"], c["material"], k["records"], k["total_s"], k["relmse"], m["relmse"],
                  m["spp"], m["relmse"] / k["relmse"], 100 * k["p99_relerr"],
                  100 * m["p99_relerr"], d["total_s"], 100 * k["convolution_s"] / k["total_s"],
                  100 * d["convolution_s"] / d["total_s"]))
    print()
    print("| failure case | records | cache s | relMSE cache | relMSE MC, same time | MC / cache | "
          "p99 error cache / MC |")
    print("|---|---|---|---|---|---|---|")
    for c in failure_results:
        k, m = c["cache"], c["mc"]
        print("| %s | %d | %.2f | %.2e | %.2e | %.1fx | %.1f %% / %.1f %% |" % (
            c["name"], k["records"], k["total_s"], k["relmse"], m["relmse"],
            m["relmse"] / k["relmse"], 100 * k["p99_relerr"], 100 * m["p99_relerr"]))


if __name__ == "__main__":
    main()
