"""A second implementation of the RGL-EPFL measured BRDF evaluation (tensor_file v1.0 .bsdf
files, isotropic RGB), in NumPy and double precision, written from the format's definition to
check the library's reader and evaluation against. Not fast; vectorised over directions.

The format: f(wi, wo) cos(theta_o) = max(0, rgb(s)) ndf(u_m) / (4 sigma(u_i)), where u_i and u_m
are wi and the half vector in (sqrt(2 theta / pi), (phi + pi) / 2 pi) coordinates (the half
vector's azimuth relative to wi's for isotropic files), and s is u_m carried back through the
visible-normal warp: the inverse of sampling a bilinear density on a vertex grid, its row
first, then the column within the row. The tables are interpolated linearly over their
parameters (phi_i, theta_i, and the channel for rgb), bilinearly over the square."""
import struct

import numpy as np

DTYPES = {1: np.uint8, 2: np.int8, 3: np.uint16, 4: np.int16, 5: np.uint32, 6: np.int32,
          7: np.uint64, 8: np.int64, 9: np.float16, 10: np.float32, 11: np.float64}


def read_tensor_file(path):
    """The named arrays of a tensor_file: a 12-byte magic, a version (two bytes), a field count,
    then per field its name, rank, dtype code, byte offset and shape, all little-endian."""
    with open(path, "rb") as file:
        data = file.read()
    if data[:12] != b"tensor_file\0":
        raise ValueError(f"{path}: not a tensor_file")
    (count,) = struct.unpack_from("<I", data, 14)
    position, fields = 18, {}
    for _ in range(count):
        (length,) = struct.unpack_from("<H", data, position)
        name = data[position + 2:position + 2 + length].decode()
        position += 2 + length
        rank, dtype, offset = struct.unpack_from("<HBQ", data, position)
        position += 11
        shape = struct.unpack_from(f"<{rank}Q", data, position)
        position += 8 * rank
        fields[name] = np.frombuffer(data, DTYPES[dtype], int(np.prod(shape)), offset).reshape(shape)
    return fields


def elevation(d):
    """Angle from +z of unit vectors (rows)."""
    return 2 * np.arcsin(np.minimum(1.0, 0.5 * np.linalg.norm(d - [0.0, 0.0, 1.0], axis=1)))


def theta_to_u(theta):
    return np.sqrt(np.maximum(0.0, 2 * theta / np.pi))


def phi_to_u(phi):
    return (phi + np.pi) / (2 * np.pi)


def parameter_corners(parameter_values, parameters):
    """The corners of the parameter cell around each query, as (indices, weights): linear
    interpolation along each parameter (a parameter with one value takes it)."""
    corners = [((), 1.0)]
    for values, p in zip(parameter_values, parameters):
        values = np.asarray(values, np.float64)
        if len(values) == 1:
            options = [(np.zeros(len(p), int), np.ones(len(p)))]
        else:
            i = np.clip(np.searchsorted(values, p, side="right") - 1, 0, len(values) - 2)
            w = (p - values[i]) / (values[i + 1] - values[i])
            options = [(i, 1 - w), (i + 1, w)]
        corners = [(c + (i,), cw * w) for c, cw in corners for i, w in options]
    return corners


class Table2D:
    """Values at the vertices of a grid over the unit square (the last two axes: rows y, columns
    x), one grid per parameter combination (the leading axes). With `density`, each grid is
    scaled to integrate to 1 and the cumulative integrals the warp inverts are kept."""

    def __init__(self, values, parameter_values, density=False):
        v = np.asarray(values, np.float64)
        self.rows, self.columns = v.shape[-2:]
        self.parameter_values = parameter_values
        if density:
            cells = (v[..., :-1, :-1] + v[..., 1:, :-1] + v[..., :-1, 1:] + v[..., 1:, 1:]) / 4
            v = v / (cells.mean(axis=(-1, -2)))[..., None, None]
            along_x = 0.5 * (v[..., :-1] + v[..., 1:])
            # Per row of vertices: the integral from x = 0 to each column (in cells).
            self.row_cumulative = np.concatenate(
                [np.zeros(v.shape[:-1] + (1,)), np.cumsum(along_x, axis=-1)], axis=-1)
            row_total = self.row_cumulative[..., -1]
            along_y = 0.5 * (row_total[..., :-1] + row_total[..., 1:])
            self.cumulative = np.concatenate(
                [np.zeros(row_total.shape[:-1] + (1,)), np.cumsum(along_y, axis=-1)], axis=-1)
        self.values = v

    def _cell(self, points):
        fx = points[:, 0] * (self.columns - 1)
        fy = points[:, 1] * (self.rows - 1)
        x = np.clip(np.floor(fx).astype(int), 0, self.columns - 2)
        y = np.clip(np.floor(fy).astype(int), 0, self.rows - 2)
        return x, y, fx - x, fy - y

    def evaluate(self, points, parameters=()):
        """Bilinear interpolation at points (rows of (x, y)), interpolated over the parameters."""
        x, y, tx, ty = self._cell(points)
        out = np.zeros(len(points))
        for corner, weight in parameter_corners(self.parameter_values, parameters):
            at = lambda yy, xx: self.values[(*corner, yy, xx)]
            out += weight * ((1 - tx) * (1 - ty) * at(y, x) + tx * (1 - ty) * at(y, x + 1) +
                             (1 - tx) * ty * at(y + 1, x) + tx * ty * at(y + 1, x + 1))
        return out

    def invert(self, points, parameters=()):
        """The uniform sample that the warp of this density takes to each point: the fraction
        of the density below the point's row, then of its row left of the point."""
        x, y, tx, ty = self._cell(points)
        n = len(points)
        below = total = row0 = row1 = left = row_total = v0 = v1 = np.zeros(n)
        last_y, last_x = self.rows - 1, self.columns - 1
        for corner, w in parameter_corners(self.parameter_values, parameters):
            at = lambda table, *index: table[(*corner, *index)]
            below = below + w * at(self.cumulative, y)
            total = total + w * at(self.cumulative, last_y)
            row0 = row0 + w * at(self.row_cumulative, y, last_x)
            row1 = row1 + w * at(self.row_cumulative, y + 1, last_x)
            left = left + w * ((1 - ty) * at(self.row_cumulative, y, x) +
                               ty * at(self.row_cumulative, y + 1, x))
            row_total = row_total + w * ((1 - ty) * at(self.row_cumulative, y, last_x) +
                                         ty * at(self.row_cumulative, y + 1, last_x))
            v0 = v0 + w * ((1 - ty) * at(self.values, y, x) + ty * at(self.values, y + 1, x))
            v1 = v1 + w * ((1 - ty) * at(self.values, y, x + 1) +
                           ty * at(self.values, y + 1, x + 1))
        # Within the cell the row density is linear in y and the density along the row linear
        # in x: their integrals up to the point are quadratic.
        u_y = (below + ty * (row0 + 0.5 * ty * (row1 - row0))) / total
        u_x = (left + tx * (v0 + 0.5 * tx * (v1 - v0))) / row_total
        return np.stack([u_x, u_y], axis=1)


class RglBrdf:
    def __init__(self, path):
        f = read_tensor_file(path)
        phi_i = f["phi_i"].astype(np.float64)
        theta_i = f["theta_i"].astype(np.float64)
        if len(phi_i) != 1:
            raise NotImplementedError(f"{path}: only isotropic files (one phi_i) are implemented")
        # jacobian set: the tables hold rgb, the value is rgb D / (4 sigma); else rgb alone.
        self.jacobian = bool(f["jacobian"][0])
        incident = [phi_i, theta_i]
        self.ndf = Table2D(f["ndf"], [])
        self.sigma = Table2D(f["sigma"], [])
        self.vndf = Table2D(f["vndf"], incident, density=True)
        self.rgb = Table2D(f["rgb"], incident + [np.array([0.0, 1.0, 2.0])])

    def value(self, wi, wo):
        """f(wi, wo) cos(theta_o) per channel (N x 3) for unit wi (the tables' parameter
        direction) and wo (rows); 0 below the horizon."""
        wm = wi + wo
        wm = wm / np.linalg.norm(wm, axis=1, keepdims=True)
        theta_i, phi_i = elevation(wi), np.arctan2(wi[:, 1], wi[:, 0])
        theta_m, phi_m = elevation(wm), np.arctan2(wm[:, 1], wm[:, 0])
        u_i = np.stack([theta_to_u(theta_i), phi_to_u(phi_i)], axis=1)
        u_phi_m = phi_to_u(phi_m - phi_i)  # isotropic: relative to wi's azimuth
        u_m = np.stack([theta_to_u(theta_m), u_phi_m - np.floor(u_phi_m)], axis=1)
        parameters = [phi_i, theta_i]
        sample = self.vndf.invert(u_m, parameters)
        scale = self.ndf.evaluate(u_m) / (4 * self.sigma.evaluate(u_i)) if self.jacobian else 1
        out = np.zeros((len(wi), 3))
        for c in range(3):
            rgb = self.rgb.evaluate(sample, parameters + [np.full(len(wi), float(c))])
            out[:, c] = np.maximum(rgb, 0) * scale
        out[(wi[:, 2] <= 0) | (wo[:, 2] <= 0)] = 0
        return out
