"""Catmull-Rom curves (Šik 2012 §2.2.8) against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from follicle import spline as sp
from follicle.errors import InputError

# a 4-vertex curve; its middle segment is the full P_{-1}..P_2 stencil
V4 = np.array([[0, 0, 0], [1, 0, 0], [2, 1, 0], [3, 3, 0]], dtype=np.float64)
# an L-shaped curve whose overshoot is known in closed form (see test_bounds_exact)
VL = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0]], dtype=np.float64)


def _dense(vertices: np.ndarray, per_segment: int = 4000) -> np.ndarray:
    n = len(vertices)
    return sp.evaluate(vertices, np.linspace(0.0, 1.0, (n - 1) * per_segment + 1))


def test_basis_matrix():
    # rows of [t^3, t^2, t, 1] . M at t = 0 and t = 1 select P_i and P_{i+1}
    np.testing.assert_array_equal(np.array([0, 0, 0, 1.0]) @ sp.CATMULL_ROM, [0, 1, 0, 0])
    np.testing.assert_array_equal(np.ones(4) @ sp.CATMULL_ROM, [0, 0, 1, 0])
    # midpoint weights by hand: (-1/16, 9/16, 9/16, -1/16)
    w = np.array([1 / 8, 1 / 4, 1 / 2, 1]) @ sp.CATMULL_ROM
    np.testing.assert_allclose(w, [-1 / 16, 9 / 16, 9 / 16, -1 / 16])


def test_midpoint_of_middle_segment_by_hand():
    # t = 0.5 is u = 0.5 of segment 1: -1/16 P0 + 9/16 P1 + 9/16 P2 - 1/16 P3
    np.testing.assert_allclose(sp.evaluate(V4, 0.5), [1.5, 0.375, 0.0], atol=1e-15)


def test_evaluate_at_vertex_parameters_is_exact():
    rng = np.random.default_rng(1)
    for n in (2, 3, 7, 33):
        v = rng.normal(size=(n, 3)).astype(np.float32)
        t = np.arange(n) / (n - 1)
        np.testing.assert_array_equal(sp.evaluate(v, t), v.astype(np.float64))


def test_straight_even_polyline_is_linear():
    v = np.outer(np.arange(6.0), [1.0, 2.0, -0.5])  # P_i = i * d
    # interior segments (full stencils) reproduce the line exactly in t
    t = np.linspace(0.2, 0.8, 61)
    np.testing.assert_allclose(sp.evaluate(v, t), 5.0 * t[:, None] * [1.0, 2.0, -0.5], atol=1e-12)
    # end segments stay on the line, monotone, but not uniform in t
    t = np.linspace(0, 1, 101)
    c = sp.evaluate(v, t)
    np.testing.assert_allclose(np.cross(c, [1.0, 2.0, -0.5]), 0.0, atol=1e-12)
    assert np.all(np.diff(c[:, 0]) > 0)
    # the duplicated end points slow the end segments: d/dt is 5d inside, 2.5d at the ends
    np.testing.assert_allclose(sp.derivative(v, [0.0, 0.5, 1.0])[1], [5.0, 10.0, -2.5])


def test_evaluate_shapes():
    assert sp.evaluate(V4, 0.25).shape == (3,)
    assert sp.evaluate(V4, np.zeros((2, 5))).shape == (2, 5, 3)
    assert sp.evaluate(V4, 0.25).dtype == np.float64


def test_derivative_matches_finite_difference():
    t = np.linspace(0.01, 0.99, 37)
    h = 1e-6
    fd = (sp.evaluate(V4, t + h) - sp.evaluate(V4, t - h)) / (2 * h)
    np.testing.assert_allclose(sp.derivative(V4, t), fd, atol=1e-6)
    # at the vertices the derivative is the Catmull-Rom tangent times (N - 1)
    tan = sp.vertex_tangents(V4, [0, 4])
    np.testing.assert_allclose(sp.derivative(V4, np.arange(4) / 3), 3 * tan, atol=1e-12)


def test_vertex_tangents_by_hand():
    pts = np.vstack([V4, VL]).astype(np.float32)
    tan = sp.vertex_tangents(pts, [0, 4, 7])
    expected = [
        [0.5, 0, 0],  # (P1 - P0)/2, P_{-1} = P_0
        [1, 0.5, 0],  # (P2 - P0)/2
        [1, 1.5, 0],
        [0.5, 1, 0],  # (P3 - P2)/2
        [0.5, 0, 0],
        [0.5, 0.5, 0],
        [0, 0.5, 0],
    ]
    np.testing.assert_allclose(tan, expected)


def test_resample():
    pts = np.vstack([V4, VL]).astype(np.float32)
    offs = np.array([0, 4, 7])
    p1, o1 = sp.resample(pts, offs, 1)
    np.testing.assert_array_equal(p1, pts)
    np.testing.assert_array_equal(o1, offs)
    p4, o4 = sp.resample(pts, offs, 4)
    assert p4.dtype == np.float32 and o4.dtype == np.int64
    np.testing.assert_array_equal(o4, [0, 13, 22])
    np.testing.assert_array_equal(p4[::4][:4], V4)  # vertices kept at j = 0
    np.testing.assert_allclose(p4[6], [1.5, 0.375, 0.0])  # segment 1, u = 2/4
    np.testing.assert_allclose(p4[:13], sp.evaluate(V4, np.arange(13) / 12), atol=1e-6)
    np.testing.assert_allclose(p4[13:], sp.evaluate(VL, np.arange(9) / 8), atol=1e-6)


def test_cut_inside_segment():
    v2, tp = sp.cut(V4, 0.5)
    np.testing.assert_allclose(v2, [[0, 0, 0], [1, 0, 0], [1.5, 0.375, 0]])
    np.testing.assert_allclose(tp, [0, 1 / 3, 0.5])
    # colour root->tip is still evaluated with the original N: the cut tip is halfway


def test_cut_at_vertex_keeps_it_as_end():
    v2, tp = sp.cut(V4, 2 / 3)
    np.testing.assert_array_equal(v2, V4[:3])
    np.testing.assert_allclose(tp, [0, 1 / 3, 2 / 3])
    v2, tp = sp.cut(V4, 1.0)
    np.testing.assert_array_equal(v2, V4)
    np.testing.assert_allclose(tp, [0, 1 / 3, 2 / 3, 1])


def test_cut_end_point_lies_on_original_curve():
    rng = np.random.default_rng(5)
    v = rng.normal(size=(9, 3))
    for t in rng.uniform(0.01, 1.0, 20):
        v2, tp = sp.cut(v, t)
        np.testing.assert_allclose(v2[-1], sp.evaluate(v, t), atol=1e-12)
        assert tp[-1] == t and np.all(np.diff(tp) > 0)
        np.testing.assert_array_equal(v2[:-1], v[: len(v2) - 1])


def test_cut_vertex_count():
    # N = 10, 9 segments: t in segment s needs P_{s-1}..P_{s+2}
    assert sp.cut_vertex_count(10, 0.05) == 3  # s = 0
    assert sp.cut_vertex_count(10, 0.5) == 7  # u = 4.5, s = 4
    assert sp.cut_vertex_count(10, 4 / 9) == 5  # exactly on P_4
    assert sp.cut_vertex_count(10, 0.95) == 10  # s = 8: capped at N
    assert sp.cut_vertex_count(10, 1.0) == 10
    assert sp.cut_vertex_count(2, 0.5) == 2


def test_cut_from_truncated_vertices_equals_full_cut():
    rng = np.random.default_rng(6)
    v = rng.normal(size=(12, 3))
    for t in (0.03, 0.2, 3 / 11, 0.5, 0.77, 0.99):
        m = sp.cut_vertex_count(12, t)
        full = sp.cut(v, t)
        part = sp.cut(v[:m], t, n_total=12)
        np.testing.assert_array_equal(full[0], part[0])
        np.testing.assert_array_equal(full[1], part[1])
    with pytest.raises(InputError, match="vertices"):
        sp.cut(v[:3], 0.5, n_total=12)


def test_cut_curves_matches_cut():
    pts = np.vstack([V4, VL]).astype(np.float32)
    p2, o2, tp = sp.cut_curves(pts, [0, 4, 7], [0.5, 0.25])
    a, ta = sp.cut(V4, 0.5)
    b, tb = sp.cut(VL, 0.25)
    np.testing.assert_array_equal(o2, [0, 3, 5])
    np.testing.assert_allclose(p2, np.vstack([a, b]), atol=1e-7)
    np.testing.assert_allclose(tp, np.concatenate([ta, tb]))


def test_to_bezier_by_hand():
    bz = sp.to_bezier(VL, [0, 3])
    assert bz.shape == (2, 4, 3)
    # segment 0: P_{-1} = P_0 = 0, P_1 = (1,0,0), P_2 = (1,1,0)
    np.testing.assert_allclose(bz[0], [[0, 0, 0], [1 / 6, 0, 0], [5 / 6, -1 / 6, 0], [1, 0, 0]])
    # segment 1: B1 = P1 + (P2 - P0)/6, B2 = P2 + (P1 - P2)/6 with P3 = P2
    np.testing.assert_allclose(bz[1], [[1, 0, 0], [7 / 6, 1 / 6, 0], [1, 5 / 6, 0], [1, 1, 0]])


def test_bezier_curve_equals_catmull_rom():
    rng = np.random.default_rng(2)
    v = rng.normal(size=(6, 3))
    bz = sp.to_bezier(v, [0, 6])
    u = np.linspace(0, 1, 11)[:, None]
    for s in range(5):
        b = bz[s]
        bez = (
            (1 - u) ** 3 * b[0]
            + 3 * (1 - u) ** 2 * u * b[1]
            + 3 * (1 - u) * u**2 * b[2]
            + u**3 * b[3]
        )
        np.testing.assert_allclose(bez, sp.evaluate(v, (s + u[:, 0]) / 5), atol=1e-12)


def test_bounds_exact():
    # segment 1 x(u) = 1 + u (1 - u)^2 / 2, max 1 + 2/27 at u = 1/3;
    # segment 0 y(u) = u^2 (u - 1) / 2, min -2/27 at u = 2/3
    b = sp.curve_bounds(VL, [0, 3])
    np.testing.assert_allclose(b[0], [[0, -2 / 27, 0], [1 + 2 / 27, 1, 0]], atol=1e-15)
    lo, hi = sp.bounds(VL, [0, 3])
    np.testing.assert_allclose(lo, [0, -2 / 27, 0], atol=1e-15)
    np.testing.assert_allclose(hi, [1 + 2 / 27, 1, 0], atol=1e-15)


def test_bounds_straight_and_degenerate():
    line = np.outer(np.arange(4.0), [1, -1, 0])
    b = sp.curve_bounds(line, [0, 4])[0]
    np.testing.assert_allclose(b, [[0, -3, 0], [3, 0, 0]])
    same = np.ones((3, 3))
    np.testing.assert_array_equal(sp.curve_bounds(same, [0, 3])[0], np.ones((2, 3)))


@settings(max_examples=40, deadline=None)
@given(arrays(np.float64, (7, 3), elements=st.floats(-10, 10)), st.integers(2, 7))
def test_bounds_between_sampling_and_bezier_hull(v, n):
    v = v[:n]
    lo, hi = sp.bounds(v, [0, n])
    dense = _dense(v)
    hull = sp.to_bezier(v, [0, n]).reshape(-1, 3)
    # inside the (conservative) seed box, outside the sampled box, and equal to dense sampling
    assert np.all(lo >= hull.min(axis=0) - 1e-9) and np.all(hi <= hull.max(axis=0) + 1e-9)
    assert np.all(lo <= dense.min(axis=0) + 1e-12) and np.all(hi >= dense.max(axis=0) - 1e-12)
    np.testing.assert_allclose(lo, dense.min(axis=0), atol=1e-6)
    np.testing.assert_allclose(hi, dense.max(axis=0), atol=1e-6)


def test_curve_bounds_per_curve():
    pts = np.vstack([V4, VL + 10])
    b = sp.curve_bounds(pts, [0, 4, 7])
    assert b.shape == (2, 2, 3)
    np.testing.assert_allclose(b[1], sp.curve_bounds(VL, [0, 3])[0] + 10)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: sp.evaluate(V4, 1.5), "t:"),
        (lambda: sp.evaluate(V4, -0.1), "t:"),
        (lambda: sp.evaluate(V4, np.nan), "t:"),
        (lambda: sp.evaluate(V4[:1], 0.5), "vertices"),
        (lambda: sp.evaluate(np.zeros((4, 2)), 0.5), "vertices"),
        (lambda: sp.derivative(V4, 2.0), "t:"),
        (lambda: sp.resample(V4, [0, 4], 0), "k:"),
        (lambda: sp.resample(V4, [0, 2, 3, 4], 2), "offsets"),
        (lambda: sp.resample(V4, [0, 3], 2), "offsets"),
        (lambda: sp.vertex_tangents(V4, [1, 4]), "offsets"),
        (lambda: sp.vertex_tangents(V4, [0.0, 4.0]), "offsets"),
        (lambda: sp.to_bezier(np.full((4, 3), np.inf), [0, 4]), "points"),
        (lambda: sp.cut(V4, 0.0), "t_cut"),
        (lambda: sp.cut(V4, 1.2), "t_cut"),
        (lambda: sp.cut(V4, [0.5, 0.6]), "t_cut"),
        (lambda: sp.cut(V4, 0.5, n_total=3), "n_total"),
        (lambda: sp.cut_vertex_count(1, 0.5), "n:"),
        (lambda: sp.cut_curves(V4, [0, 4], 0.0), "t_cut"),
        (lambda: sp.bounds(np.zeros((0, 3)), [0]), "no curves"),
    ],
)
def test_bad_inputs_raise(call, match):
    with pytest.raises(InputError, match=match):
        call()
