"""Bounds of curve chunks, as the writers store them (USD ``extent``, Alembic
``.selfBnds``): one pass over the points in a numba kernel.

A writer computes the bounds of every chunk it writes, a million hairs × 24 points at a
time; NumPy's ``min(axis=0)`` over (N, 3) rows walks the array with a stride and made
the bounds a quarter of a USD write. The kernels give the values NumPy gives, in
float32 as NumPy computes them, so a file's bytes do not change with the method.
"""

from __future__ import annotations

import numpy as np

from ..arrays import readonly
from ..kernels import kernel

__all__ = ["vertex_bounds", "catmull_rom_bounds"]


@kernel(nogil=True)
def _vertex_bounds(points: np.ndarray) -> np.ndarray:
    out = np.empty((2, 3), np.float32)
    out[0] = points[0]
    out[1] = points[0]
    for i in range(1, points.shape[0]):
        for k in range(3):
            v = points[i, k]
            if v < out[0, k]:
                out[0, k] = v
            if v > out[1, k]:
                out[1, k] = v
    return out


@kernel(nogil=True)
def _catmull_rom_bounds(points: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    out = np.empty((2, 3), np.float32)
    out[0] = np.inf
    out[1] = -np.inf
    half, third = np.float32(0.5), np.float32(3.0)
    for c in range(offsets.shape[0] - 1):
        a, b = offsets[c], offsets[c + 1] - 1
        for i in range(a, b + 1):
            for k in range(3):
                if i == a:
                    m = points[a + 1, k] - points[a, k]
                elif i == b:
                    m = points[b, k] - points[b - 1, k]
                else:
                    m = (points[i + 1, k] - points[i - 1, k]) * half
                m = abs(m) / third
                lo, hi = points[i, k] - m, points[i, k] + m
                if lo < out[0, k]:
                    out[0, k] = lo
                if hi > out[1, k]:
                    out[1, k] = hi
    return out


def vertex_bounds(points: np.ndarray) -> np.ndarray:
    """(2, 3) float32 [min, max] of ``points`` (N ≥ 1, 3), as ``points.min(axis=0)`` and
    ``points.max(axis=0)`` give them: the bounds of linear curves."""
    return _vertex_bounds(readonly(points, np.float32))


def catmull_rom_bounds(points: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(2, 3) float32 bounds of pinned Catmull-Rom curves (``points`` (N ≥ 1, 3), curve
    ``c`` being ``points[offsets[c]:offsets[c + 1]]``, two points or more each): every
    segment lies in the hull of its Bézier points P_i ± m_i / 3, m_i the vertex tangent
    (half the neighbours' difference; at an end, the end segment, as USD's phantom
    points make it)."""
    return _catmull_rom_bounds(readonly(points, np.float32), readonly(offsets, np.int64))
