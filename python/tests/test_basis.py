"""The Python module against the C++ tools on the same files, NumPy round trips, and errors.
Runs with PYTHONPATH at the built module, BASIS_BIN at the tools and BASIS_SOURCE_DIR at the
source tree (ctest sets them)."""
import gc
import json
import os
import signal
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest

import basis

BIN = os.environ.get("BASIS_BIN", "build/bin")
SOURCE = os.environ.get("BASIS_SOURCE_DIR", ".")


def tool(name, *args, cwd=None):
    return subprocess.run([os.path.join(BIN, name), *map(str, args)], cwd=cwd, check=True,
                          capture_output=True, text=True).stdout


def qtconvolve_json(table, captures, *args):
    out = json.loads(tool("qtconvolve", table, captures, "--json", "-q", *args))
    values = np.array([r["value"] for r in out["results"]])
    bounds = np.array([r["bound"] for r in out["results"]])
    return values, bounds


SPEC = '{"model": "phong", "kd": [0.5, 0.4, 0.3], "ks": 0.4, "exponent": 60}'
POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 2, 0.5], [0.3, -1, 0.2], [2, 2, 2]], float)
NORMALS = np.array([[0, 0, 1], [0.3, 0, 1], [0, -0.5, 1], [1, 1, 1], [0.1, 0.9, 0.2]], float)


@pytest.fixture(scope="module")
def made_by_tools(tmp_path_factory):
    """A small table and a capture set made by brdf2qt and capture2qt."""
    d = tmp_path_factory.mktemp("tools")
    (d / "phong.json").write_text(SPEC)
    tool("brdf2qt", "phong.json", "--wo-res", 9, "--wi-res", 16, "-q", cwd=d)
    with open(d / "points.csv", "w") as f:
        for p, n in zip(POINTS, NORMALS):
            f.write(",".join(map(str, [*p, *n])) + "\n")
    sky = "/usr/share/blender/datafiles/studiolights/world/sunrise.exr"  # Debian's blender-data
    if os.path.exists(sky):
        light = ["--env", sky]
    else:
        warnings.warn(f"{sky} absent: the captures see a constant sky, one node each, so the "
                      "comparisons of captures check little")
        light = ["--env-constant", "0.3,0.6,1.2"]
    tool("capture2qt", *light, "--points", "points.csv", "--res", 16, "-o", "captures.qt", "-q",
         cwd=d)
    return d, light


def test_projection_round_trips_within_the_tolerance():
    u, v = np.meshgrid((np.arange(32) + 0.5) / 32, (np.arange(32) + 0.5) / 32)
    grid = np.stack([1.5 + np.sin(4 * u + c) * np.cos(3 * v) for c in range(3)]).astype(np.float32)
    exact = basis.project(grid, tolerance=0)
    back = exact.reconstruct()
    assert back.shape == (1, 3, 32, 32)
    # Half floats: 2^-11 relative.
    np.testing.assert_allclose(back[0], grid, rtol=2.0 ** -11, atol=1e-7)
    cut = basis.project(grid, tolerance=0.05)
    assert cut.node_count < exact.node_count
    means = grid.reshape(3, -1).mean(axis=1)
    deviation = np.abs(cut.reconstruct()[0] - grid).reshape(3, -1).max(axis=1)
    assert np.all(deviation <= 0.05 * means * (1 + 1e-3) + 2.0 ** -11 * grid.max())
    for c in range(3):
        assert cut.integrate(0, c) == pytest.approx(grid[c].mean(), rel=1e-3)


def test_tree_words_are_the_nodes_in_place():
    tree = basis.project(np.ones((16, 16), np.float32) * np.arange(16, dtype=np.float32), 0.01)
    words = tree.words
    assert words.dtype == np.uint32
    assert tree.texel_start == tree.node_count  # no texel nodes of values alone
    assert words.shape == (tree.node_count, tree.words_per_node)
    assert tree.texel_words.shape[0] == 0
    assert not tree.shared_values  # a projected tree's values are halves
    assert not words.flags.writeable
    scale = tree.value_scale
    del tree
    gc.collect()
    # The view outlives the Python tree and still reads its nodes: the root's link word (first
    # child at node 1, every quadrant refined) and its four values, halves times the value scale,
    # which are the quadrants' averages of the grid (columns 0..7 average 3.5, 8..15 11.5).
    assert words[0, 0] == (1 << 4 | 15)
    root = np.sort(words[0, 1:3].copy().view(np.float16).astype(np.float64) * scale)
    assert root == pytest.approx([3.5, 3.5, 11.5, 11.5])


def test_convolution_matches_the_texels_within_its_bound():
    rng = np.random.default_rng(5)
    a = rng.uniform(0, 1, size=(3, 64, 64)).astype(np.float32)
    b = rng.uniform(0, 3, size=(1, 64, 64)).astype(np.float32)
    ta, tb = basis.project(a, 0.1), basis.project(b, 0.1)
    value, bound = basis.convolve(ta, tb)
    texels = (a * b).reshape(3, -1).mean(axis=1)
    assert np.all(np.abs(value - texels) <= bound * (1 + 1e-4) + 1e-6)
    dense = (ta.reconstruct()[0] * tb.reconstruct()[0]).reshape(3, -1).mean(axis=1)
    np.testing.assert_allclose(value, dense, rtol=1e-3)
    # Without the bound: the same descent's value, and nothing certified.
    alone, none = basis.convolve(ta, tb, bound=False)
    np.testing.assert_array_equal(alone, value)
    assert np.all(np.isinf(none))
    with pytest.raises(ValueError, match="accuracy target"):
        basis.convolve(ta, tb, accuracy=0.1, bound=False)


def test_files_made_by_the_tools_shade_as_qtconvolve_does(made_by_tools):
    d, _ = made_by_tools
    table = basis.load(str(d / "phong.qt"))
    captures = basis.load(str(d / "captures.qt"))
    assert table.kind == "brdf-table" and captures.kind == "capture-set"
    # A table is read where it lies; a capture set's refined nodes are restored on loading.
    assert table.zero_copy and not captures.zero_copy
    assert captures.format_version >= 8 and captures.checksum_verified
    # One byte changed in the middle of the trees: refused by the checksum, naming the file.
    damaged = bytearray((d / "captures.qt").read_bytes())
    damaged[len(damaged) // 2] ^= 0x10
    (d / "damaged.qt").write_bytes(bytes(damaged))
    with pytest.raises(basis.Error, match="damaged.qt: checksum mismatch"):
        basis.load(str(d / "damaged.qt"))
    assert len(captures.captures()) == len(POINTS)
    np.testing.assert_allclose(captures.captures().positions, POINTS)
    for wo, args in (((0, 0, 1), []), ((0.3, 0.2, 0.93), ["--wo", "0.3,0.2,0.93"]),
                     ((0.5, 0, 0.87), ["--wo", "0.5,0,0.87", "--interpolation", "bilinear"])):
        mode = "bilinear" if "bilinear" in args else "hermite"
        values, bounds = basis.shade(table.table(), captures.captures(), wo, interpolation=mode)
        expected, expected_bounds = qtconvolve_json(d / "phong.qt", d / "captures.qt", *args)
        np.testing.assert_allclose(values, expected, rtol=1e-5)
        np.testing.assert_allclose(bounds, expected_bounds, rtol=1e-3, atol=1e-7)
        alone, none = basis.shade(table.table(), captures.captures(), wo, interpolation=mode,
                                  bound=False)
        np.testing.assert_array_equal(alone, values)
        assert np.all(np.isinf(none))


def test_files_written_here_are_read_by_the_tools(made_by_tools, tmp_path):
    d, light = made_by_tools
    brdf = basis.Brdf.from_json(SPEC)
    table = basis.tabulate(brdf, wo_res=9, wi_res=16)
    kw = {"env": light[1]} if light[0] == "--env" else {"constant": (0.3, 0.6, 1.2)}
    captures = basis.capture(POINTS, NORMALS, res=16, **kw)
    basis.write(str(tmp_path / "t.qt"), table)
    basis.write(str(tmp_path / "c.qt"), captures)
    info = json.loads(tool("qtinfo", tmp_path / "t.qt", "--json"))
    assert info["kind"] == "brdf-table"
    values, _ = basis.shade(table, captures)
    expected, _ = qtconvolve_json(tmp_path / "t.qt", tmp_path / "c.qt")
    np.testing.assert_allclose(values, expected, rtol=1e-5)
    # The same tables and captures as the tools make from the same inputs, node for node.
    by_tool = basis.load(str(d / "phong.qt")).table()
    for i, j in ((0, 0), (4, 4), (8, 3)):
        assert np.array_equal(table.entry(i, j).words, by_tool.entry(i, j).words)
    tool_captures = basis.load(str(d / "captures.qt")).captures()
    for k in range(len(POINTS)):
        assert np.array_equal(captures.tree(k).words, tool_captures.tree(k).words)
        assert np.array_equal(captures.tree(k).texel_words, tool_captures.tree(k).texel_words)
        # Captures' texels are exact: their texel nodes hold a shared-exponent word per texel.
        tree = captures.tree(k)
        assert tree.texel_words.shape == (tree.node_count - tree.texel_start, 4)
        assert tree.shared_values
    # The tools' full-resolution reference reads the recipe written here: the values shaded
    # here lie within their bounds of the product of the full-resolution texels.
    out = json.loads(tool("qtconvolve", tmp_path / "t.qt", tmp_path / "c.qt", "--reference",
                          "--json", "-q"))
    reference = np.array([r["reference"] for r in out["results"]])
    bounds = np.array([r["bound"] for r in out["results"]])
    assert reference.shape == values.shape
    assert np.all(np.abs(values - reference) <= bounds * (1 + 1e-4) + 1e-6 * np.abs(reference))


def test_brdf_evaluation_matches_closed_forms():
    lambert = basis.Brdf.from_json('{"model": "lambert", "albedo": [0.2, 0.5, 0.8]}')
    wi = np.array([[0, 0, 1], [0.6, 0, 0.8], [0, 0, -1]], float)
    f = lambert.evaluate(wi, np.array([[0, 0, 1]], float))
    np.testing.assert_allclose(f[:2], np.tile([0.2 / np.pi, 0.5 / np.pi, 0.8 / np.pi], (2, 1)))
    np.testing.assert_allclose(f[2], 0)
    phong = basis.Brdf.from_json('{"model": "phong", "kd": 0, "ks": 1, "exponent": 20}')
    wo = np.array([[0.6, 0, 0.8]])
    mirror = np.array([[-0.6, 0, 0.8]])
    assert phong.evaluate(mirror, wo)[0, 0] == pytest.approx(22 / (2 * np.pi))
    assert phong.lobe_width == pytest.approx(np.arccos(2 ** (-1 / 20)) / 1.1774, rel=0.005)


def test_a_constant_light_reflects_the_directional_albedo():
    brdf = basis.Brdf.from_json('{"model": "phong", "kd": 0.3, "ks": 0.5, "exponent": 30}')
    table = basis.tabulate(brdf, wo_res=9, wi_res=32, tilt=False)
    light = basis.project(np.ones((8, 8), np.float32))
    wo = np.array([0.4, 0.1, np.sqrt(1 - 0.17)])
    value, _ = basis.reflect(table, light, tuple(wo))
    # Directional albedo by a midpoint rule over the hemisphere (theta, phi).
    n = 400
    theta = (np.arange(n) + 0.5) / n * np.pi / 2
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    wi = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    f = brdf.evaluate(wi, wo[None, :])[:, 0]
    albedo = np.sum(f * wi[:, 2] * np.sin(t).ravel()) * (np.pi / 2 / n) * (2 * np.pi / (2 * n))
    assert value[0] == pytest.approx(albedo, rel=0.01)
    # wo is a direction whatever its length: its squared length may leave the double range.
    for scale in (1e300, 1e-300):
        scaled, _ = basis.reflect(table, light, tuple(wo * scale))
        assert scaled[0] == pytest.approx(albedo, rel=0.01)


def test_errors_are_exceptions_with_one_line(tmp_path):
    with pytest.raises(basis.Error, match="missing.qt"):
        basis.load(str(tmp_path / "missing.qt"))
    (tmp_path / "junk.qt").write_bytes(b"not a qt file at all")
    with pytest.raises(basis.Error, match="junk.qt"):
        basis.load(str(tmp_path / "junk.qt"))
    with pytest.raises(basis.Error, match="exponent"):
        basis.Brdf.from_json('{"model": "phong", "kd": 0, "ks": 1, "exponent": -3}')
    with pytest.raises(ValueError, match="power of two"):
        basis.project(np.ones((3, 24, 24), np.float32))
    with pytest.raises(ValueError):
        basis.project(np.ones((2, 16, 16), np.float32))
    with pytest.raises(ValueError, match="grid has NaN|NaN"):
        basis.project(np.full((8, 8), np.nan, np.float32))
    table = basis.tabulate(basis.Brdf.from_json('{"model": "lambert", "albedo": 0.5}'), wo_res=3,
                           wi_res=4, tilt=False)
    with pytest.raises(IndexError, match="outside the 3 x 3 table"):
        table.entry(3, 0)
    with pytest.raises(ValueError, match=r"wi\[1\] must be"):
        basis.Brdf.from_json('{"model": "lambert", "albedo": 0.5}').evaluate(
            np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]]))
    with pytest.raises(ValueError, match="wo must be"):
        basis.reflect(table, basis.project(np.ones((8, 8), np.float32)), (0, 0, 0))
    tree = basis.project(np.ones((8, 8), np.float32))
    for group, channel in ((5, 0), (0, 2), (-1, 0), (100000000, 0)):
        with pytest.raises(ValueError, match="no group"):
            tree.integrate(group, channel)


def test_a_specs_table_block_is_taken_as_brdf2qt_takes_it(tmp_path):
    # A tolerance far from the default 5 %, so that entries cut at the default would differ.
    spec = {"model": "phong", "kd": 0.3, "ks": 0.5, "exponent": 20,
            "table": {"wo_res": 5, "wi_res": 8, "tolerance": 0.5}}
    path = tmp_path / "blocked.json"
    path.write_text(json.dumps(spec))
    tool("brdf2qt", path.name, "-q", cwd=tmp_path)
    by_tool = basis.load(str(tmp_path / "blocked.qt")).table()
    brdf = basis.Brdf.from_file(str(path))
    table = basis.tabulate(brdf)
    assert table.wo_resolution == by_tool.wo_resolution == 5
    for i, j in ((0, 0), (2, 2), (4, 1)):
        assert np.array_equal(table.entry(i, j).words, by_tool.entry(i, j).words)
    # Arguments override the block.
    assert basis.tabulate(brdf, wo_res=3).wo_resolution == 3
    assert basis.tabulate(brdf, wi_res=16).entry(0, 0).resolution == 16
    finer = basis.tabulate(brdf, tolerance=0.05)
    assert finer.entry(2, 2).node_count > table.entry(2, 2).node_count
    # A written table names its spec and options as brdf2qt's does.
    basis.write(str(tmp_path / "written.qt"), table)
    written = json.loads(tool("qtinfo", tmp_path / "written.qt", "--json"))
    made = json.loads(tool("qtinfo", tmp_path / "blocked.qt", "--json"))
    assert written["provenance"]["sources"] == [str(path)]
    assert json.loads(written["provenance"]["parameters"]) == json.loads(
        made["provenance"]["parameters"])
    # Loaded and written back, a table keeps them.
    basis.write(str(tmp_path / "again.qt"), basis.load(str(tmp_path / "blocked.qt")).table())
    again = json.loads(tool("qtinfo", tmp_path / "again.qt", "--json"))
    assert again["provenance"]["sources"] == made["provenance"]["sources"]
    assert again["provenance"]["parameters"] == made["provenance"]["parameters"]


def test_arguments_are_checked_where_they_are_given(made_by_tools, tmp_path):
    d, _ = made_by_tools
    table = basis.load(d / "phong.qt").table()  # os.PathLike paths are taken
    captures = basis.load(str(d / "captures.qt")).captures()
    # Python indices: negative from the end, IndexError outside; the set is a sequence.
    assert np.array_equal(captures[-1].words, captures.tree(len(captures) - 1).words)
    assert len(list(captures)) == len(captures)
    with pytest.raises(IndexError):
        captures.tree(len(captures))
    with pytest.raises(IndexError):
        captures.lights(-len(captures) - 1)
    # A path cut short by a NUL character would name another file.
    for call in (lambda: basis.load(str(d / "phong.qt") + "\0x"),
                 lambda: basis.write(str(tmp_path / "t.qt") + "\0.bak", table),
                 lambda: basis.Brdf.from_file(os.path.join(SOURCE, "data", "phong.json") + "\0")):
        with pytest.raises(ValueError, match="NUL"):
            call()
    assert not (tmp_path / "t.qt").exists()
    # A FIFO is refused at once rather than waited on.
    os.mkfifo(tmp_path / "pipe.qt")
    with pytest.raises(basis.Error, match="not a regular file"):
        basis.load(tmp_path / "pipe.qt")
    # Accuracy targets are fractions from 0 to 1.
    for accuracy in (float("nan"), -0.1, 1.5, float("inf")):
        with pytest.raises(ValueError, match="accuracy"):
            basis.shade(table, captures, accuracy=accuracy)
    # Tilts beyond 90 degrees, tilts that are not finite, and wo below the horizon are refused.
    tree = captures.tree(0)
    with pytest.raises(ValueError, match="90 degrees"):
        basis.reflect_tilted(table, tree, (0, 0, 1), (2 * np.pi, 0))
    with pytest.raises(ValueError, match="tilt is not finite"):
        basis.reflect_tilted(table, tree, (0, 0, 1), (np.nan, 0))
    with pytest.raises(ValueError, match="horizon"):
        basis.reflect_tilted(table, tree, (0.6, 0, -0.8), (0.05, 0))
    # Options checked when given, not when written.
    brdf = basis.Brdf.from_json(SPEC)
    with pytest.raises(ValueError, match="tolerance floor"):
        basis.tabulate(brdf, wo_res=3, wi_res=8, tolerance_floor=float("nan"))
    with pytest.raises(ValueError, match="threads"):
        basis.tabulate(brdf, wo_res=3, wi_res=8, threads=-3)
    with pytest.raises(ValueError, match="position"):
        basis.capture(np.array([[np.nan, 0, 0]]), np.array([[0, 0, 1.0]]), constant=(1, 1, 1), res=8)
    with pytest.raises(ValueError, match="spp"):
        basis.capture(POINTS, NORMALS, constant=(1, 1, 1), res=8, spp=0)
    # A table's or a capture set's file holds no single tree.
    with pytest.raises(basis.Error, match="not a single tree"):
        basis.load(d / "phong.qt").tree()


def test_tilted_lookups_take_reflects_options(made_by_tools):
    """reflect_tilted takes accuracy, interpolation and bound as reflect does: untilted it is
    reflect to the bit with each, without the bound the same values, and a targeted lookup's
    certified interval meets the full one's."""
    d, _ = made_by_tools
    table = basis.load(d / "phong.qt").table()
    tree = basis.load(d / "captures.qt").captures().tree(2)
    wo = (0.3, 0.2, 0.93)
    for options in ({}, {"accuracy": 0.1}, {"interpolation": "bilinear"}, {"bound": False}):
        tilted = basis.reflect_tilted(table, tree, wo, (0, 0), **options)
        plain = basis.reflect(table, tree, wo, **options)
        np.testing.assert_array_equal(tilted[0], plain[0], err_msg=str(options))
        np.testing.assert_array_equal(tilted[1], plain[1], err_msg=str(options))
    tilt = (0.08, -0.05)
    full_value, full_bound = basis.reflect_tilted(table, tree, wo, tilt)
    alone, inf = basis.reflect_tilted(table, tree, wo, tilt, bound=False)
    np.testing.assert_array_equal(alone, full_value)
    assert np.all(np.isinf(inf))
    targeted, targeted_bound = basis.reflect_tilted(table, tree, wo, tilt, accuracy=0.1)
    assert np.all(np.abs(targeted - full_value) <= targeted_bound + full_bound)
    bilinear, _ = basis.reflect_tilted(table, tree, wo, tilt, interpolation="bilinear")
    assert not np.array_equal(bilinear, full_value)
    with pytest.raises(ValueError, match="accuracy"):
        basis.reflect_tilted(table, tree, wo, tilt, accuracy=2)


def test_long_calls_let_other_threads_run(made_by_tools):
    """Brdf.evaluate, Tree.reconstruct, reflect and reflect_tilted work without the GIL. While a
    long evaluate runs in one thread, another keeps running: its longest pause stays well under
    the call's time, which it would match if the call held the GIL. The other three take
    microseconds on these trees, too short to tell that way: called from several threads at
    once, they give what they give one call at a time (the released calls share nothing)."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    brdf = basis.Brdf.from_json('{"model": "ggx", "f0": [0.95, 0.64, 0.54], "alpha": 0.2}')
    rng = np.random.default_rng(3)
    wi = rng.normal(size=(200_000, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.01
    wo = np.array([[0.3, 0.2, 0.9]])
    # Enough directions that one call takes at least 0.2 s here (up to 3.2 million).
    while True:
        start = time.perf_counter()
        alone = brdf.evaluate(wi, wo)
        took = time.perf_counter() - start
        if took >= 0.2 or len(wi) >= 3_200_000:
            break
        wi = np.concatenate([wi, wi])
    assert took >= 0.05, "evaluate too fast on this machine to tell"
    result = {}
    worker = threading.Thread(target=lambda: result.setdefault("f", brdf.evaluate(wi, wo)))
    longest_pause, last = 0.0, time.perf_counter()
    worker.start()
    while worker.is_alive():
        now = time.perf_counter()
        longest_pause, last = max(longest_pause, now - last), now
    worker.join()
    np.testing.assert_array_equal(result["f"], alone)
    assert longest_pause < took / 2, f"paused {longest_pause:.3f} s in a call of {took:.3f} s"

    d, _ = made_by_tools
    table = basis.load(d / "phong.qt").table()
    captures = basis.load(d / "captures.qt").captures()
    trees = [captures.tree(k) for k in range(len(POINTS))]
    calls = [lambda t=t: t.reconstruct() for t in trees]
    calls += [lambda t=t: basis.reflect(table, t, (0.3, 0.2, 0.93)) for t in trees]
    calls += [lambda t=t: basis.reflect_tilted(table, t, (0.3, 0.2, 0.93), (0.05, -0.02))
              for t in trees]
    calls *= 20
    serial = [call() for call in calls]
    with ThreadPoolExecutor(max_workers=4) as pool:
        threaded = list(pool.map(lambda call: call(), calls))
    for one, other in zip(serial, threaded):
        for x, y in zip(one if isinstance(one, tuple) else (one,),
                        other if isinstance(other, tuple) else (other,)):
            np.testing.assert_array_equal(x, y)


def test_more_threads_than_cores_run_quietly(capfd):
    """threads beyond the cores run on every core, without oneTBB's own warning on stderr."""
    brdf = basis.Brdf.from_json(SPEC)
    one = basis.tabulate(brdf, wo_res=3, wi_res=8, threads=1)
    many = basis.tabulate(brdf, wo_res=3, wi_res=8, threads=1024)
    assert "TBB" not in capfd.readouterr().err
    assert np.array_equal(one.entry(1, 1).words, many.entry(1, 1).words)


def test_objects_come_from_the_modules_functions_only():
    """A bare Class.__new__(Class), as generic copying code may call, gave an object whose C++
    value was never made: reading it printed garbage or crashed the interpreter."""
    for cls in (basis.Tree, basis.Table, basis.Captures, basis.File, basis.Brdf):
        with pytest.raises(TypeError, match="made by the module's functions"):
            cls.__new__(cls)
        with pytest.raises(TypeError, match="made by the module's functions"):
            cls()
    tree = basis.project(np.ones((8, 8), np.float32))  # the functions still make them
    assert tree.node_count == 1 and isinstance(tree, basis.Tree)


def test_empty_paths_name_no_file(tmp_path):
    """An empty path (an unset variable, most often) is refused: capture(scene="") traced with no
    scene at all, silently."""
    point, normal = np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]])
    for call in (lambda: basis.capture(point, normal, constant=(1, 1, 1), scene="", res=8),
                 lambda: basis.capture(point, normal, env="", res=8),
                 lambda: basis.load(""),
                 lambda: basis.Brdf.from_file(b""),
                 lambda: basis.write("", basis.project(np.ones((8, 8), np.float32)))):
        with pytest.raises(ValueError, match="is empty: it names no file"):
            call()


def test_messages_keep_their_file_names_whatever_the_bytes(tmp_path):
    (tmp_path / "bin.json").write_bytes(b'{"model": "phong", "\xff": 1}')
    with pytest.raises(basis.Error, match="bin.json"):
        basis.Brdf.from_file(tmp_path / "bin.json")


def test_tracing_leaves_the_callers_subnormals_alone():
    tiny = np.float64(5e-324)
    assert tiny > 0
    basis.capture(np.array([[0, 0.3, 0.001]]), np.array([[0, 0, 1.0]]), constant=(1, 1, 1), res=8,
                  scene=os.path.join(SOURCE, "data", "scene.obj"))
    assert tiny * 1.0 > 0 and np.array([1e-310]).sum() > 0


def test_a_capture_set_written_back_keeps_its_provenance(made_by_tools, tmp_path):
    d, light = made_by_tools
    loaded = basis.load(d / "captures.qt")
    basis.write(tmp_path / "again.qt", loaded.captures())
    again = basis.load(tmp_path / "again.qt").provenance
    assert again["parameters"] == loaded.provenance["parameters"]
    assert again["sources"] == loaded.provenance["sources"]
    # Sets made here record the files they read.
    made = basis.capture(POINTS[:1], NORMALS[:1], res=8, scene=os.path.join(SOURCE, "data", "scene.obj"),
                         **({"env": light[1]} if light[0] == "--env" else {"constant": (1, 1, 1)}))
    basis.write(tmp_path / "made.qt", made)
    sources = basis.load(tmp_path / "made.qt").provenance["sources"]
    assert os.path.join(SOURCE, "data", "scene.obj") in sources


def test_a_measured_table_whose_data_is_gone_warns_and_shades_from_its_texels(made_by_tools,
                                                                                tmp_path):
    """A table of a MERL file (written here: constant samples) shades its captures' lights with
    the BRDF rebuilt from its spec, reading the data file once per table and only when there are
    lights; once the file is gone, with a RuntimeWarning as qtconvolve's, from its texels."""
    d, light = made_by_tools
    header = np.array([90, 90, 180], np.int32).tobytes()
    (tmp_path / "m.binary").write_bytes(header + np.full(3 * 90 * 90 * 180, 40.0).tobytes())
    (tmp_path / "m.json").write_text('{"model": "merl", "file": "m.binary"}')
    tool("brdf2qt", "m.json", "--wo-res", 5, "--wi-res", 8, "-q", cwd=tmp_path)
    table = basis.load(str(tmp_path / "m.qt")).table()
    captures = basis.load(str(d / "captures.qt")).captures()
    if not any(len(captures.lights(k)) for k in range(len(captures))):
        pytest.skip("the captures keep no lights apart (no sun map): nothing to shade them with")
    cwd = os.getcwd()
    os.chdir(tmp_path)  # the spec's data file is found as brdf2qt was given it
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with_data, _ = basis.shade(table, captures)
        os.remove("m.binary")
        # Read once per table: the same table shades as before, the file gone or not.
        again, _ = basis.shade(table, captures)
        np.testing.assert_array_equal(again, with_data)
        reloaded = basis.load(str(tmp_path / "m.qt")).table()
        with pytest.warns(RuntimeWarning, match="m.binary.*directional lights use the table's"):
            from_texels, _ = basis.shade(reloaded, captures)
    finally:
        os.chdir(cwd)
    expected, _ = qtconvolve_json(tmp_path / "m.qt", d / "captures.qt", "--lights", "table")
    np.testing.assert_allclose(from_texels, expected, rtol=1e-5)


def test_tabulate_warns_of_resolutions_too_coarse_for_the_lobe():
    """As brdf2qt warns: a Phong 10^4 lobe over 2 x 2 texels, whose texel averages lose it (its
    albedo at the normal is 1 by the normalisation), and 3 x 3 outgoing directions."""
    sharp = basis.Brdf.from_json('{"model": "phong", "ks": 1, "exponent": 10000}')
    with pytest.warns(RuntimeWarning) as record:
        table = basis.tabulate(sharp, wo_res=3, wi_res=2, tilt=False)
    messages = [str(w.message) for w in record]
    assert any("texel averages may miss it" in m for m in messages), messages
    assert any("3 x 3 outgoing directions are coarser" in m for m in messages), messages
    albedo = np.pi * table.entry(1, 1).reconstruct()[0].mean(axis=(1, 2))
    assert albedo.max() < 0.5
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        basis.tabulate(basis.Brdf.from_json('{"model": "phong", "ks": 1, "exponent": 100}'),
                       wi_res=16, tilt=False)


def test_provenance_of_a_source_whose_name_is_not_utf8(tmp_path):
    """A spec named with bytes that are not UTF-8: the table's provenance names it as
    os.fsdecode does, and the name leads back to the file."""
    name = os.fsencode(str(tmp_path)) + b"/\xff\xfe.json"
    with open(name, "wb") as f:
        f.write(SPEC.encode())
    table = basis.tabulate(basis.Brdf.from_file(name), wo_res=3, wi_res=8, tilt=False)
    basis.write(str(tmp_path / "t.qt"), table)
    sources = basis.load(str(tmp_path / "t.qt")).provenance["sources"]
    assert [os.fsencode(s) for s in sources] == [name]


def test_grids_beyond_floats_and_specs_with_a_nul_are_refused():
    """A finite texel beyond the largest float raises OverflowError (it was read as infinity and
    reported as NaN or Inf); JSON text with a NUL character raises ValueError (the parser stopped
    there and took the rest as gone)."""
    with pytest.raises(OverflowError, match="beyond what floats hold"):
        basis.project(np.ones((8, 8)) * 1e300)
    with pytest.raises(ValueError, match="NUL"):
        basis.Brdf.from_json('{"model": "lambert", "albedo": 0.5}\0garbage')
    # A constant light whose texels overflow once averaged: the argument, as OverflowError.
    with pytest.raises(OverflowError, match="constant radiance.*too large for captures"):
        basis.capture(np.zeros((1, 3)), np.array([[0, 0, 1.0]]), constant=(1e38,) * 3)


def run_and_interrupt(code, tmp_path):
    """Runs `code` in a Python of its own, which prints "started" just before its long call;
    1.5 s later sends it SIGINT, and returns its exit status and stderr. The long calls below
    would take minutes: an interrupt that waited for them would outlast the 60 s allowed."""
    script = tmp_path / "long_call.py"
    # Python installs its KeyboardInterrupt handler only where SIGINT is not ignored, and a
    # process started in the background of a script inherits it ignored: installed here.
    script.write_text("import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"
                      "import numpy as np\nimport basis\n" + code)
    process = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, cwd=SOURCE)
    try:
        assert process.stdout.readline().strip() == "started"
        time.sleep(1.5)
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=60)
    finally:
        process.kill()
        process.wait()
    return process.returncode, err


def test_ctrl_c_stops_tabulation_and_tracing(tmp_path):
    """Both long calls run with the GIL released; Ctrl-C reaches them (they stop at their next
    entry or capture) and raises KeyboardInterrupt, as brdf2qt and capture2qt stop on it."""
    tabulation = (
        'brdf = basis.Brdf.from_json(\'{"model": "phong", "kd": 0.5, "ks": 0.4, '
        '"exponent": 100}\')\n'
        'print("started", flush=True)\n'
        "basis.tabulate(brdf, wo_res=129, threads=1)\n")
    tracing = (
        "points = np.zeros((10000, 3)); normals = np.tile([0.0, 0.0, 1.0], (10000, 1))\n"
        'print("started", flush=True)\n'
        'basis.capture(points, normals, constant=(1, 1, 1), scene="data/scene.obj", '
        "threads=1)\n")
    for code in (tabulation, tracing):
        status, err = run_and_interrupt(code, tmp_path)
        assert status != 0 and "KeyboardInterrupt" in err, err


def write_pfm(path, rgb):
    """A little-endian RGB PFM file of rows listed top first (PFM stores them bottom first)."""
    height, width, _ = rgb.shape
    with open(path, "wb") as f:
        f.write(f"PF\n{width} {height}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(rgb[::-1], dtype="<f4").tobytes())


def test_a_map_with_nan_or_infinite_texels_is_refused_as_capture2qt_refuses_it(tmp_path):
    sky = np.ones((8, 16, 3), np.float32)
    sky[1, 2, 0] = np.nan
    sky[2, 3, 1] = np.inf
    sky[3, 4, 2] = -1
    write_pfm(tmp_path / "bad.pfm", sky)
    point, normal = np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]])
    with pytest.raises(basis.Error, match=r"bad\.pfm: 1 NaN and 1 infinite texel values"):
        basis.capture(point, normal, env=str(tmp_path / "bad.pfm"), res=8)
    with pytest.warns(RuntimeWarning, match="1 NaN, 1 infinite and 1 negative texel values set"):
        captured = basis.capture(point, normal, env=str(tmp_path / "bad.pfm"), res=8,
                                 zero_invalid=True)
    # What is left is the unit sky with three texels' channels at 0: the cosine-weighted mean
    # of the capture's tree is at most 1 and within a few per cent of it.
    mean = captured.tree(0).integrate(0, 0)
    assert 0.9 < mean <= 1.0 + 1e-3
    with pytest.raises(ValueError, match="exclude each other"):
        basis.capture(point, normal, env=str(tmp_path / "bad.pfm"), constant=(1, 1, 1))


def test_a_written_tree_records_how_it_was_cut(tmp_path):
    grid = np.arange(256, dtype=np.float32).reshape(16, 16)
    basis.write(str(tmp_path / "t.qt"), basis.project(grid, 0.5, absolute=True, bounds="linf"))
    info = json.loads(tool("qtinfo", tmp_path / "t.qt", "--json"))
    assert info["tolerance"]["value"] == 0.5
    assert info["tolerance"]["mode"] == "absolute"


def test_arguments_of_the_wrong_kind_are_type_errors():
    with pytest.raises(TypeError, match="got int"):
        basis.write("never.qt", 42)
    with pytest.raises(TypeError, match="single value"):
        basis.project(3.0)
    with pytest.raises(ValueError, match="got -1e-09"):
        basis.project(np.ones((8, 8), np.float32), tolerance=-1e-9)


def test_tabulate_warns_before_it_works():
    """A Phong 10^4 table on a 128 x 128 outgoing grid (the lobe asks for 129) takes many
    minutes: with warnings as errors, the warning must come before the work."""
    code = ("import warnings\nwarnings.simplefilter('error')\n"
            'sharp = basis.Brdf.from_json(\'{"model": "phong", "ks": 1, "exponent": 10000}\')\n'
            "try:\n    basis.tabulate(sharp, wo_res=128, threads=1)\n"
            "except RuntimeWarning as w:\n    print('warned:', w)\n")
    done = subprocess.run([sys.executable, "-c", "import basis\n" + code], capture_output=True,
                          text=True, timeout=60)
    assert "warned:" in done.stdout and "outgoing directions" in done.stdout, done.stderr
