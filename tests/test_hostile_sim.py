"""The simulator under abuse: every argument of step / set_pose / teleport is accepted
correctly or refused with an InputError naming it, every value the [sim] schema accepts
gives a stable simulation, and `follicle simulate` keeps its promises (exit 0 with a
finite, unstretched cache, or exit 2 with one line)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from follicle.curves import HairCurves
from follicle.errors import ConfigError, InputError, ResourceError, SimulationError
from follicle.io.sim_cache import load_cache
from follicle.scene import SimParams
from follicle.sim import Simulator
from follicle.sim.motion import head_motion, motion_pivot
from follicle.sim.simulator import MAX_SUBSTEPS_PER_CALL
from hostile import assert_cli_refused, run_cli, warm

MAX_STRETCH = 0.02  # the walk's bound on |length / rest − 1| (each single extreme: ≤ 0.5 %)
MAX_COMBINED_STRETCH = 0.10  # … where extremes combine (the worst: 5.3 %)
MAX_REACH = 1.07  # … and on a vertex's distance from its root, in strand lengths (the
# longest, stretch_limit off or 1: 1.069)


def _strands(count: int = 3, n: int = 12, length: float = 0.3) -> HairCurves:
    """``count`` curled strands of ``length`` m along +x, 5 cm apart."""
    pts = np.zeros((count, n, 3))
    s = np.linspace(0.0, length, n)
    pts[:, :, 0] = s
    pts[:, :, 1] = 0.05 * np.sin(20.0 * s)
    pts[:, :, 2] = np.arange(count)[:, None] * 0.05
    return HairCurves.from_array(pts)


@pytest.fixture
def sim() -> Simulator:
    return Simulator(_strands())


# ------------------------------------------------------------------ step(dt)
@pytest.mark.parametrize(
    "dt",
    [
        np.float32(1 / 60),
        np.float64(1 / 60),
        np.array(1 / 60),
        np.array(1 / 60, np.float32),
        1 / 60,
        0,
        np.int64(0),
        np.array(0, np.int32),
        np.float16(0.0),
    ],
    ids=["float32", "float64", "0-d", "0-d float32", "float", "int", "int64", "0-d int", "float16"],
)
def test_step_takes_any_real_number_of_seconds(sim, dt):
    sim.step(dt)
    assert sim.state.time == pytest.approx(round(float(dt) / sim.params.substep) / 120.0)
    assert np.isfinite(sim.positions).all()


@pytest.mark.parametrize(
    ("dt", "needle"),
    [
        (float("nan"), "finite"),
        (float("inf"), "finite"),
        (-float("inf"), "finite"),
        (np.float32("nan"), "finite"),
        (-1.0, "≥ 0"),
        (np.float64(-1e-9), "≥ 0"),
        (True, "dt"),
        (np.bool_(True), "dt"),
        ("0.1", "dt"),
        (None, "dt"),
        (1j, "dt"),
        (np.array([0.1]), "dt"),
        (np.array([0.1, 0.2]), "dt"),
        (np.array("0.1"), "dt"),
    ],
)
def test_step_refuses_bad_seconds_with_an_input_error(sim, dt, needle):
    before = sim.positions.copy()
    with pytest.raises(InputError, match="dt") as info:
        sim.step(dt)
    assert needle in str(info.value)
    assert sim.state.time == 0.0 and np.array_equal(sim.positions, before)


@pytest.mark.parametrize(
    ("dt", "needle"), [(1e9, "10,000"), (MAX_SUBSTEPS_PER_CALL / 120 + 1, "smaller pieces")]
)
def test_a_step_too_long_for_one_call_is_a_resource_error(sim, dt, needle):
    before = sim.positions.copy()
    with pytest.raises(ResourceError, match="dt") as info:
        sim.step(dt)
    assert needle in str(info.value) and not isinstance(info.value, InputError)
    assert sim.state.time == 0.0 and np.array_equal(sim.positions, before)


@pytest.mark.slow
def test_the_substep_cap_counts_the_whole_step_and_says_the_fix():
    sim = Simulator(_strands(), params=SimParams(substep=1e-6))
    sim.step(MAX_SUBSTEPS_PER_CALL * 1e-6)  # exactly at the cap: runs
    assert sim.state.time == pytest.approx(MAX_SUBSTEPS_PER_CALL * 1e-6)
    with pytest.raises(ResourceError) as info:
        sim.step(1 / 24)
    message = str(info.value)
    assert "41,666 substeps" in message and "at most 10,000" in message
    assert "smaller pieces" in message and "[sim].substep" in message


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.one_of(
        st.floats(),
        st.floats(0.0, 0.5),
        st.integers(-(10**30), 10**30),
        st.sampled_from([np.float32(0.01), np.float64(1e300), np.float16(-0.0), 1.8e306]),
    )
)
def test_step_accepts_or_refuses_any_number(dt):
    sim = Simulator(_strands(1, 6), params=SimParams(substep=0.01))
    try:
        sim.step(dt)
    except (InputError, ResourceError) as exc:
        assert "dt" in str(exc)
        ok = math.isfinite(float(dt)) and 0 <= float(dt) <= MAX_SUBSTEPS_PER_CALL * 0.01
        assert not ok, f"{dt!r} refused: {exc}"
    else:
        assert 0 <= float(dt) < (MAX_SUBSTEPS_PER_CALL + 1) * 0.01
        assert np.isfinite(sim.positions).all()


# ------------------------------------------------------------------ set_pose / teleport
def _m(rot: object = np.eye(3), move: object = (0.0, 0.0, 0.0)) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = rot, move
    return out


_OBJECTS = np.empty((4, 4), object)
_OBJECTS[:] = "x"
BAD_TRANSFORMS = [
    (np.diag([-1.0, 1.0, 1.0, 1.0]), "mirror"),
    (_m(np.diag([1.0, -1.0, -1.0])) @ np.diag([-1.0, 1.0, 1.0, 1.0]), "mirror"),
    (_m(np.zeros((3, 3))), "singular"),
    (_m(np.diag([1.0, 1.0, 0.0])), "singular"),
    (np.diag([2.0, 2.0, 2.0, 1.0]), "rigid"),
    (np.diag([1.0, 1.0, 1e-9, 1.0]), "rigid"),
    (_m([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "rigid"),  # shear
    (_m(move=(0.0, float("nan"), 0.0)), "finite"),
    (_m(move=(float("inf"), 0.0, 0.0)), "finite"),
    (_m(move=(2e6, 0.0, 0.0)), "beyond"),
    (_m(move=(0.0, 0.0, -1e300)), "beyond"),
    (np.eye(3), "3×3 rotation"),
    (np.eye(4)[:3], "4×4"),
    (np.eye(4).ravel(), "4×4"),
    (np.eye(4)[None], "4×4"),
    ([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]], "last row"),
    ("eye(4)", "transform"),
    (b"\x00" * 128, "transform"),
    (_OBJECTS, "transform"),
    (np.eye(4, dtype=complex), "transform"),
    (np.eye(4, dtype=bool), "transform"),
    ([[1, 0, 0], [0, 1, 0, 0]], "transform"),
    (object(), "transform"),
]


@pytest.mark.parametrize("method", ["set_pose", "teleport"])
@pytest.mark.parametrize(
    ("transform", "needle"),
    BAD_TRANSFORMS,
    ids=[f"{i}-{n}" for i, (_, n) in enumerate(BAD_TRANSFORMS)],
)
def test_bad_transforms_are_refused_and_leave_the_pose(sim, method, transform, needle):
    sim.set_pose(transform=_m(move=(0.1, 0.0, 0.0)))
    before = sim.positions.copy()
    with pytest.raises(InputError, match="transform") as info:
        getattr(sim, method)(transform=transform)
    assert needle in str(info.value)
    assert np.array_equal(sim._transform, _m(move=(0.1, 0.0, 0.0)))
    sim.step(1 / 60)  # the roots go where the last good pose put them
    np.testing.assert_allclose(sim.positions[:, 0, 0] - before[:, 0, 0], 0.1, atol=1e-12)


def test_a_rotation_and_a_far_but_sane_translation_are_taken():
    sim = Simulator(_strands())
    turn = _m([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], (1e5, 0.0, 0.0))
    sim.teleport(transform=turn.tolist())  # nested lists of ints and floats
    shape = sim.positions - sim.positions[:, :1]
    np.testing.assert_allclose(
        np.linalg.norm(shape, axis=2),
        np.linalg.norm(Simulator(_strands()).positions - sim.model.rest_roots[:, None], axis=2),
        atol=1e-9,
    )
    assert float(sim.positions[0, 0, 0]) == pytest.approx(1e5)


@settings(max_examples=80, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=16, max_size=16))
@pytest.mark.slow
def test_any_4x4_is_a_rigid_motion_or_an_input_error(entries):
    sim = Simulator(_strands(1, 4))
    m = np.array(entries).reshape(4, 4)
    try:
        sim.set_pose(transform=m)
    except InputError as exc:
        assert "transform" in str(exc)
    else:
        r = sim._transform[:3, :3]
        assert np.abs(r.T @ r - np.eye(3)).max() <= 1e-6 and np.linalg.det(r) > 0
        assert np.abs(sim._transform[:3, 3]).max() <= 1e6
        sim.step(1 / 60)
        assert np.isfinite(sim.positions).all()


@pytest.fixture(scope="module")
def head():
    """The built-in head's groom and 25 of its long guides."""
    from follicle.pipeline import groom_scene
    from follicle.scene import Scene

    groom = groom_scene(Scene())
    return groom.mesh, groom.guides.curves[::12]


@pytest.mark.parametrize(
    ("make", "needle"),
    [
        (lambda v: v[:-1], "shape"),
        (lambda v: v.ravel(), "shape"),
        (lambda v: np.where(np.arange(len(v))[:, None] == 7, np.nan, v), "vertex 7"),
        (lambda v: v.astype(str), "vertices"),
        (lambda v: v + 1e7, "beyond"),
        (lambda v: "v", "vertices"),
    ],
)
@pytest.mark.slow
def test_bad_vertices_are_refused(head, make, needle):
    mesh, curves = head
    sim = Simulator(curves, mesh=mesh, params=SimParams(skin_collision=False))
    for method in (sim.set_pose, sim.teleport):
        with pytest.raises(InputError, match=needle):
            method(vertices=make(np.array(mesh.rest_vertices)))
    assert sim.pose is mesh and mesh.at_rest  # the pose is left as it was


# ------------------------------------------------------------------ blow-ups
def test_a_non_finite_state_is_a_simulation_error_that_says_what_to_soften(sim):
    sim.state.x[1, 5] = np.nan  # as if a substep had gone wrong
    with pytest.raises(SimulationError, match=r"\[sim\]") as info:
        sim.step(1 / 60)
    assert not isinstance(info.value, InputError)
    assert "substep" in str(info.value)


def test_strands_flying_apart_are_a_simulation_error():
    params = SimParams(
        stretch_stiffness=0.0,
        stretch_limit=None,
        bend_stiffness=0.0,
        shape_global=0.0,
        gravity=(0.0, -100.0, 0.0),
        volume_friction=0.0,
    )
    sim = Simulator(_strands(), params=params)
    with pytest.raises(SimulationError, match="strand lengths from its root") as info:
        for _ in range(60):
            sim.step(1 / 60)
    assert "stretch_limit" in str(info.value)


# ------------------------------------------------------------------ the schema's extremes
def _extremes(schema: dict) -> list:
    """The smallest and largest values a JSON-schema number (or tuple of numbers, or
    optional one) accepts; an exclusive minimum is approached by 1e-9."""
    if "anyOf" in schema:
        return [None] + [
            v for s in schema["anyOf"] if s.get("type") != "null" for v in _extremes(s)
        ]
    if "prefixItems" in schema:
        ends = [_extremes(s) for s in schema["prefixItems"]]
        return [tuple(e[k] for e in ends) for k in range(2)]
    if schema.get("type") not in ("number", "integer"):
        return []
    lo = schema.get("minimum", schema.get("exclusiveMinimum", 0) + 1e-9)
    return [lo, schema["maximum"]]


EXTREMES = [
    (name, value)
    for name, prop in SimParams.model_json_schema()["properties"].items()
    for value in _extremes(prop)
]
# refused before anything moves, naming the key: a frame at 24 fps would take more
# substeps than one step() may run; the skin's SDF would have more than 256³ vertices; the
# head would turn about a point a million metres away
REFUSED = {  # the error and what it names
    ("substep", 1e-9): (ResourceError, r"\[sim\]\.substep"),  # 10⁴ substeps a step at most
    ("skin_voxel", 1e-9): (ResourceError, r"\[sim\]\.skin_voxel"),
    ("motion_pivot", (-1e6,) * 3): (InputError, r"\[sim\]\.motion_pivot"),
    ("motion_pivot", (1e6,) * 3): (InputError, r"\[sim\]\.motion_pivot"),
}
# refused by SimParams itself: with the default turbulence (0.5) the wind's peak would
# pass 100 m/s²
PEAK_REFUSED = {("wind", (-100.0,) * 3), ("wind", (100.0,) * 3)}
STRETCH = {"stretch_limit": {None: 0.25, 1.0: 0.25}}  # off or loose: PBD's distance
# constraints alone keep the lengths against collisions
# Collisions come last and push vertices out of the skin; the settle pass after them
# hangs each segment left too long or too short back at its length from its settled
# parent, root to tip, turned along the skin where the push would change its length
# (measured at the extremes, before it: vertices 256 → 16 %, gravity (-100, -100, -100)
# → 35 %, 10 g into the scalp → 32 %, 10 g at the longest substep with one iteration
# and no damping → 2.84×; README: Dynamics)
COMBINED = [  # extremes that only show together
    {"cone_angle": 1e-9, "drag": 1000.0},
    {
        "wind": (0.09, 0.0, -0.09),
        "wind_gust": 100.0,
        "wind_turbulence": 10.0,
        "wind_frequency": 1000.0,
    },  # the wind's peak at its limit, 100 m/s²
    {"substep": 1 / 30, "iterations": 1, "damping": 0.0, "gravity": (100.0, -100.0, 100.0)},
    {"solver": "dftl", "cone_angle": 1e-9, "dftl_damping": 1.0, "gravity": (-100.0,) * 3},
    {
        "integrator": "euler",
        "drag": 1000.0,
        "substep": 1 / 30,
        "motion_amplitude": 180.0,
        "motion_period": 1e-9,
    },
    {
        "stretch_stiffness": 0.0,
        "bend_stiffness": 1.0,
        "bend_scale": 10.0,
        "bend_attenuation": 0.0,
        "shape_local": 1.0,
        "shape_global": 1.0,
    },
]


def test_gusts_and_turbulence_cannot_lift_the_wind_past_its_limit():
    SimParams(wind=(10.0, 0.0, 0.0), wind_gust=4.0, wind_turbulence=1.0)  # peaks at 100
    with pytest.raises(ConfigError, match=r"\[sim\]: .*peaks at 101 m/s²; at most 100"):
        SimParams(wind=(10.1, 0.0, 0.0), wind_gust=4.0, wind_turbulence=1.0)


def test_the_walk_covers_every_numeric_field():
    names = {name for name, _ in EXTREMES}
    numeric = {
        name
        for name, f in SimParams.model_fields.items()
        if "float" in str(f.annotation) or "int" in str(f.annotation)
    }
    assert numeric <= names and len(names) >= 30


def _shake(mesh, curves, settings: dict) -> tuple[float, float]:
    """The first quarter second of the head shaking (its fastest swing) at 24 fps as
    `follicle simulate` runs it: the largest stretch and vertex-to-root distance (in
    strand lengths) seen."""
    p = SimParams(**settings)
    pivot = motion_pivot(mesh, p.motion_pivot)
    sim = Simulator(curves, mesh=mesh, params=p)
    length = sim.model.rest_length.sum(axis=1)
    stretch = reach = 0.0
    for f in range(1, 7):
        sim.set_pose(
            transform=head_motion("shake", f / 24, p.motion_amplitude, p.motion_period, pivot)
        )
        sim.step(1 / 24)
        x = sim.positions
        assert np.isfinite(x).all() and np.isfinite(sim.state.v).all()
        stretch = max(stretch, sim.stats["max_stretch"])
        reach = max(reach, float((np.linalg.norm(x - x[:, :1], axis=2).max(axis=1) / length).max()))
    return stretch, reach


@pytest.mark.parametrize(("name", "value"), EXTREMES, ids=[f"{n}={v}" for n, v in EXTREMES])
@pytest.mark.slow
def test_every_accepted_sim_value_gives_a_stable_simulation(head, name, value):
    mesh, curves = head
    if (name, value) in PEAK_REFUSED:
        with pytest.raises(ConfigError, match=r"\[sim\]: wind × \(1 \+ wind_gust\)"):
            SimParams(**{name: value})
        return
    if (name, value) in REFUSED:
        error, needle = REFUSED[name, value]
        with pytest.raises(error, match=needle):
            _shake(mesh, curves, {name: value})
        return
    stretch, reach = _shake(mesh, curves, {name: value})
    assert reach <= MAX_REACH, f"{name}={value}: reach {reach:.3g}"
    bound = STRETCH.get(name, {}).get(value, MAX_STRETCH)
    assert stretch <= bound, f"{name}={value}: stretch {stretch:.3g}"


@pytest.mark.parametrize("settings", COMBINED, ids=[",".join(c) for c in COMBINED])
def test_combined_extremes_give_a_stable_simulation(head, settings):
    mesh, curves = head
    stretch, reach = _shake(mesh, curves, settings)
    assert reach <= MAX_REACH, f"{settings}: reach {reach:.3g}"
    assert stretch <= MAX_COMBINED_STRETCH, f"{settings}: stretch {stretch:.3g}"


# ------------------------------------------------------------------ the command line
@pytest.fixture(scope="module")
def warmed() -> None:
    warm()


@pytest.mark.parametrize(
    "sim_table",
    ["cone_angle = 1e-9", "drag = 1000.0", "cone_angle = 1e-9\ndrag = 1000.0\nsolver = 'dftl'"],
)
@pytest.mark.slow
def test_cli_simulates_extreme_settings_to_a_finite_unstretched_cache(warmed, tmp_path, sim_table):
    (tmp_path / "s.toml").write_text(f"[groom]\ncount = 50\n[sim]\n{sim_table}\n")
    out = run_cli(
        "simulate", "s.toml", "--motion", "shake", "--frames", 12, "-o", "sim.npz", cwd=tmp_path
    )
    assert out.rc == 0 and not out.timed_out, out.stderr
    x = load_cache(tmp_path / "sim.npz").positions.astype(np.float64)
    assert np.isfinite(x).all()
    seg = np.linalg.norm(np.diff(x, axis=2), axis=3)
    assert np.abs(seg / seg[:1] - 1.0).max() < MAX_STRETCH
    assert np.linalg.norm(x - x[:, :, :1], axis=3).max() < 1.0  # m: the longest guide is 0.33


@pytest.mark.slow
def test_cli_refuses_a_substep_a_frame_cannot_afford_in_one_line(warmed, tmp_path):
    (tmp_path / "s.toml").write_text("[groom]\ncount = 50\n[sim]\nsubstep = 1e-7\n")
    out = run_cli("simulate", "s.toml", "--frames", 48, "-o", "sim.npz", cwd=tmp_path)
    line = assert_cli_refused(out, "[sim].substep", "416,667", "24 fps", "10,000")
    assert "raise" in line and not (tmp_path / "sim.npz").exists()


def test_simulate_scene_refuses_before_growing_anything(monkeypatch):
    from follicle import pipeline
    from follicle.scene import Scene

    def grown(scene):
        raise AssertionError("the groom was grown before the substep was checked")

    monkeypatch.setattr(pipeline, "groom_scene", grown)
    scene = Scene()
    scene = scene.replace(sim=scene.sim.replace(substep=1e-7))
    with pytest.raises(ResourceError, match="416,667 substeps per frame at 24 fps"):
        pipeline.simulate_scene(scene, frames=2, fps=24)
