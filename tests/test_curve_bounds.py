"""The writers' bounds kernels give exactly what NumPy gives for the same formula, on
curves of unequal lengths and scales (so a file's bytes do not depend on the method)."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.io.curve_bounds import catmull_rom_bounds, vertex_bounds


def _numpy_hull(points: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """P_i ± |m_i| / 3 over all vertices, m_i the Catmull-Rom tangent (end segments at
    the ends), in float32 as NumPy computes it."""
    m = np.empty_like(points)
    m[1:-1] = (points[2:] - points[:-2]) * np.float32(0.5)
    starts, ends = offsets[:-1], offsets[1:] - 1
    m[starts] = points[starts + 1] - points[starts]
    m[ends] = points[ends] - points[ends - 1]
    m = np.abs(m) / np.float32(3.0)
    return (points - m).min(axis=0), (points + m).max(axis=0)


@pytest.mark.parametrize("seed", range(8))
def test_bounds_equal_numpy_on_production_shaped_curves(seed):
    rng = np.random.default_rng(seed)
    counts = rng.integers(2, 49, rng.integers(1, 400))
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    scale = 10.0 ** rng.integers(-3, 2)  # millimetre to ten-metre grooms
    points = (rng.normal(size=(offsets[-1], 3)) * scale).astype(np.float32)
    points[rng.random(len(points)) < 0.05] = points[0]  # coincident vertices
    lo, hi = _numpy_hull(points, offsets)
    bounds = catmull_rom_bounds(points, offsets)
    assert bounds.dtype == np.float32
    assert (bounds[0] == lo).all() and (bounds[1] == hi).all()
    assert (vertex_bounds(points) == np.stack([points.min(0), points.max(0)])).all()
    assert (bounds[0] <= points.min(0)).all() and (bounds[1] >= points.max(0)).all()


def test_the_bounds_hold_the_curve_between_its_vertices():
    """A hairpin's curve pokes past its vertices; sampled densely (Hermite form, the
    same tangents) it stays inside the bounds, which reach past the vertices."""
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    bounds = catmull_rom_bounds(points, np.array([0, 4]))
    m = np.array(
        [
            points[1] - points[0],
            (points[2] - points[0]) / 2,
            (points[3] - points[1]) / 2,
            points[3] - points[2],
        ]
    )
    t = np.linspace(0, 1, 101)[:, None]
    h00, h10, h01, h11 = (
        2 * t**3 - 3 * t**2 + 1,
        t**3 - 2 * t**2 + t,
        -2 * t**3 + 3 * t**2,
        t**3 - t**2,
    )
    curve = np.concatenate(
        [h00 * points[i] + h10 * m[i] + h01 * points[i + 1] + h11 * m[i + 1] for i in range(3)]
    )
    assert curve[:, 0].max() > 1.0  # the curve does leave the vertices' box
    assert (curve >= bounds[0] - 1e-6).all() and (curve <= bounds[1] + 1e-6).all()
