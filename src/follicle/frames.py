"""Coordinate frames on hair: root frames on the skin and frames along curves."""

from __future__ import annotations

import numpy as np

from .errors import InputError
from .kernels import kernel
from .spline import _check_curves

__all__ = ["normalize", "root_frames", "rotation_minimizing_frames", "polyline_frames"]


def normalize(v: np.ndarray) -> np.ndarray:
    """Unit vectors along the last axis; zero vectors stay zero."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def root_frames(
    normals: np.ndarray, tangents: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orthonormal root frames (normal, tangent, binormal) from surface normals/tangents.

    Šik 2012 §2.2.3: the normal is normalised, the tangent made orthogonal to it
    (t - (t·n) n) and normalised, and binormal = tangent × normal. A tangent
    parallel to the normal (or zero) is replaced by a fixed perpendicular, so the
    frame is always defined. Inputs (n, 3); outputs three float64 (n, 3) arrays.
    """
    n = normalize(np.asarray(normals, dtype=np.float64))
    t = np.asarray(tangents, dtype=np.float64)
    t = t - np.sum(t * n, axis=-1, keepdims=True) * n
    length = np.linalg.norm(t, axis=-1)
    bad = length < 1e-9
    if np.any(bad):
        # perpendicular from the axis least aligned with the normal
        nb = n[bad]
        axis = np.zeros_like(nb)
        axis[np.arange(len(nb)), np.argmin(np.abs(nb), axis=-1)] = 1.0
        t[bad] = axis - np.sum(axis * nb, axis=-1, keepdims=True) * nb
    t = normalize(t)
    b = np.cross(t, n)
    return n, t, b


# ------------------------------------------------------------------ rotation minimizing frames
@kernel(inline="always")
def _perpendicular(
    tx: float, ty: float, tz: float, rx: float, ry: float, rz: float
) -> tuple[float, float, float]:
    """r made orthogonal to unit t and normalised; if r ∥ t, the axis least aligned with t."""
    d = rx * tx + ry * ty + rz * tz
    x = rx - d * tx
    y = ry - d * ty
    z = rz - d * tz
    nx = np.sqrt(x * x + y * y + z * z)
    if nx < 1e-9:
        ax, ay, az = abs(tx), abs(ty), abs(tz)
        if ax <= ay and ax <= az:
            x, y, z = 1.0 - tx * tx, -tx * ty, -tx * tz
        elif ay <= az:
            x, y, z = -ty * tx, 1.0 - ty * ty, -ty * tz
        else:
            x, y, z = -tz * tx, -tz * ty, 1.0 - tz * tz
        nx = np.sqrt(x * x + y * y + z * z)
    return x / nx, y / nx, z / nx


@kernel(nogil=True)
def polyline_frames(
    p: np.ndarray, first: np.ndarray, tan: np.ndarray, nor: np.ndarray, bi: np.ndarray
) -> None:
    """Rotation-minimising frame of one polyline ``p`` (N, 3) into ``tan``, ``nor``, ``bi``.

    The one kernel behind every curve frame (Šik 2012 §2.2.8): Catmull-Rom vertex tangents
    (P_{i+1} − P_{i−1}) / 2, the first normal ``first`` (3,) made orthogonal to the
    first tangent, carried by double reflection (Wang et al. 2008; two reflections are an
    exact rotation, so no re-orthonormalisation on the serial path); binormal = t × n
    (skipped when ``bi`` has no rows: the caller needs only the normals).
    A zero tangent carries the previous one, leading zeros take the first valid one, a
    fully degenerate polyline gets +Z. The zero threshold comes from this polyline
    alone, so any grouping of curves gives the same frames. Allocates nothing.
    """
    nv = p.shape[0]
    scale = 0.0
    for i in range(nv):
        for a in range(3):
            scale = max(scale, abs(p[i, a]))
    eps = 1e-12 * max(scale, 1e-30)
    first_ok = -1
    for i in range(nv):
        lo = max(i - 1, 0)
        hi = min(i + 1, nv - 1)
        x = 0.5 * (p[hi, 0] - p[lo, 0])
        y = 0.5 * (p[hi, 1] - p[lo, 1])
        z = 0.5 * (p[hi, 2] - p[lo, 2])
        nt = np.sqrt(x * x + y * y + z * z)
        if nt > eps:
            inv = 1.0 / nt
            tan[i, 0] = x * inv
            tan[i, 1] = y * inv
            tan[i, 2] = z * inv
            if first_ok < 0:
                first_ok = i
        elif first_ok >= 0:
            for a in range(3):
                tan[i, a] = tan[i - 1, a]
    if first_ok < 0:
        for i in range(nv):
            tan[i, 0] = 0.0
            tan[i, 1] = 0.0
            tan[i, 2] = 1.0
    else:
        for i in range(first_ok):
            for a in range(3):
                tan[i, a] = tan[first_ok, a]
    rx, ry, rz = _perpendicular(tan[0, 0], tan[0, 1], tan[0, 2], first[0], first[1], first[2])
    nor[0, 0], nor[0, 1], nor[0, 2] = rx, ry, rz
    for i in range(nv - 1):
        v1x = p[i + 1, 0] - p[i, 0]
        v1y = p[i + 1, 1] - p[i, 1]
        v1z = p[i + 1, 2] - p[i, 2]
        c1 = v1x * v1x + v1y * v1y + v1z * v1z
        if c1 <= eps * eps:
            # zero-length segment: reflect in the plane normal to the tangent instead, so
            # the two reflections still make the minimal rotation t_i -> t_{i+1}
            v1x, v1y, v1z = tan[i, 0], tan[i, 1], tan[i, 2]
            c1 = 1.0
        k1 = 2.0 / c1
        kn = k1 * (v1x * rx + v1y * ry + v1z * rz)
        kt = k1 * (v1x * tan[i, 0] + v1y * tan[i, 1] + v1z * tan[i, 2])
        rx -= kn * v1x
        ry -= kn * v1y
        rz -= kn * v1z
        tx, ty, tz = tan[i + 1, 0], tan[i + 1, 1], tan[i + 1, 2]
        v2x = tx - (tan[i, 0] - kt * v1x)
        v2y = ty - (tan[i, 1] - kt * v1y)
        v2z = tz - (tan[i, 2] - kt * v1z)
        c2 = v2x * v2x + v2y * v2y + v2z * v2z
        if c2 > eps * eps:
            k2 = (2.0 / c2) * (v2x * rx + v2y * ry + v2z * rz)
            rx -= k2 * v2x
            ry -= k2 * v2y
            rz -= k2 * v2z
        nor[i + 1, 0], nor[i + 1, 1], nor[i + 1, 2] = rx, ry, rz
    for i in range(bi.shape[0]):  # none when the caller passes no rows for them
        tx, ty, tz = tan[i, 0], tan[i, 1], tan[i, 2]
        nx, ny, nz = nor[i, 0], nor[i, 1], nor[i, 2]
        bi[i, 0] = ty * nz - tz * ny
        bi[i, 1] = tz * nx - tx * nz
        bi[i, 2] = tx * ny - ty * nx


@kernel(nogil=True)
def _rmf_kernel(
    pts: np.ndarray, offs: np.ndarray, first: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    tan = np.empty_like(pts)
    nor = np.empty_like(pts)
    bi = np.empty_like(pts)
    for c in range(offs.shape[0] - 1):
        a, b = offs[c], offs[c + 1]
        polyline_frames(pts[a:b], first[c], tan[a:b], nor[a:b], bi[a:b])
    return tan, nor, bi


def rotation_minimizing_frames(
    points: np.ndarray, offsets: np.ndarray, first_normals: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Twist-minimising frames (tangents, normals, binormals), each (P, 3) float64 unit.

    Šik 2012 §2.2.8 curve frames: tangents are the normalised Catmull-Rom vertex tangents;
    each curve's first normal (``first_normals`` (C, 3), made orthogonal to the first
    tangent) is carried along by the double reflection method, so hair ribbons do not
    spin; binormal = tangent × normal. Zero-length segments carry the previous frame.
    Each curve is :func:`polyline_frames` (callable from other kernels).
    """
    pts, offs = _check_curves(points, offsets)
    first = np.asarray(first_normals, dtype=np.float64)
    ncurves = len(offs) - 1
    if first.shape != (ncurves, 3):
        raise InputError(
            f"first_normals: expected shape ({ncurves}, 3) (one per curve), got {first.shape}"
        )
    if not np.all(np.isfinite(first)):
        raise InputError("first_normals: values must be finite (no NaN or inf)")
    return _rmf_kernel(pts, offs, np.ascontiguousarray(first))
