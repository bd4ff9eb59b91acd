"""Coordinate frames on hair: root frames on the skin and frames along curves."""

from __future__ import annotations

import numpy as np
from numba import njit

from .errors import InputError
from .spline import _check_curves, _tangents_kernel

__all__ = ["normalize", "root_frames", "rotation_minimizing_frames"]


def normalize(v: np.ndarray) -> np.ndarray:
    """Unit vectors along the last axis; zero vectors stay zero."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def root_frames(
    normals: np.ndarray, tangents: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orthonormal root frames (normal, tangent, binormal) from surface normals/tangents.

    000 §2.2.3: the normal is normalised, the tangent made orthogonal to it
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
@njit(cache=True, inline="always")
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def _unit_perpendicular(t, r):
    """r made orthogonal to unit t and normalised; an arbitrary perpendicular if r ∥ t."""
    d = _dot(r, t)
    x = r - d * t
    nx = np.sqrt(_dot(x, x))
    if nx < 1e-9:
        # the axis least aligned with t, orthogonalised
        ax = np.zeros(3)
        ax[np.argmin(np.abs(t))] = 1.0
        x = ax - _dot(ax, t) * t
        nx = np.sqrt(_dot(x, x))
    return x / nx


@njit(cache=True)
def _rmf_kernel(pts, offs, first, eps):
    raw = _tangents_kernel(pts, offs)
    tan = np.empty_like(pts)
    nor = np.empty_like(pts)
    bi = np.empty_like(pts)
    for c in range(offs.shape[0] - 1):
        a, b = offs[c], offs[c + 1]
        # unit tangents; a zero tangent (coincident vertices) carries the previous one,
        # leading zeros take the first valid one, a fully degenerate curve gets +Z
        first_ok = -1
        for i in range(a, b):
            nt = np.sqrt(_dot(raw[i], raw[i]))
            if nt > eps:
                tan[i] = raw[i] / nt
                if first_ok < 0:
                    first_ok = i
            elif first_ok >= 0:
                tan[i] = tan[i - 1]
        if first_ok < 0:
            for i in range(a, b):
                tan[i, 0] = 0.0
                tan[i, 1] = 0.0
                tan[i, 2] = 1.0
        else:
            for i in range(a, first_ok):
                tan[i] = tan[first_ok]
        nor[a] = _unit_perpendicular(tan[a], first[c])
        for i in range(a, b - 1):
            # 000 §2.2.8 Fig. 2.39, double reflection (Wang et al. 2008)
            v1 = pts[i + 1] - pts[i]
            c1 = _dot(v1, v1)
            if c1 <= eps * eps:
                # zero-length segment: reflect in the plane normal to the tangent instead,
                # so the two reflections still make the minimal rotation t_i -> t_{i+1}
                # (one reflection alone would flip the frame's handedness)
                v1 = tan[i].copy()
                c1 = 1.0
            rl = nor[i] - (2.0 / c1) * _dot(v1, nor[i]) * v1
            tl = tan[i] - (2.0 / c1) * _dot(v1, tan[i]) * v1
            v2 = tan[i + 1] - tl
            c2 = _dot(v2, v2)
            r = rl - (2.0 / c2) * _dot(v2, rl) * v2 if c2 > eps * eps else rl
            nor[i + 1] = _unit_perpendicular(tan[i + 1], r)  # re-orthonormalise (round-off)
        for i in range(a, b):
            t = tan[i]
            n = nor[i]
            bi[i, 0] = t[1] * n[2] - t[2] * n[1]
            bi[i, 1] = t[2] * n[0] - t[0] * n[2]
            bi[i, 2] = t[0] * n[1] - t[1] * n[0]
    return tan, nor, bi


def rotation_minimizing_frames(
    points: np.ndarray, offsets: np.ndarray, first_normals: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Twist-minimising frames (tangents, normals, binormals), each (P, 3) float64 unit.

    000 §2.2.8 curve frames: tangents are the normalised Catmull-Rom vertex tangents;
    each curve's first normal (``first_normals`` (C, 3), made orthogonal to the first
    tangent) is carried along by the double reflection method, so hair ribbons do not
    spin; binormal = tangent × normal. Zero-length segments carry the previous frame.
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
    scale = float(np.abs(pts).max()) if len(pts) else 1.0
    eps = 1e-12 * max(scale, 1e-30)
    return _rmf_kernel(pts, offs, np.ascontiguousarray(first), eps)
