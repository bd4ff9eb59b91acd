"""Rotation minimizing frames (Šik 2012 §2.2.8, double reflection) and root frames."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.errors import InputError
from follicle.frames import polyline_frames, root_frames, rotation_minimizing_frames
from follicle.spline import vertex_tangents


def _rowdot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def _assert_orthonormal(t, n, b):
    for v in (t, n, b):
        np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(_rowdot(t, n), 0.0, atol=1e-12)
    np.testing.assert_allclose(_rowdot(t, b), 0.0, atol=1e-12)
    np.testing.assert_allclose(_rowdot(n, b), 0.0, atol=1e-12)
    np.testing.assert_allclose(b, np.cross(t, n), atol=1e-12)  # right-handed


def _planar_curve() -> np.ndarray:
    s = np.linspace(0, 3, 25)
    return np.stack([s, np.sin(2 * s), np.zeros_like(s)], axis=-1)


def test_root_frames_unchanged():
    n, t, b = root_frames([[0, 0, 2.0]], [[1.0, 0, 1.0]])
    np.testing.assert_allclose(n, [[0, 0, 1]])
    np.testing.assert_allclose(t, [[1, 0, 0]])
    np.testing.assert_allclose(b, [[0, -1, 0]])


def test_planar_curve_normal_perpendicular_to_plane_stays():
    pts = _planar_curve()
    t, n, b = rotation_minimizing_frames(pts, [0, len(pts)], [[0, 0, 1.0]])
    _assert_orthonormal(t, n, b)
    np.testing.assert_allclose(n, np.tile([0, 0, 1.0], (len(pts), 1)), atol=1e-12)
    np.testing.assert_allclose(b[:, 2], 0.0, atol=1e-12)


def test_planar_curve_normal_in_plane_stays_in_plane():
    pts = _planar_curve()
    t, n, b = rotation_minimizing_frames(pts, [0, len(pts)], [[0, 1.0, 0]])
    _assert_orthonormal(t, n, b)
    np.testing.assert_allclose(n[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(b, np.tile([0, 0, 1.0], (len(pts), 1)), atol=1e-12)


def test_tangents_are_normalised_vertex_tangents():
    pts = _planar_curve()
    t, _, _ = rotation_minimizing_frames(pts, [0, len(pts)], [[0, 0, 1.0]])
    raw = vertex_tangents(pts, [0, len(pts)])
    np.testing.assert_allclose(t, raw / np.linalg.norm(raw, axis=1)[:, None], atol=1e-15)


def test_first_normal_is_orthogonalised():
    pts = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]])
    t, n, b = rotation_minimizing_frames(pts, [0, 3], [[1.0, 1.0, 0]])
    np.testing.assert_allclose(n, np.tile([0, 1.0, 0], (3, 1)), atol=1e-15)
    # a first normal parallel to the tangent still gives a valid frame
    t, n, b = rotation_minimizing_frames(pts, [0, 3], [[2.0, 0, 0]])
    _assert_orthonormal(t, n, b)


def test_helix_has_low_twist_compared_with_frenet():
    th = np.linspace(0, 4 * np.pi, 200)
    c = 0.3
    pts = np.stack([np.cos(th), np.sin(th), c * th], axis=-1)
    frenet_n = np.stack([-np.cos(th), -np.sin(th), np.zeros_like(th)], axis=-1)
    t, n, b = rotation_minimizing_frames(pts, [0, len(th)], frenet_n[:1])
    _assert_orthonormal(t, n, b)
    # twist about the tangent between neighbouring frames: N_{i+1} . B_i
    frenet_t = np.stack([-np.sin(th), np.cos(th), np.full_like(th, c)], axis=-1)
    frenet_t /= np.linalg.norm(frenet_t, axis=1)[:, None]
    frenet_b = np.cross(frenet_t, frenet_n)
    twist_rmf = np.abs(_rowdot(n[1:], b[:-1])).sum()
    twist_frenet = np.abs(_rowdot(frenet_n[1:], frenet_b[:-1])).sum()
    # Frenet twists by torsion c / (1 + c^2) times arc length sqrt(1 + c^2) per radian
    assert twist_frenet == pytest.approx(c / np.sqrt(1 + c**2) * 4 * np.pi, rel=0.01)
    assert twist_rmf < 0.05 * twist_frenet
    # and the RMF normal turns relative to Frenet by -torsion * arc length
    ang = np.arctan2(_rowdot(n, frenet_b), _rowdot(n, frenet_n))
    expected = -c / np.sqrt(1 + c**2) * th
    wrapped = np.angle(np.exp(1j * (ang - expected)))
    assert np.abs(wrapped[20:-20]).max() < 0.02


def test_coincident_vertices_carry_the_frame():
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 0], [2, 1, 0], [2, 1, 0], [2, 1, 0], [3, 3, 0.0]])
    t, n, b = rotation_minimizing_frames(pts, [0, 7], [[0, 1.0, 0]])
    _assert_orthonormal(t, n, b)
    # planar curve: binormal stays +Z, no flip at the zero-length segments
    np.testing.assert_allclose(b, np.tile([0, 0, 1.0], (7, 1)), atol=1e-12)
    np.testing.assert_allclose(n[3], n[4], atol=1e-15)


def test_long_rough_curve_stays_orthonormal():
    """No drift on 5,000 random steps with reversals, kinks and repeated vertices."""
    rng = np.random.default_rng(3)
    steps = rng.normal(size=(5000, 3)) * rng.choice([1e-3, 1.0, 50.0], size=(5000, 1))
    steps[rng.random(5000) < 0.05] = 0.0  # zero-length segments
    steps[1::97] = -steps[0:-1:97]  # straight back along the previous segment
    pts = np.cumsum(steps, axis=0)
    t, n, b = rotation_minimizing_frames(pts, [0, len(pts)], [[0.3, 0.4, 0.5]])
    _assert_orthonormal(t, n, b)


def test_fully_degenerate_curve_gives_a_frame():
    t, n, b = rotation_minimizing_frames(np.ones((3, 3)), [0, 3], [[1.0, 0, 0]])
    _assert_orthonormal(t, n, b)


def test_several_curves_are_independent():
    pts = _planar_curve()
    both = np.vstack([pts, pts + 5])
    m = len(pts)
    t, n, b = rotation_minimizing_frames(both, [0, m, 2 * m], [[0, 0, 1.0], [0, 1.0, 0]])
    t1, n1, _ = rotation_minimizing_frames(pts, [0, m], [[0, 0, 1.0]])
    t2, n2, _ = rotation_minimizing_frames(pts, [0, m], [[0, 1.0, 0]])
    np.testing.assert_allclose(n, np.vstack([n1, n2]))
    np.testing.assert_allclose(t, np.vstack([t1, t2]))


def test_bad_inputs_raise():
    pts = _planar_curve()
    with pytest.raises(InputError, match="first_normals"):
        rotation_minimizing_frames(pts, [0, len(pts)], [[0, 0, 1.0], [0, 0, 1.0]])
    with pytest.raises(InputError, match="first_normals"):
        rotation_minimizing_frames(pts, [0, len(pts)], [[0, 0, np.nan]])
    with pytest.raises(InputError, match="offsets"):
        rotation_minimizing_frames(pts, [0, 1, len(pts)], [[0, 0, 1.0]] * 2)


def test_one_polyline_in_a_kernel_equals_the_batched_frames_bit_for_bit():
    # fibres and curl call polyline_frames per hair; a batch of curves must give the same
    rng = np.random.default_rng(1)
    curves = [np.cumsum(rng.normal(size=(nv, 3)), axis=0) for nv in (2, 5, 20)]
    batch = rotation_minimizing_frames(
        np.vstack(curves), [0, 2, 7, 27], np.tile([1.0, 0.0, 0.0], (3, 1))
    )
    start = 0
    for p in curves:
        got = [np.empty((len(p), 3)) for _ in range(3)]
        polyline_frames(p, np.array([1.0, 0.0, 0.0]), *got)
        for g, w in zip(got, batch, strict=True):
            np.testing.assert_array_equal(g, w[start : start + len(p)])
        start += len(p)
