"""Dynamics on guides shaped like production assets (issue: production dynamics): unequal
segments, coincident vertices, stubble beside long hair, read from TressFX and cyHair
files as well as given, and the same groom in centimetres. The built-in grooms' figures
are in test_sim_sdf.py; these are the ones that failed on real-shaped input (a quarter
of the strands over 1e-3 in the first step, 2.4 % at rest on the scalp)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from benchmarks.production_guides import LONGEST, SHORTEST, production_guides

import follicle
from follicle.curves import HairCurves
from follicle.groom.guides import Guides
from follicle.io.cyhair import save_cyhair
from follicle.sim.collision import clearance
from follicle.sim.motion import head_motion, motion_pivot
from follicle.sim.settings import SimParams
from follicle.sim.simulator import MIN_SEGMENT, Simulator
from hairfiles import tfx3_table

FPS = 24


@pytest.fixture(scope="module")
def head():
    return follicle.load_mesh("builtin:head")


@pytest.fixture(scope="module")
def production(head) -> HairCurves:
    return production_guides(0, head)


def _rest_depth(sim: Simulator) -> np.ndarray:
    """Per strand, how deep its rest pose lies inside the skin (0 when outside): guides
    groomed into the skin keep that depth (their margin is their rest clearance)."""
    near = clearance(sim.state.x, sim._colliders(sim._transform, sim.sdf))
    return np.maximum(-near.min(axis=1), 0.0)


def _run(sim: Simulator, head, frames: int, motion: str) -> tuple[float, float]:
    """(the worst max stretch after any frame, the deepest penetration beyond each
    strand's groomed depth) over ``frames`` frames of ``motion`` ("none": at rest)."""
    pivot = motion_pivot(head, None)
    groomed = _rest_depth(sim) if sim.sdf is not None else 0.0
    worst = deepest = 0.0
    for f in range(1, frames + 1):
        if motion != "none":
            sim.set_pose(head_motion(motion, f / FPS, 40.0, 2.0, pivot))
        sim.step(1 / FPS)
        worst = max(worst, sim.stats["max_stretch"])
        if sim.sdf is not None:
            deeper = _rest_depth(sim) - groomed
            deepest = max(deepest, float(deeper.max()))
    return worst, deepest


@pytest.mark.slow
def test_the_production_guides_are_shaped_like_production_ones(production):
    """The generator gives what the tests claim to cover: counts 4–48, segments within a
    strand ×0.1–10 of each other's typical, ~1 % of zero length, 2 mm to 60 cm strands."""
    counts = production.counts
    assert counts.min() == 4 and counts.max() == 48
    seg = np.linalg.norm(np.diff(production.points.astype(np.float64), axis=0), axis=1)
    inner = np.ones(len(seg), bool)
    inner[production.offsets[1:-1] - 1] = False  # the gaps between strands
    seg = seg[inner]
    starts = np.concatenate([[0], np.cumsum(counts - 1)[:-1]])
    lengths = np.add.reduceat(seg, starts)
    # (a zero-length segment takes its share off the strand: within 2 %)
    assert lengths.min() == pytest.approx(SHORTEST, rel=0.02)
    assert lengths.max() == pytest.approx(LONGEST, rel=0.02)
    zero = seg < 1e-9
    assert 0.005 < zero.mean() < 0.02
    spread = []
    for a, n in zip(starts, counts - 1, strict=True):
        s = seg[a : a + n]
        s = s[s > 1e-9]
        spread.append(s.max() / s.min())
    assert np.median(spread) > 20  # ×0.1 … ×10: up to 100 between a strand's segments


@pytest.mark.parametrize(
    "motion, params",
    [("none", dict(skin_collision=False)), ("none", {}), ("shake", {})],
    ids=["free fall", "at rest on the skin", "head shake on the skin"],
)
@pytest.mark.slow
def test_lengths_hold_on_production_guides(head, production, motion, params):
    """Default settings (PBD, strain limit 1e-4): after every frame no segment is more
    than 1e-3 off its rest length, and 2 s after the head stops, 1e-4 (was: 3.6 % on a
    2 mm strand in free fall, 2.4 % at rest on the scalp; the strain limit now also
    lengthens crushed segments and the settle pass puts segments back at length after
    the collisions); no vertex sinks into the skin deeper than it was groomed."""
    sim = Simulator(Guides(production, head), params=SimParams(**params))
    worst, deepest = _run(sim, head, 48, motion)
    assert worst < 1e-3, worst
    assert deepest < 1e-4, deepest
    _run(sim, head, 48, "none")
    assert sim.stats["max_stretch"] < 1e-4, sim.stats["max_stretch"]


@pytest.mark.slow
def test_tressfx_and_cyhair_grooms_keep_their_lengths(head, tmp_path):
    """The production-shaped groom as a TressFX 3 file (32 vertices a strand, as TressFX
    has them; unequal and coincident inside) and as a cyHair file (its own counts),
    read back as guides and shaken: within 1e-3 all the way, 1e-4 at rest."""
    fixed = production_guides(1, head, vertices=32)
    tfx = tmp_path / "groom.tfx"
    points = fixed.points.reshape(fixed.curve_count, 32, 3)
    tfx.write_bytes(tfx3_table(fixed.curve_count, 32, points))
    hair = save_cyhair(iter([production_guides(2, head)]), tmp_path / "groom.hair")
    for path in (tfx, hair):
        sim = Simulator(follicle.load_guides(str(path), head))
        worst, deepest = _run(sim, head, 36, "shake")
        assert worst < 1e-3, (path.name, worst)
        assert deepest < 1e-4, (path.name, deepest)
        _run(sim, head, 48, "none")
        assert sim.stats["max_stretch"] < 1e-4, (path.name, sim.stats["max_stretch"])


@pytest.mark.slow
def test_stretch_of_strands_shorter_than_rounding_is_measured_against_min_segment(head):
    """A 20 µm strand of 48 segments (0.4 µm each) beside the built-in ones: a 1 nm
    nudge of its tip, rounding at the size of a head, is 2.4e-3 of its last segment but
    1e-3 of MIN_SEGMENT; stats report the latter, and a real stretch of the long
    strands still shows."""
    base = follicle.load_guides("builtin:long", head).curves
    pts = base.points.astype(np.float64).copy()
    a, b = base.offsets[0], base.offsets[1]
    shape = pts[a:b] - pts[a]
    pts[a:b] = pts[a] + shape * (2e-5 / np.linalg.norm(np.diff(shape, axis=0), axis=1).sum())
    sim = Simulator(Guides(HairCurves(pts, base.offsets), head), params=SimParams(vertices=49))
    assert sim.model.rest_length[0].max() < MIN_SEGMENT
    assert sim.stats["max_stretch"] < 1e-6
    tip = sim.state.x[0, -1]
    direction = tip - sim.state.x[0, -2]
    sim.state.x[0, -1] = tip + 1e-9 * direction / np.linalg.norm(direction)
    assert sim.stats["max_stretch"] == pytest.approx(1e-3, rel=0.05)
    sim.state.x[1, -1] += 0.01 * (sim.state.x[1, -1] - sim.state.x[1, -2])
    assert sim.stats["max_stretch"] == pytest.approx(0.01, rel=0.01)


@pytest.mark.slow
def test_a_groom_in_centimetres_simulates_like_the_same_groom_in_metres(head, tmp_path):
    """The built-in head and long guides written in centimetres and read with units =
    "cm": gravity, margins and stiffness act the same: after 1 s at rest every vertex is
    where the metre groom's is, to 1 µm (float32 rounding of the files: 64 nm at most),
    and after a 1 s head shake as near as the rounding lets a chaotic motion stay."""
    metre = follicle.load_guides("builtin:long", head).curves
    cm_mesh = tmp_path / "head.obj"
    trimesh.Trimesh(head.rest_vertices * 100.0, head.faces, process=False).export(cm_mesh)
    cm_hair = save_cyhair(
        iter([HairCurves(metre.points.astype(np.float64) * 100.0, metre.offsets)]),
        tmp_path / "long.hair",
    )
    runs = []
    for mesh, guides in (
        (head, metre),
        (follicle.load_mesh(str(cm_mesh), units="cm"), None),
    ):
        g = (
            Guides(guides, mesh)
            if guides is not None
            else follicle.load_guides(str(cm_hair), mesh, units="cm")
        )
        sim = Simulator(g, params=SimParams(vertices=16))
        _run(sim, mesh, FPS, "none")
        rest = sim.positions.copy()
        _run(sim, mesh, FPS, "shake")
        runs.append((rest, sim.positions.copy()))
    at_rest = np.linalg.norm(runs[0][0] - runs[1][0], axis=2)
    assert at_rest.max() < 1e-6, at_rest.max()
    # a shake through the skin's collisions amplifies the files' rounding (measured:
    # 70 µm median, 1.3 mm at worst), not a factor of 100 in any force or margin
    shaken = np.linalg.norm(runs[0][1] - runs[1][1], axis=2)
    assert np.median(shaken) < 5e-4 and shaken.max() < 5e-3, shaken.max()
