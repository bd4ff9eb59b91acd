"""Guide-strand dynamics: the quality numbers of the dynamics issue (Simulator, Solver)."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.curves import HairCurves
from follicle.errors import InputError
from follicle.mesh.skin import SkinMesh
from follicle.scene import ColliderParams, SimParams
from follicle.sim import Simulator


def _strands(count: int = 3, n: int = 24, length: float = 0.3, up: bool = False) -> HairCurves:
    """``count`` straight strands of ``length`` m, horizontal along +x (or up at 45°)."""
    pts = np.zeros((count, n, 3))
    s = np.linspace(0.0, length, n)
    if up:
        pts[:, :, 0] = pts[:, :, 1] = s / np.sqrt(2.0)
    else:
        pts[:, :, 0] = s
    pts[:, :, 2] = np.arange(count)[:, None] * 0.05
    return HairCurves.from_array(pts)


def _run(sim: Simulator, seconds: float, rate: float = 60.0) -> None:
    for _ in range(round(seconds * rate)):
        sim.step(1.0 / rate)


@pytest.mark.parametrize(("solver", "bound"), [("pbd", 1e-4), ("dftl", 1e-6)])
def test_stretch_after_every_step_is_within_the_bound(solver, bound):
    params = SimParams(solver=solver, bend_stiffness=0.0, shape_global=0.0)
    sim = Simulator(_strands(), params=params)
    worst = 0.0
    for _ in range(90):  # a free fall from horizontal: the hardest swing
        sim.step(1 / 60)
        worst = max(worst, sim.stats["max_stretch"])
    assert worst <= bound
    assert sim.positions[0, -1, 1] < -0.2  # it did swing down


@pytest.mark.parametrize("solver", ["pbd", "dftl"])
def test_pinned_strand_settles_with_decaying_energy(solver):
    sim = Simulator(_strands(), params=SimParams(solver=solver, damping=1.0))
    energy = []
    for _ in range(8):
        _run(sim, 0.5)
        energy.append(sim.stats["kinetic_energy"])
    assert energy[-1] < 0.05 * max(energy)
    assert energy[-1] < energy[-3] < energy[1]
    np.testing.assert_allclose(sim.positions[:, 0], _strands().points[::24], atol=1e-6)


def test_caller_frame_rate_does_not_change_the_motion():
    length = 0.3
    a = Simulator(_strands(length=length))
    b = Simulator(_strands(length=length))
    _run(a, 2.0, 60.0)
    _run(b, 2.0, 120.0)
    gap = np.linalg.norm(a.positions - b.positions, axis=2).max()
    assert gap <= 0.02 * length


@pytest.mark.slow
def test_stiffness_gives_the_same_sag_at_any_iteration_count():
    tips = []
    for iterations in (2, 4, 8):
        params = SimParams(solver="dftl", iterations=iterations, bend_stiffness=0.6, damping=4.0)
        sim = Simulator(_strands(), params=params)
        _run(sim, 3.0)
        tips.append(-float(sim.positions[0, -1, 1]))
    assert min(tips) > 0.02  # it sags ...
    assert max(tips) - min(tips) <= 0.05 * np.mean(tips)  # ... by the same amount


def test_bending_holds_a_strand_up_and_attenuation_lets_the_tip_fall():
    sags = {}
    for att in (0.0, 4.0):
        params = SimParams(solver="dftl", bend_stiffness=0.9, bend_attenuation=att, damping=4.0)
        sim = Simulator(_strands(), params=params)
        _run(sim, 2.0)
        sags[att] = -float(sim.positions[0, -1, 1])
    free = Simulator(_strands(), params=SimParams(solver="dftl", bend_stiffness=0.0, damping=4.0))
    _run(free, 2.0)
    assert sags[0.0] < sags[4.0] < -float(free.positions[0, -1, 1])


def test_strands_rest_on_a_sphere_outside_the_margin():
    ball = ColliderParams(kind="sphere", centre=(0.1, -0.105, 0.05), radius=0.1)
    params = SimParams(colliders=[ball], collision_margin=0.002)
    sim = Simulator(_strands(), params=params)
    _run(sim, 2.0)
    d = np.linalg.norm(sim.positions - np.array(ball.centre, np.float32), axis=2)
    assert d.min() >= ball.radius + 0.002 - 1e-5
    assert d.min() <= ball.radius + 0.004  # it lies on the ball, not beside it
    assert sim.stats["max_penetration"] == 0.0


def test_head_turn_at_two_metres_per_second_stays_out_of_the_head():
    # strands hang from the top of a head sphere of radius 0.1 that turns about y
    n = 20
    angles = np.linspace(-1.2, 1.2, 9)
    roots = np.stack([0.1 * np.sin(angles), 0.1 * np.cos(angles), np.zeros(9)], 1)
    out = roots / np.linalg.norm(roots, axis=1, keepdims=True)
    pts = roots[:, None] + out[:, None] * np.linspace(0, 0.25, n)[None, :, None]
    head = ColliderParams(kind="sphere", centre=(0, 0, 0), radius=0.095, follow=True)
    sim = Simulator(HairCurves.from_array(pts), params=SimParams(colliders=[head]))
    _run(sim, 1.0)
    rate = 120
    omega = 2.0 / 0.1  # 2 m/s at the head's surface
    worst = 0.0
    for k in range(1, rate // 2):
        a = omega * k / rate
        c, s = np.cos(a), np.sin(a)
        sim.set_pose(transform=[[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1]])
        sim.step(1 / rate)
        d = np.linalg.norm(sim.positions[:, 1:], axis=2)
        worst = max(worst, float((head.radius - d).max()))
    assert worst <= 0.0  # no vertex deeper than the surface (the margin is kept)


@pytest.mark.parametrize("speed", [1.0, 4.0])
def test_a_collider_sweeping_into_lagging_tips_pushes_them_out(speed):
    # strands hang from y = 0; a ball on the head (it follows the head) waits beside the
    # tips; the head moves towards them at ``speed`` m/s: the roots follow, the tips lag,
    # and the ball reaches tips found clear of it a few substeps earlier. The solver must
    # count the ball's own move against that clearance (without it: 10–40 mm deep).
    n = 16
    pts = np.zeros((5, n, 3))
    pts[:, :, 1] = -np.linspace(0.0, 0.3, n)
    pts[:, :, 2] = np.arange(5)[:, None] * 0.01
    ball = ColliderParams(kind="sphere", centre=(-0.15, -0.27, 0.02), radius=0.06, follow=True)
    sim = Simulator(
        HairCurves.from_array(pts), params=SimParams(colliders=[ball], collision_margin=0.002)
    )
    _run(sim, 0.5, rate=120)
    for k in range(1, 30):
        move = np.eye(4)
        move[0, 3] = speed * k / 120
        sim.set_pose(transform=move)
        sim.step(1 / 120)
        d = np.linalg.norm(sim.positions - (np.array(ball.centre) + move[:3, 3]), axis=2)
        assert d.min() >= ball.radius + 0.002 - 1e-6, k


@pytest.mark.slow
def test_global_shape_keeps_a_standing_style_under_gravity():
    style = _strands(up=True, length=0.15)
    rest = Simulator(style).positions.copy()
    kept = Simulator(style, params=SimParams(shape_global=0.5, shape_local=0.5))
    # loose: no bending and no hold (which keeps styled strands up by default)
    loose = Simulator(style, params=SimParams(bend_stiffness=0.0, shape_hold=0.0))
    for sim in (kept, loose):
        _run(sim, 2.0)
    rms = {
        k: float(np.sqrt(np.mean(np.sum((s.positions - rest) ** 2, axis=2))))
        for k, s in (("kept", kept), ("loose", loose))
    }
    assert rms["kept"] < 0.01
    assert rms["loose"] > 0.04


def test_style_returns_after_a_head_shake():
    style = _strands(up=True, length=0.15)
    sim = Simulator(style, params=SimParams(shape_global=0.5, shape_local=0.5))
    rest = sim.positions.copy()
    for k in range(60):  # shake ±0.4 rad at 2 Hz for 0.5 s
        a = 0.4 * np.sin(2 * np.pi * 2 * k / 120)
        c, s = np.cos(a), np.sin(a)
        sim.set_pose(transform=[[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
        sim.step(1 / 120)
    sim.set_pose(transform=np.eye(4))
    _run(sim, 2.0)
    rms = float(np.sqrt(np.mean(np.sum((sim.positions - rest) ** 2, axis=2))))
    assert rms < 0.01


def test_wind_blows_strands_downwind_and_teleport_keeps_the_shape():
    params = SimParams(wind=(0.0, 0.0, 30.0), gravity=(0, 0, 0), bend_stiffness=0.0)
    sim = Simulator(_strands(), params=params)
    _run(sim, 1.0)
    assert sim.positions[:, -1, 2].mean() > 0.1 + sim.positions[:, 0, 2].mean()
    before = sim.positions - sim.positions[:, :1]
    sim.teleport(transform=[[1, 0, 0, 10], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    np.testing.assert_allclose(sim.positions - sim.positions[:, :1], before, atol=1e-5)
    assert abs(float(sim.positions[0, 0, 0]) - 10.0) < 1e-5


@pytest.mark.slow
def test_adversarial_settings_never_give_nan():
    pts = np.zeros((3, 12, 3))
    pts[:, :, 0] = np.linspace(0, 0.2, 12)
    pts[:, 5] = pts[:, 4]  # a zero-length segment in the input
    params = SimParams(
        wind=(25.0, 0.0, 0.0),
        wind_turbulence=3.0,
        drag=5.0,  # peak: 100
        substep=1 / 30,
        colliders=[ColliderParams(radius=0.05, centre=(0.1, -0.1, 0.0))],
    )
    sim = Simulator(HairCurves.from_array(pts), params=params)
    for k in range(10_000):
        sim.step(1 / 15)
        if k == 5000:
            sim.teleport(transform=[[1, 0, 0, 10], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
        if k == 7000:
            sim.set_pose(transform=np.eye(4))  # the head jumps back 10 m in one step
    assert np.isfinite(sim.positions).all() and np.isfinite(sim.state.v).all()
    assert sim.stats["max_stretch"] < 0.01


@pytest.mark.parametrize(
    ("call", "needle"),
    [
        (lambda s: s.step(-1.0), "dt"),
        (lambda s: s.step(float("nan")), "dt"),
        (lambda s: s.set_pose(transform=np.eye(3)), "transform"),
        (lambda s: s.set_pose(transform=np.diag([2.0, 2.0, 2.0, 1.0])), "rigid"),
        (lambda s: s.set_pose(vertices=np.zeros((3, 3))), "mesh"),
        (lambda s: s.set_pose(), "exactly one"),
    ],
)
def test_bad_calls_say_what_is_wrong(call, needle):
    sim = Simulator(_strands())
    with pytest.raises(InputError, match=needle):
        call(sim)


def test_zero_length_guide_is_refused():
    with pytest.raises(InputError, match="zero length"):
        Simulator(HairCurves.from_array(np.zeros((1, 4, 3))))


# --------------------------------------------------------------- skin, grooms, gusts
@pytest.fixture(scope="module")
def head_groom():
    """The built-in head's groom: its 300 long guides."""
    from follicle.pipeline import groom_scene
    from follicle.scene import Scene

    return groom_scene(Scene(mesh={"path": "builtin:head"}))


@pytest.mark.slow
def test_a_fast_head_turn_keeps_hair_out_of_the_skin_mesh(head_groom):
    mesh = head_groom.mesh
    sim = Simulator(head_groom.guides, params=SimParams(iterations=4))
    assert sim.sdf is not None
    _run(sim, 0.5)  # hair settles onto the head
    lo, hi = mesh.bounds("rest")
    pivot = np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])
    reach = float(np.linalg.norm(sim.positions[:, 0] - pivot, axis=1).max())
    omega = 2.0 / reach  # the fastest root moves at 2 m/s
    worst, rate = 0.0, 120
    for k in range(1, rate // 2):
        a = omega * k / rate
        c, s = np.cos(a), np.sin(a)
        turn = np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1.0]])
        turn[:3, 3] = pivot - turn[:3, :3] @ pivot
        sim.set_pose(transform=turn)
        sim.step(1 / rate)
        worst = max(worst, sim.stats["max_penetration"])
    assert mesh.at_rest and not sim.pose.at_rest  # the simulator posed its own value
    assert a > 0.9  # it turned by more than 50°
    assert worst <= sim.params.collision_margin  # no vertex deeper than the margin


def test_groomed_vertices_inside_the_skin_at_rest_keep_their_depth_as_margin():
    from follicle.mesh.head import builtin_head

    head = builtin_head()
    lo, hi = head.bounds("rest")
    top = np.array([(lo[0] + hi[0]) / 2, hi[1], (lo[2] + hi[2]) / 2])
    pts = top + np.linspace(0, 0.05, 8)[:, None] * [0.0, -1.0, 0.0]  # into the head
    sim = Simulator(HairCurves.from_array(pts[None]), head)
    rest = sim.positions.copy()
    assert (sim.solver.rest_clearance[0, 1:] < -0.005).all()  # groomed under the scalp
    sim.params = sim.solver.params = SimParams(gravity=(0, 0, 0))
    _run(sim, 0.5)
    np.testing.assert_allclose(sim.positions, rest, atol=1e-6)  # not pushed, not stretched


@pytest.mark.slow
def test_hairs_follow_the_simulated_guides(head_groom):
    sim = Simulator(head_groom.guides)  # the guides' own vertex count: exact transport
    grown = head_groom.generate(count=2000)
    at_rest = head_groom.follow(sim, count=2000)  # at rest: the same hairs
    np.testing.assert_array_equal(at_rest.offsets, grown.offsets)
    np.testing.assert_allclose(at_rest.points, grown.points, atol=1e-6)  # float32 rounding
    c, s = np.cos(0.6), np.sin(0.6)
    turn = np.array([[c, 0, s, 0.1], [0, 1, 0, 0.2], [-s, 0, c, 0], [0, 0, 0, 1.0]])
    sim.teleport(transform=turn)
    moved = head_groom.follow(sim.positions.copy(), count=2000, pose=sim.pose)
    posed = head_groom.generate(count=2000, pose=sim.pose)
    np.testing.assert_allclose(moved.points, posed.points, atol=1e-5)
    _run(sim, 0.5)  # the guides swing: hairs near a guide's root follow that guide
    follow = head_groom.follow(sim, count=2000)  # on the simulator's own pose
    assert np.isfinite(follow.points).all() and follow.curve_count == grown.curve_count
    assert np.abs(follow.points - moved.points).max() > 0.01  # the hairs did move
    with pytest.raises(InputError, match="positions"):
        head_groom.follow(np.zeros((3, 24, 3)))
    other = SkinMesh(head_groom.mesh.rest_vertices * 2.0, head_groom.mesh.faces, name="twice")
    with pytest.raises(InputError, match="pose: expected the groom's mesh 'head' in some pose"):
        head_groom.generate(count=10, pose=other)


@pytest.mark.slow
def test_frames_follow_on_threads_as_one_by_one(head_groom):
    """follow changes nothing of the groom (no guides swapped in and out), so frames of
    a simulation grow on several threads at once exactly as one after another."""
    from concurrent.futures import ThreadPoolExecutor

    sim = Simulator(head_groom.guides)
    frames = []
    for k in range(4):
        a = 0.15 * k
        turn = np.array(
            [
                [np.cos(a), 0, np.sin(a), 0],
                [0, 1, 0, 0],
                [-np.sin(a), 0, np.cos(a), 0],
                [0, 0, 0, 1],
            ]
        )
        sim.set_pose(transform=turn)
        sim.step(1 / 24)
        frames.append((sim.positions.copy(), sim.pose))

    def grow(frame):
        return head_groom.follow(frame[0], count=1500, pose=frame[1])

    alone = [grow(f) for f in frames]
    with ThreadPoolExecutor(4) as pool:
        together = list(pool.map(grow, frames * 2))
    for k, hair in enumerate(together):
        np.testing.assert_array_equal(hair.points, alone[k % 4].points)
    assert not np.array_equal(alone[0].points, alone[3].points)  # the frames differ


def test_wind_gusts_vary_between_steady_and_the_gust_strength():
    params = SimParams(wind=(2.0, 0.0, 0.0), wind_gust=3.0, wind_gust_period=0.5)
    sim = Simulator(_strands(), params=params)
    speeds = np.array([sim.wind(t)[0] for t in np.linspace(0.0, 20.0, 2001)])
    assert speeds.min() >= 2.0 and speeds.max() <= 8.0
    assert speeds.max() - speeds.min() > 3.0  # real gusts …
    assert np.abs(np.diff(speeds)).max() < 0.5  # … that rise and fall smoothly
    steady = Simulator(_strands(), params=SimParams(wind=(2.0, 0.0, 0.0)))
    assert {float(steady.wind(t)[0]) for t in (0.0, 1.3, 7.7)} == {2.0}


def test_changed_params_apply_from_the_next_step_and_in_place_changes_are_refused():
    """The stale-physics fault: a params change mid-run must take effect. Gravity turned
    upwards mid-fall lifts the tips on the next steps; vertices rebuild the model and put
    the hair at rest; assigning a key in place says how to change it."""
    from follicle.errors import ConfigError

    sim = Simulator(_strands(1), params=SimParams(bend_stiffness=0.0, shape_local=0.0))
    _run(sim, 0.25)
    falling = sim.positions[0, -1, 1]
    assert falling < -0.05  # the tip has dropped under gravity
    with pytest.raises(
        ConfigError,
        match=r"SimParams.gravity: settings are values .*replace\("
        r"gravity=\.\.\.\), and give it to Simulator.params",
    ):
        sim.params.gravity = (0.0, 9.81, 0.0)
    sim.params = sim.params.replace(gravity=(0.0, 9.81, 0.0), damping=5.0)
    _run(sim, 0.5)
    assert sim.positions[0, -1, 1] > falling + 0.05  # now it rises
    assert sim.state.time > 0.7  # the same run, not a new one
    sim.params = sim.params.replace(vertices=12)  # a model key: rebuilt, at rest
    assert sim.positions.shape == (1, 12, 3) and sim.state.time == 0.0
    np.testing.assert_allclose(sim.positions[0, :, 1], 0.0, atol=1e-9)
    with pytest.raises(InputError, match="params: expected SimParams"):
        sim.params = {"gravity": (0, 0, 0)}
