"""Hair colour, width and opacity per vertex (Šik 2012 §2.2.6, §2.2.9)."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.color import hsv_to_rgb, lerp_hsv, rgb_to_hsv
from follicle.errors import InputError
from follicle.groom.appearance import hair_appearance
from follicle.rng import uniforms

BROWN = (0.3, 0.2, 0.1)
BLOND = (0.8, 0.6, 0.3)
GREY = (0.8, 0.8, 0.8)


def _call(n: int = 4, **kw: object) -> dict[str, np.ndarray]:
    """hair_appearance for hairs 0 … n − 1 with plain defaults, overridden by ``kw``."""
    args = dict(
        hair_ids=np.arange(n),
        seed=1,
        vertices=5,
        root_color=BROWN,
        tip_color=BLOND,
        hue_var=0.0,
        sat_var=0.0,
        val_var=0.0,
        mutant_fraction=0.0,
        mutant_color=GREY,
        root_width=80e-6,
        tip_width=30e-6,
        root_opacity=1.0,
        tip_opacity=0.5,
    )
    args.update(kw)
    return hair_appearance(**args)


def _hsv(out: dict[str, np.ndarray], vertices: int) -> np.ndarray:
    """(n, N, 3) HSV of the output colours."""
    return rgb_to_hsv(out["color"].astype(np.float64)).reshape(-1, vertices, 3)


def _wrapped(d: np.ndarray) -> np.ndarray:
    """Hue differences mapped to [-180, 180)."""
    return (d + 180.0) % 360.0 - 180.0


# ------------------------------------------------------------------ interpolation
@pytest.mark.parametrize(
    ("root_hue", "tip_hue", "middle_hue"),
    [(350.0, 10.0, 0.0), (10.0, 350.0, 0.0), (10.0, 200.0, 285.0), (300.0, 60.0, 0.0)],
)
def test_hue_takes_the_short_way_round(root_hue, tip_hue, middle_hue):
    root = hsv_to_rgb([root_hue, 1.0, 1.0])
    tip = hsv_to_rgb([tip_hue, 1.0, 1.0])
    out = _call(n=1, vertices=3, root_color=root, tip_color=tip)
    hsv = _hsv(out, 3)[0]
    assert abs(_wrapped(hsv[1, 0] - middle_hue)) < 1e-4
    np.testing.assert_allclose(hsv[:, 1:], 1.0, atol=1e-6)  # saturation never dips
    if middle_hue == 0.0:
        np.testing.assert_array_equal(out["color"][1], [1.0, 0.0, 0.0])  # pure red midway
    np.testing.assert_allclose(out["color"][[0, 2]], [root, tip], atol=1e-6)


def test_saturation_and_value_are_linear_in_t():
    root, tip = hsv_to_rgb([30.0, 0.2, 0.4]), hsv_to_rgb([30.0, 0.6, 0.8])
    hsv = _hsv(_call(n=1, vertices=5, root_color=root, tip_color=tip), 5)[0]
    np.testing.assert_allclose(hsv[:, 1], [0.2, 0.3, 0.4, 0.5, 0.6], atol=1e-6)
    np.testing.assert_allclose(hsv[:, 2], [0.4, 0.5, 0.6, 0.7, 0.8], atol=1e-6)


def test_width_and_opacity_at_root_middle_and_tip():
    out = _call(n=3, vertices=5)
    w = out["width"].reshape(3, 5)
    o = out["opacity"].reshape(3, 5)
    assert out["width"].dtype == out["opacity"].dtype == out["color"].dtype == np.float32
    assert out["color"].shape == (15, 3)
    np.testing.assert_array_equal(w[:, [0, 2, 4]], np.float32([[80e-6, 55e-6, 30e-6]] * 3))
    np.testing.assert_array_equal(o[:, [0, 2, 4]], np.float32([[1.0, 0.75, 0.5]] * 3))
    np.testing.assert_allclose(w[0], np.float32([80e-6, 67.5e-6, 55e-6, 42.5e-6, 30e-6]))


def test_per_hair_values_and_curve_parameters():
    # hair 1 is cut in half: its vertices keep the parameters of the uncut curve (§2.2.8)
    t = np.array([[0.0, 0.5, 1.0], [0.0, 0.25, 0.5]])
    out = _call(
        n=2,
        vertices=3,
        root_width=[1e-4, 2e-4],
        tip_width=[5e-5, 1e-4],
        root_opacity=[1.0, 0.8],
        tip_opacity=[0.0, 0.4],
        t=t,
    )
    np.testing.assert_allclose(
        out["width"], np.float32([1e-4, 7.5e-5, 5e-5, 2e-4, 1.75e-4, 1.5e-4])
    )
    np.testing.assert_allclose(out["opacity"], [1.0, 0.5, 0.0, 0.8, 0.7, 0.6], atol=1e-7)
    shared = _call(n=2, vertices=3, t=[0.0, 0.5, 1.0])
    np.testing.assert_array_equal(shared["width"], _call(n=2, vertices=3)["width"])


def test_shared_and_per_hair_inputs_agree():
    n = 50
    shared = _call(n=n, hue_var=20.0, sat_var=0.1, val_var=0.1, mutant_fraction=0.3)
    per_hair = _call(
        n=n,
        root_color=np.tile(BROWN, (n, 1)),
        tip_color=np.tile(BLOND, (n, 1)),
        hue_var=np.full(n, 20.0),
        sat_var=np.full(n, 0.1),
        val_var=np.full(n, 0.1),
        mutant_fraction=np.full(n, 0.3),
        mutant_color=np.tile(GREY, (n, 1)),
        root_width=np.full(n, 80e-6),
        tip_width=np.full(n, 30e-6),
        root_opacity=np.ones(n),
        tip_opacity=np.full(n, 0.5),
        t=np.tile(np.linspace(0.0, 1.0, 5), (n, 1)),
    )
    for key in ("color", "width", "opacity"):
        np.testing.assert_array_equal(shared[key], per_hair[key])


def test_values_above_one_are_clamped_and_empty_input_works():
    out = _call(n=1, vertices=2, root_color=(2.0, 0.0, 0.0), tip_color=(0.0, 0.0, 3.0))
    np.testing.assert_array_equal(out["color"], [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    empty = _call(n=0, vertices=4)
    assert empty["color"].shape == (0, 3) and empty["width"].shape == (0,)


# ---------------------------------------------------------------------- variation
def test_variation_is_uniform_per_hair_and_follows_the_stream():
    n, nv, seed = 20000, 4, 5
    root = hsv_to_rgb([120.0, 0.5, 0.5])
    tip = hsv_to_rgb([140.0, 0.6, 0.4])
    out = _call(
        n=n,
        seed=seed,
        vertices=nv,
        root_color=root,
        tip_color=tip,
        hue_var=30.0,
        sat_var=0.2,
        val_var=0.1,
    )
    hsv = _hsv(out, nv)
    dh_root = _wrapped(hsv[:, 0, 0] - 120.0)
    dh_tip = _wrapped(hsv[:, -1, 0] - 140.0)
    np.testing.assert_allclose(dh_root, dh_tip, atol=1e-3)  # one shift per hair
    np.testing.assert_allclose(hsv[:, 0, 1] - 0.5, hsv[:, -1, 1] - 0.6, atol=1e-6)
    np.testing.assert_allclose(hsv[:, 0, 2] - 0.5, hsv[:, -1, 2] - 0.4, atol=1e-6)
    assert np.all(np.abs(dh_root) <= 30.0 + 1e-3)
    assert dh_root.min() < -29.5 and dh_root.max() > 29.5  # the whole ±var is reached
    assert abs(dh_root.mean()) < 0.5 and abs(np.std(dh_root) - 30.0 / np.sqrt(3)) < 0.5
    # Šik 2012 §2.2.6: hue = hue − var · 2(ξ − 0.5), ξ numbers 0, 1, 2 of (seed, id, purpose)
    xi = uniforms(seed, np.arange(n), "color variation", 3)
    shift = 2.0 * (xi - 0.5) * [30.0, 0.2, 0.1]
    np.testing.assert_allclose(dh_root, -shift[:, 0], atol=1e-3)
    np.testing.assert_allclose(hsv[:, 0, 1], 0.5 - shift[:, 1], atol=1e-6)
    np.testing.assert_allclose(hsv[:, 0, 2], 0.5 - shift[:, 2], atol=1e-6)
    # inner vertices interpolate the shifted root and tip
    t = np.linspace(0.0, 1.0, nv)
    inner = lerp_hsv(hsv[:, :1], hsv[:, -1:], t[None, :])
    np.testing.assert_allclose(_wrapped(hsv[..., 0] - inner[..., 0]), 0.0, atol=1e-3)
    np.testing.assert_allclose(hsv[..., 1:], inner[..., 1:], atol=1e-6)


def test_hue_wraps_and_saturation_value_clamp():
    n = 5000
    red = (1.0, 0.0, 0.0)  # hue 0, s = v = 1: every negative s or v shift clamps at 1
    out = _call(
        n=n, vertices=2, root_color=red, tip_color=red, hue_var=45.0, sat_var=0.5, val_var=0.5
    )
    hsv = _hsv(out, 2)[:, 0]
    assert np.all((hsv[:, 0] >= 0.0) & (hsv[:, 0] < 360.0))
    assert np.any(hsv[:, 0] > 315.0) and np.any(hsv[:, 0] < 45.0)  # wrapped both ways
    assert np.all(np.abs(_wrapped(hsv[:, 0])) <= 45.0 + 1e-3)
    assert np.all((hsv[:, 1:] >= 0.5 - 1e-6) & (hsv[:, 1:] <= 1.0))
    clamped = np.isclose(hsv[:, 1:], 1.0, atol=1e-7).mean(axis=0)
    assert np.all(np.abs(clamped - 0.5) < 0.05)  # half the hairs shift up and are clamped
    dark = _call(
        n=n, vertices=2, root_color=(0.1, 0.05, 0.0), tip_color=(0.1, 0.05, 0.0), val_var=1.0
    )
    v = _hsv(dark, 2)[:, 0, 2]  # 0.1 − U(−1, 1): P(v < 0) = 0.45, P(v > 1) = 0.05
    assert v.min() == 0.0 and v.max() == 1.0
    assert abs(np.mean(v == 0.0) - 0.45) < 0.04 and abs(np.mean(v == 1.0) - 0.05) < 0.02


# ------------------------------------------------------------------------- mutants
def test_mutant_fraction_is_binomial_and_mutants_have_the_mutant_color():
    n, p, nv, seed = 100_000, 0.02, 3, 9
    out = _call(n=n, seed=seed, vertices=nv, mutant_fraction=p)
    c = out["color"].reshape(n, nv, 3)
    mutant = np.all(c == np.float32(0.8), axis=(1, 2))
    k = int(mutant.sum())
    assert abs(k - n * p) < 5.0 * np.sqrt(n * p * (1.0 - p)), k
    np.testing.assert_array_equal(mutant, uniforms(seed, np.arange(n), "mutant hair", 1)[:, 0] < p)
    np.testing.assert_allclose(c[~mutant, 0], np.broadcast_to(BROWN, (n - k, 3)), atol=1e-6)
    np.testing.assert_allclose(c[~mutant, -1], np.broadcast_to(BLOND, (n - k, 3)), atol=1e-6)
    # width and opacity do not depend on the mutant choice
    np.testing.assert_array_equal(out["width"], _call(n=n, seed=seed, vertices=nv)["width"])


def test_mutant_variation_and_per_hair_fraction():
    n = 400
    out = _call(
        n=n,
        vertices=3,
        mutant_fraction=1.0,
        mutant_color=(0.6, 0.4, 0.2),
        hue_var=20.0,
        val_var=0.2,
    )
    c = out["color"].reshape(n, 3, 3)
    np.testing.assert_allclose(c, np.repeat(c[:, :1], 3, axis=1), atol=1e-7)  # one colour
    assert np.unique(c[:, 0], axis=0).shape[0] == n  # shifted per hair
    hsv = rgb_to_hsv(c[:, 0].astype(np.float64))
    assert np.all(np.abs(_wrapped(hsv[:, 0] - 30.0)) <= 20.0 + 1e-3)
    half = _call(n=n, vertices=2, mutant_fraction=np.repeat([0.0, 1.0], n // 2))
    is_grey = np.all(half["color"].reshape(n, 2, 3) == np.float32(0.8), axis=(1, 2))
    np.testing.assert_array_equal(is_grey, np.arange(n) >= n // 2)


# -------------------------------------------------------------------- determinism
def test_deterministic_and_independent_of_chunking():
    n = 5000
    kw = dict(
        seed=123,
        vertices=6,
        hue_var=25.0,
        sat_var=0.2,
        val_var=0.2,
        mutant_fraction=0.1,
        root_width=np.linspace(50e-6, 90e-6, n),
    )
    whole = _call(n=n, **kw)
    again = _call(n=n, **kw)
    parts = [(0, 1234), (1234, 1235), (1235, n)]
    split = [
        _call(hair_ids=np.arange(a, b), **{**kw, "root_width": kw["root_width"][a:b]})
        for a, b in parts
    ]
    for key in ("color", "width", "opacity"):
        np.testing.assert_array_equal(whole[key], again[key])
        np.testing.assert_array_equal(whole[key], np.concatenate([s[key] for s in split]))
    picked = np.array([4999, 7, 3])
    some = _call(hair_ids=picked, **{**kw, "root_width": kw["root_width"][picked]})
    rows = (picked[:, None] * 6 + np.arange(6)).ravel()
    np.testing.assert_array_equal(some["color"], whole["color"][rows])
    other = _call(n=n, **{**kw, "seed": 124})
    assert not np.array_equal(other["color"], whole["color"])


# ---------------------------------------------------------------------- refusals
@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("hair_ids", np.zeros((2, 2), dtype=np.int64)),
        ("hair_ids", [0.0, 1.0, 2.0, 3.0]),
        ("hair_ids", [0, -1, 2, 3]),
        ("seed", -1),
        ("seed", 1.5),
        ("seed", True),
        ("seed", 2**64),
        ("vertices", 1),
        ("vertices", 3.0),
        ("root_color", (0.1, 0.2)),
        ("root_color", (0.1, np.nan, 0.2)),
        ("tip_color", (0.1, -0.2, 0.3)),
        ("tip_color", np.ones((3, 3))),
        ("mutant_color", "grey"),
        ("hue_var", 181.0),
        ("hue_var", -1.0),
        ("sat_var", 1.5),
        ("val_var", np.nan),
        ("val_var", np.zeros(3)),
        ("mutant_fraction", 1.2),
        ("mutant_fraction", [0.1, 0.1, -0.1, 0.1]),
        ("root_width", 0.0),
        ("tip_width", np.inf),
        ("tip_width", -1e-5),
        ("root_opacity", 1.1),
        ("tip_opacity", True),
        ("t", [0.0, 0.5, 1.0]),
        ("t", [0.0, 0.25, 0.5, 0.75, 1.5]),
        ("t", [0.0, 0.25, np.nan, 0.75, 1.0]),
    ],
)
def test_bad_inputs_name_the_parameter(name, value):
    with pytest.raises(InputError, match=rf"^{name}:"):
        _call(**{name: value})
