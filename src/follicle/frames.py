"""Coordinate frames on hair: root frames on the skin and frames along curves."""

from __future__ import annotations

import numpy as np

__all__ = ["root_frames"]


def _normalize(v: np.ndarray) -> np.ndarray:
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
    n = _normalize(np.asarray(normals, dtype=np.float64))
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
    t = _normalize(t)
    b = np.cross(t, n)
    return n, t, b
