"""Styles that hold (issues 25 and 41): with the default [sim] and the skin on, a
generated spiky groom (strands rising against gravity, benchmarks/spiky_guides.py) keeps
its style at rest and after a head shake, and a production-like styled groom read from a
centimetre file (benchmarks/styled_guides.py: spikes, strands swept back, back spikes
sticking out level) keeps its rise, while the built-in long groom, which hangs, still
swings and long straight strands still fall. The hold (``shape_hold``, the style length:
global shape matching as stiff as a cantilever of that length) carries the styles;
without it they fall."""

from __future__ import annotations

import math

import numpy as np
import pytest
from benchmarks.spiky_guides import (
    FPS,
    HOLD,
    _shaken,
    deviation,
    long_guides,
    rest_now,
    spiky_guides,
)
from benchmarks.styled_guides import GROUPS, load_centimetres, rise, rise_change, styled_guides

import follicle
from follicle.groom.guides import Guides
from follicle.sim.settings import SimParams
from follicle.sim.simulator import Simulator
from follicle.sim.solver import SHAPE_SUBSTEP, STANDARD_GRAVITY, hold_compliance, per_substep


@pytest.fixture(scope="module")
def head():
    return follicle.load_mesh("builtin:head")


@pytest.fixture(scope="module")
def spiky(head):
    return spiky_guides(1, head, count=100)


@pytest.fixture(scope="module")
def figures(head, spiky):
    """The figures of benchmarks/spiky_guides.py's hold_figures with the defaults (5 s
    at rest, the 2 s head shake, 2 s still), for the spikes and the long groom."""
    out = {}
    for name, curves in (("spiky", spiky), ("long", long_guides(head))):
        sim = Simulator(Guides(curves, head))
        out[name] = _shaken(sim, head, 5.0, 2.0)
    return out


def test_the_spikes_rise_against_gravity(head, spiky):
    """What the tests claim to cover: every spike ends above its root, 5–15 cm long."""
    pts = spiky.points.reshape(spiky.curve_count, -1, 3).astype(np.float64)
    rise = pts[:, -1, 1] - pts[:, 0, 1]
    length = np.linalg.norm(np.diff(pts, axis=1), axis=2).sum(axis=1)
    assert (rise > 0.5 * length).all()
    assert 0.05 <= length.min() and length.max() <= 0.15


@pytest.mark.slow
def test_spikes_hold_within_a_centimetre_after_five_seconds_at_rest(figures):
    """Default settings: RMS deviation from the rest pose ≤ 1 cm after 5 s (measured
    4 mm; shape_hold = 0, the old defaults: 5.2 cm)."""
    assert figures["spiky"]["rest"] <= HOLD, figures["spiky"]


@pytest.mark.slow
def test_spikes_are_back_within_two_seconds_of_a_head_shake(figures):
    """After the built-in ±40° shake the RMS deviation is ≤ 1 cm again within 2 s of
    the head stopping and stays there (measured: it never left 1 cm)."""
    f = figures["spiky"]
    assert f["back"] <= 2.0, f
    assert f["settled"] <= HOLD, f


def test_long_hair_still_swings(figures):
    """The hanging long groom gets no hold: its tips swing ≥ 5 cm RMS relative to the
    head during the shake (measured 7.3 cm, as before the hold), over 5× the spikes'."""
    long, spikes = figures["long"], figures["spiky"]
    assert long["shake_tip"] >= 0.05, long
    assert long["shake_tip"] >= 5.0 * spikes["shake_tip"], (long, spikes)


def test_without_the_hold_the_spikes_fall(head, spiky):
    """shape_hold = 0 (hold off, the other defaults): over 1 s the spikes sag 3 cm RMS."""
    sim = Simulator(Guides(spiky, head), params=SimParams(shape_hold=0.0))
    for _ in range(FPS):
        sim.step(1 / FPS)
    assert deviation(sim) > 0.03


def test_level_spikes_hold_whichever_way_gravity_pulls(head, spiky):
    """Gravity along −x, the head still: the spikes, which rise along +y, now stand
    level to it; the hold keeps a groom's shape whatever its direction (the old hold,
    × the sine of the rise, let them fall 3.2 cm RMS in 1 s): within 1 cm (measured 5 mm)."""
    sim = Simulator(Guides(spiky, head), params=SimParams(gravity=(-9.81, 0.0, 0.0)))
    for _ in range(FPS):
        sim.step(1 / FPS)
    assert deviation(sim) <= HOLD


@pytest.fixture(scope="module")
def styled(head, tmp_path_factory):
    """The styled groom (120 strands, 40 per group) as a centimetre file, read back."""
    curves, group = styled_guides(0, head)
    return load_centimetres(curves, head, tmp_path_factory.mktemp("styled")), group


def test_the_styled_groom_is_shaped_like_a_production_one(styled):
    """What the rise tests claim to cover: read in centimetres (lengths 5–15 cm in
    metres), 6–24 vertices, unequal and coincident segments; top spikes rise ≥ 0.7 of
    their length, the back ones stick out level (≤ 0.09)."""
    guides, group = styled
    curves = guides.curves
    assert curves.counts.min() == 6 and curves.counts.max() == 24
    pts = curves.points.astype(np.float64)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    inner = np.ones(len(seg), bool)
    inner[curves.offsets[1:-1] - 1] = False  # the gaps between strands
    seg = seg[inner]
    starts = np.concatenate([[0], np.cumsum(curves.counts - 1)[:-1]])
    length = np.add.reduceat(seg, starts)
    assert 0.05 <= length.min() and length.max() <= 0.15
    assert (seg < 1e-9).sum() >= 5  # coincident vertices
    assert (seg[seg > 1e-9].max() / seg[seg > 1e-9].min()) > 5  # unequal segments
    tip = pts[curves.offsets[1:] - 1] - pts[curves.offsets[:-1]]
    up = tip[:, 1] / length
    names = list(GROUPS)
    assert up[group == names.index("top")].min() >= 0.7
    assert 0.0 < up[group == names.index("back")].max() <= 0.09


@pytest.mark.slow
def test_a_styled_groom_keeps_its_rise_under_gravity(styled):
    """Default [sim], skin on, 2 s at rest: the groom keeps ≥ 0.8 of its summed rise,
    the rising groups (top, front) each ≥ 0.8 of their own (measured 0.92; top 0.92,
    front 0.98), and the back spikes, which barely rise, drop ≤ 0.1 of their length
    (measured 0.03). The old hold (× the sine of the rise) kept 0.48 (front 0.77), and
    the back spikes fell 0.68 of their length."""
    guides, group = styled
    sim = Simulator(guides)
    before = rise(sim)
    change = rise_change(sim)
    now = rise(sim)
    assert now.sum() >= 0.8 * before.sum()
    for name in ("top", "front"):
        g = group == list(GROUPS).index(name)
        assert now[g].sum() >= 0.8 * before[g].sum(), name
    assert -change[group == list(GROUPS).index("back")].mean() <= 0.1


@pytest.mark.slow
def test_short_fur_lying_low_on_top_keeps_its_rise(head):
    """Fur on top of the head: 60 strands of 1–3 cm, 5–25° above level, default [sim]:
    after 2 s it keeps ≥ 0.9 of its rise (measured 1.00); the old hold (× the sine of
    the rise) let it fall flat (−0.60, its tips 0.42 of its length lower)."""
    curves, _ = styled_guides(0, head, 60, {"top": ((0.01, 0.03), (5.0, 25.0))})
    sim = Simulator(Guides(curves, head))
    before = rise(sim)
    rise_change(sim)
    assert rise(sim).sum() >= 0.9 * before.sum()


@pytest.mark.slow
def test_long_straight_hair_still_falls(head, tmp_path):
    """The back spikes made 30–45 cm long (read in centimetres, default [sim]): in 2 s
    every tip drops ≥ 0.25 of its strand's length (measured 0.34–0.37, as with no hold
    at all; the old hold held some at 0.17)."""
    curves, _ = styled_guides(0, head, 40, {"back": ((0.3, 0.45), (0.0, 5.0))})
    sim = Simulator(load_centimetres(curves, head, tmp_path))
    assert (rise_change(sim) <= -0.25).all()


def test_the_hold_is_as_stiff_as_a_cantilever_of_the_style_length():
    """hold_compliance: a level strand as long as the style length sags a tenth of it
    at its tip, twice as long 8× more of its length ((L / ℓ)³); the compliance follows
    arc length, so 8 and 32 segments give the same at the same place."""
    ell = 0.12
    for segments, length in ((8, ell), (32, ell), (8, 2 * ell)):
        alpha = hold_compliance(np.full((1, segments), length / segments), ell)
        assert alpha[0, 0] == 0.0
        tip_sag = STANDARD_GRAVITY * alpha[0, -1]
        assert tip_sag == pytest.approx(0.1 * length * (length / ell) ** 3)
    coarse = hold_compliance(np.full((1, 8), ell / 8), ell)[0]
    fine = hold_compliance(np.full((1, 32), ell / 32), ell)[0]
    np.testing.assert_allclose(fine[::4], coarse, rtol=1e-12)
    assert (np.diff(fine) > 0).all()
    tiny = hold_compliance(np.full((1, 4), 0.05), 1e-300)  # ℓ³ underflows: no hold, no NaN
    assert tiny[0, 0] == 0.0 and np.isinf(tiny[0, 1:]).all()


@pytest.mark.slow
def test_the_shape_stiffness_keeps_its_compliance_at_any_substep(head, spiky):
    """per_substep keeps a shape stiffness's compliance: k at 1/120 s, 0 and 1 kept,
    and the spikes sag alike at substeps of 1/240 s and 1/30 s (4 mm; the per-substep
    stiffness itself would let them sag 16× more at 1/30 s than at 1/120 s)."""
    assert per_substep(0.3, SHAPE_SUBSTEP) == 0.3
    assert per_substep(0.0, 1 / 30) == 0.0 and per_substep(1.0, 1 / 30) == 1.0
    k = per_substep(0.1, 1 / 60)
    alpha = SHAPE_SUBSTEP**2 * 0.9 / 0.1
    assert k == pytest.approx((1 / 60) ** 2 / ((1 / 60) ** 2 + alpha))
    sags = []
    few = spiky_guides(2, head, count=30)
    for substep in (1 / 240, 1 / 30):
        sim = Simulator(Guides(few, head), params=SimParams(substep=substep))
        for _ in range(FPS):
            sim.step(1 / FPS)
        sags.append(deviation(sim))
    assert max(sags) <= HOLD and max(sags) <= 2.0 * min(sags), sags


def test_rest_now_is_where_reset_puts_the_hair(head, spiky):
    sim = Simulator(Guides(spiky, head))
    np.testing.assert_allclose(rest_now(sim), sim.positions, atol=1e-12)
    assert deviation(sim) < 1e-9
    assert math.isfinite(deviation(sim, tips=True))
