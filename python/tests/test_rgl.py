"""The library's RGL-EPFL evaluation (basis.Brdf of an {"model": "rgl"} spec) against a second
implementation of the format in NumPy (rgl_reference.py), on every measured file of the shared
data folder (../shared/data/rgl-bsdf beside the source tree)."""
import glob
import json
import os

import numpy as np
import pytest

import basis
import rgl_reference

SOURCE = os.environ.get("BASIS_SOURCE_DIR", ".")
FOLDER = os.path.join(SOURCE, "..", "shared", "data", "rgl-bsdf")


def directions(theta_degrees, phi_degrees):
    t, p = np.radians(theta_degrees), np.radians(phi_degrees)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=1)


def test_evaluation_matches_a_second_implementation():
    files = sorted(glob.glob(os.path.join(FOLDER, "*.bsdf")))
    if not files:
        pytest.skip(f"{FOLDER} is absent or holds no .bsdf files: the measured RGL files are not "
                    "checked against the second implementation (the C++ tests check a synthetic "
                    "file)")
    rng = np.random.default_rng(11)
    n = 2000
    for path in files:
        # Random pairs over the whole hemisphere, the mirror direction and grazing angles among
        # them; the library's evaluate(wi, wo) takes wo as the tables' parameter direction.
        parameter = directions(rng.uniform(0, 89.5, n), rng.uniform(-180, 180, n))
        free = directions(rng.uniform(0, 89.5, n), rng.uniform(-180, 180, n))
        free[:20] = parameter[:20] * [-1, -1, 1]
        expected = rgl_reference.RglBrdf(path).value(parameter, free) / free[:, 2:3]
        brdf = basis.Brdf.from_json(json.dumps({"model": "rgl", "file": path}))
        f = brdf.evaluate(free, parameter)
        scale = np.abs(expected).max()
        assert np.all(np.abs(f - expected) <= 1e-9 * np.abs(expected) + 1e-12 * scale), (
            f"{os.path.basename(path)}: largest difference "
            f"{np.max(np.abs(f - expected) / (np.abs(expected) + 1e-12 * scale)):.3g} (relative)")
        assert np.count_nonzero(expected > 0) > 0.5 * expected.size, path  # not vacuous
