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
        assert np.all(np.abs(f - expected) <= 1e-10 * np.abs(expected) + 1e-12 * scale), (
            f"{os.path.basename(path)}: largest difference "
            f"{np.max(np.abs(f - expected) / (np.abs(expected) + 1e-12 * scale)):.3g} (relative)")
        assert np.count_nonzero(expected > 0) > 0.5 * expected.size, path  # not vacuous


def albedo_by_quadrature(brdf, parameter):
    """The integral over the free direction of f cos (what a table entry's lookup under a unit
    light gives), by Gauss-Legendre along 256 azimuths around the mirror direction, in polar
    segments graded towards it so that sharp lobes are resolved (16 nodes each), the last one
    ending at the horizon so that the integrand's edge there is a segment's end."""
    centre = parameter * [-1, -1, 1]
    t = np.cross([1.0, 0, 0] if abs(centre[0]) < 0.9 else [0, 1.0, 0], centre)
    t /= np.linalg.norm(t)
    b = np.cross(centre, t)
    knots = np.array([0, 0.001, 0.003, 0.01, 0.02, 0.04, 0.08, 0.15, 0.3, 0.6, 1.0, 1.5, 2.0, 2.6])
    x, w = np.polynomial.legendre.leggauss(16)
    free, weight = [], []
    for azimuth in (np.arange(256) + 0.5) / 256 * 2 * np.pi:
        d = np.cos(azimuth) * t + np.sin(azimuth) * b
        horizon = np.arctan2(centre[2], -d[2])  # where cos(p) centre_z + sin(p) d_z = 0
        ends = np.append(knots[knots < horizon], horizon)
        polar = np.concatenate([lo + (hi - lo) * (x + 1) / 2 for lo, hi in zip(ends, ends[1:])])
        ring = np.concatenate([w * (hi - lo) / 2 for lo, hi in zip(ends, ends[1:])])
        free.append(np.cos(polar)[:, None] * centre + np.sin(polar)[:, None] * d)
        weight.append(ring * np.sin(polar) * (2 * np.pi / 256))
    free, weight = np.concatenate(free), np.concatenate(weight)
    value = brdf.value(np.repeat(parameter[None], len(free), axis=0), free)
    return (value * weight[:, None]).sum(axis=0)


def test_tabulated_albedo_matches_quadrature_of_the_second_implementation():
    """A table tabulated from each shared file (7 x 7 entries of 16^2 texels: a unit light's
    lookup integrates the texel averages exactly at any resolution), looked up under a unit light
    at the entries at 0, 36.9 and 67.4 degrees, against the albedo the second implementation
    integrates by quadrature: within 0.1 % of the largest channel (f grows as 1/cos towards the
    horizon in these files; the tables grade their quadrature there)."""
    files = sorted(glob.glob(os.path.join(FOLDER, "*.bsdf")))
    if not files:
        pytest.skip(f"{FOLDER} is absent or holds no .bsdf files")
    light = basis.project(np.ones((3, 2, 2), np.float32), tolerance=0)
    for path in files:
        brdf = basis.Brdf.from_json(json.dumps({"model": "rgl", "file": path}))
        table = basis.tabulate(brdf, wo_res=7, wi_res=16, tilt=False)
        reference = rgl_reference.RglBrdf(path)
        for s in (0.0, 1 / 3, 2 / 3):  # entries (3 + 3 s, 3) of the parabolic grid
            wo = np.array([2 * s, 0, 1 - s * s]) / (1 + s * s)
            tabulated = np.array(basis.reflect(table, light, wo)[0])
            expected = albedo_by_quadrature(reference, wo)
            assert np.all(np.abs(tabulated - expected) <= 0.001 * expected.max()), (
                f"{os.path.basename(path)} at {np.degrees(np.arccos(wo[2])):.1f} degrees: "
                f"tabulated {tabulated}, quadrature {expected}")
