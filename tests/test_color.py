"""RGB <-> HSV and shortest-route hue interpolation (Šik 2012 §2.2.6)."""

from __future__ import annotations

import colorsys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from follicle.color import (
    hsv_to_rgb,
    hsv_to_rgb1,
    hue_distance,
    hue_distance1,
    lerp_hsv,
    lerp_hsv1,
    rgb_to_hsv,
    rgb_to_hsv1,
)
from follicle.errors import InputError

unit = st.floats(0.0, 1.0)

KNOWN = [
    ([1, 0, 0], [0, 1, 1]),  # red
    ([0, 1, 0], [120, 1, 1]),  # green
    ([0, 0, 1], [240, 1, 1]),  # blue
    ([1, 1, 0], [60, 1, 1]),  # yellow
    ([1, 0, 1], [300, 1, 1]),  # magenta
    ([0.5, 0.5, 0.5], [0, 0, 0.5]),  # grey
    ([1, 1, 1], [0, 0, 1]),  # white
    ([0, 0, 0], [0, 0, 0]),  # black
    ([0.5, 0.25, 0.0], [30, 1, 0.5]),  # brown
]


def test_known_colors():
    rgb = np.array([k[0] for k in KNOWN], dtype=float)
    hsv = np.array([k[1] for k in KNOWN], dtype=float)
    np.testing.assert_allclose(rgb_to_hsv(rgb), hsv, atol=1e-12)
    np.testing.assert_allclose(hsv_to_rgb(hsv), rgb, atol=1e-12)
    assert rgb_to_hsv1(1.0, 0.0, 0.0) == (0.0, 1.0, 1.0)
    assert hsv_to_rgb1(360.0, 1.0, 1.0) == (1.0, 0.0, 0.0)  # hue wraps


def test_shapes_broadcast():
    x = np.random.default_rng(0).uniform(size=(4, 5, 3))
    assert rgb_to_hsv(x).shape == (4, 5, 3)
    assert hsv_to_rgb([0.0, 0.0, 1.0]).shape == (3,)


def test_hue_in_range_for_tiny_negative_hue():
    h = rgb_to_hsv([1.0, 0.0, 1e-17])[0]  # hue -6e-16 must wrap to 0, not 360
    assert 0.0 <= h < 360.0


@settings(max_examples=200, deadline=None)
@given(unit, unit, unit)
def test_roundtrip_and_matches_colorsys(r, g, b):
    hsv = rgb_to_hsv([r, g, b])
    assert 0.0 <= hsv[0] < 360.0 and 0.0 <= hsv[1] <= 1.0 and 0.0 <= hsv[2] <= 1.0
    np.testing.assert_allclose(hsv_to_rgb(hsv), [r, g, b], atol=1e-12)
    ch, cs, cv = colorsys.rgb_to_hsv(r, g, b)
    np.testing.assert_allclose(hsv[1:], [cs, cv], atol=1e-12)
    if cs > 1e-9:
        dh = (hsv[0] - 360.0 * ch + 180.0) % 360.0 - 180.0
        assert abs(dh) < 1e-9


def test_hue_distance_seed_cases():
    assert hue_distance(350, 10) == 20.0  # clockwise through 0
    assert hue_distance(10, 350) == -20.0  # counter-clockwise through 0
    assert hue_distance(0, 180) == 180.0  # tie: cw <= ccw picks clockwise
    assert hue_distance(90, 90) == 0.0
    np.testing.assert_array_equal(hue_distance([0, 90, 300], [90, 0, 30]), [90, -90, 90])
    assert hue_distance1(350.0, 10.0) == 20.0


def test_lerp_shortest_route_through_zero():
    out = lerp_hsv([350, 1, 1], [10, 0, 0.5], np.array([0, 0.25, 0.5, 0.75, 1.0]))
    np.testing.assert_allclose(out[:, 0], [350, 355, 0, 5, 10], atol=1e-12)
    np.testing.assert_allclose(out[:, 1], [1, 0.75, 0.5, 0.25, 0])
    np.testing.assert_allclose(out[:, 2], [1, 0.875, 0.75, 0.625, 0.5])
    assert np.all((out[:, 0] >= 0) & (out[:, 0] < 360))


def test_lerp_broadcasts():
    a = np.array([[60.0, 1, 1], [200.0, 0.5, 0.5]])
    out = lerp_hsv(a, [100.0, 0, 0], 0.5)
    np.testing.assert_allclose(out, [[80, 0.5, 0.5], [150, 0.25, 0.25]])
    assert lerp_hsv(a[:, None], a[None], np.zeros(1)).shape == (2, 2, 3)
    # t over the leading axes, or numpy style with a trailing axis: the same result
    t = np.linspace(0, 1, 5)
    np.testing.assert_array_equal(lerp_hsv(a[0], a[1], t), lerp_hsv(a[0], a[1], t[:, None]))
    assert lerp_hsv(a[0], a[1], t[:, None]).shape == (5, 3)
    assert lerp_hsv1(350.0, 1.0, 1.0, 10.0, 0.0, 0.0, 0.5) == (0.0, 0.5, 0.5)


def test_yellow_to_blue_keeps_saturation():
    # the paper's Fig. 2.25 argument: HSV keeps saturation where RGB mixes to grey
    hsv = lerp_hsv(rgb_to_hsv([1, 1, 0]), rgb_to_hsv([0, 0, 1]), np.linspace(0, 1, 9))
    np.testing.assert_allclose(hsv[:, 1], 1.0)
    assert np.allclose(0.5 * np.array([1, 1, 0]) + 0.5 * np.array([0, 0, 1]), 0.5)


def test_scalar_versions_callable_from_kernels():
    @njit
    def kernel(r, g, b):
        h, s, v = rgb_to_hsv1(r, g, b)
        return hsv_to_rgb1(h, s, v)

    np.testing.assert_allclose(kernel(0.2, 0.4, 0.6), (0.2, 0.4, 0.6), atol=1e-12)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: rgb_to_hsv([1.0, 0.0]), "rgb"),
        (lambda: rgb_to_hsv([np.nan, 0.0, 0.0]), "rgb"),
        (lambda: hsv_to_rgb(np.zeros((2, 4))), "hsv"),
        (lambda: hue_distance(np.inf, 0.0), "h1"),
        (lambda: lerp_hsv([0, 0, 0], [0, 0, 0], np.nan), "t:"),
        (lambda: lerp_hsv(np.zeros((2, 3)), np.zeros((3, 3)), 0.5), "broadcast"),
    ],
)
def test_bad_inputs_raise(call, match):
    with pytest.raises(InputError, match=match):
        call()
