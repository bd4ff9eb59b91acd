"""The dynamics benchmark's NumPy baseline (benchmarks/sim_baseline.py) is right on its own."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from benchmarks.sim_baseline import BaselinePBD, _SDFSampler, _VolumeGrid

from follicle.curves import HairCurves
from follicle.mesh.sdf import SDF
from follicle.scene import SimParams
from follicle.sim import Simulator
from follicle.sim.model import Model
from follicle.sim.volume import apply_volume

DT = 1 / 120


@pytest.fixture(scope="module")
def ball_sdf() -> SDF:
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.1)
    return SDF.from_mesh(ball.vertices, ball.faces)


def _line(count: int, n: int, length: float = 0.3) -> np.ndarray:
    """``count`` straight strands of ``length`` m along +x, 5 cm apart in z: (S, N, 3)."""
    pts = np.zeros((count, n, 3))
    pts[:, :, 0] = np.linspace(0.0, length, n)
    pts[:, :, 2] = np.arange(count)[:, None] * 0.05
    return pts


def _model(pts: np.ndarray) -> Model:
    return Model.build(HairCurves.from_array(pts), None, None)


def _rest(model: Model) -> np.ndarray:
    """The model's rest positions (S, N, 3) float64: the roots exactly where they are pinned."""
    return model.rest_roots[:, None] + model.rest_local.astype(np.float64)


def _segments(x: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.diff(x, axis=1), axis=2)


def test_distance_constraints_bring_a_stretched_strand_back_to_rest_lengths():
    pts = _line(2, 6)
    model = _model(pts)
    errors = []
    for iterations in (20, 200):
        params = SimParams(
            iterations=iterations, gravity=(0, 0, 0), bend_stiffness=0.0, stretch_limit=None
        )
        x = pts.copy()
        x[:, :, 0] *= 1.3  # stretched 30 %, root in place
        v = np.zeros_like(x)
        BaselinePBD(model, params).substep(x, v, model.rest_roots, model.rest_frames, DT)
        errors.append(np.abs(_segments(x) / model.rest_length - 1.0).max())
        np.testing.assert_array_equal(x[:, 0], model.rest_roots)
    assert errors[1] < 1e-7 < 1e-3 < errors[0]  # PBD converges like diffusion: slowly


def test_a_pinned_strand_falls_under_gravity_and_its_root_stays():
    pts = _line(3, 16)
    model = _model(pts)
    params = SimParams(shape_global=0.0)  # free fall; strain limit 1e-4: no segment longer
    # than (1 + 0.5e-4) × rest
    solver = BaselinePBD(model, params)
    x, v = pts.copy(), np.zeros_like(pts)
    tips = []
    for _ in range(30):
        solver.substep(x, v, model.rest_roots, model.rest_frames, DT)
        tips.append(x[0, -1, 1])
        assert (_segments(x) <= (1 + 0.5e-4 + 1e-12) * model.rest_length.astype(float)).all()
    assert tips[-1] < -0.05 and (np.diff(tips) < 0).all()  # falling, faster and faster
    np.testing.assert_array_equal(x[:, 0], model.rest_roots)
    np.testing.assert_array_equal(v[:, 0], 0.0)
    assert set(solver.times) == {"integrate", "constraints", "collision", "strain", "volume"}


def test_the_baseline_matches_the_numba_solver():
    pts = _line(4, 12)
    pts[:, :, 1] = 0.1 * np.sin(7.0 * pts[:, :, 0])  # curled: local shape has work to do
    params = SimParams(
        iterations=4,
        bend_stiffness=0.3,
        shape_local=0.2,
        shape_global=0.1,
        shape_global_range=(0.2, 0.8),
        shape_hold=0.0,  # the baseline has no hold (issue: styles that hold)
        volume_friction=0.0,
    )
    sim = Simulator(HairCurves.from_array(pts), params=params)
    model = sim.model
    x, v = sim.state.x.copy(), sim.state.v.copy()
    baseline = BaselinePBD(model, params)
    for _ in range(5):
        sim.step(params.substep)
        baseline.substep(x, v, model.rest_roots, model.rest_frames, params.substep)
    assert np.abs(sim.state.x - pts).max() > 0.01  # it moved
    np.testing.assert_allclose(x, sim.state.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(v, sim.state.v, rtol=0, atol=1e-9)


def test_sdf_collision_pushes_a_point_inside_the_sphere_out_to_the_margin(ball_sdf):
    pts = np.array([[[0.3, 0.0, 0.0], [0.05, 0.01, 0.0]]])  # the tip 5 cm deep in the ball
    model = _model(pts)
    margin = 0.004
    params = SimParams(
        iterations=2,
        gravity=(0, 0, 0),
        stretch_stiffness=0.0,
        stretch_limit=None,
        bend_stiffness=0.0,
        collision_margin=margin,
    )
    solver = BaselinePBD(model, params, sdf=ball_sdf)
    x, v = pts.copy(), np.zeros_like(pts)
    solver.substep(x, v, model.rest_roots, model.rest_frames, DT)
    tip = x[0, 1]
    assert ball_sdf.distance(tip[None])[0] == pytest.approx(margin, abs=5e-4)
    assert np.linalg.norm(tip) == pytest.approx(0.1 + margin, abs=2e-3)
    assert tip @ pts[0, 1] / np.linalg.norm(tip) / np.linalg.norm(pts[0, 1]) > 0.99  # ~radial
    normal = ball_sdf.distance_and_normal(tip[None])[1][0]
    assert v[0, 1] @ normal > 0  # the push leaves an outward speed, never an inward one


def test_sdf_sampler_reproduces_follicle_sdf_inside_and_outside_the_grid(ball_sdf):
    turn = trimesh.transformations.rotation_matrix(0.7, [1, 2, 3], [0.01, 0.0, 0.02])
    for sdf in (ball_sdf, ball_sdf.with_transform(turn)):
        pts = np.random.default_rng(1).uniform(-0.3, 0.3, (5000, 3))  # the box ends at ±0.12
        sampler = _SDFSampler(sdf, len(pts))
        dist = sampler.distances(np.ascontiguousarray(pts.T))
        normal = sampler.normals(np.arange(len(pts)))
        want_dist, want_normal = sdf.distance_and_normal(pts)
        # follicle subtracts corner values in float32, the baseline in float64
        np.testing.assert_allclose(dist, want_dist, rtol=0, atol=1e-9)
        np.testing.assert_allclose(normal.T, want_normal, rtol=0, atol=1e-6)


def _pair() -> tuple[Model, np.ndarray, np.ndarray, SimParams]:
    """Two 2-vertex strands whose tips share a point and move apart along ±y."""
    pts = np.array([[[-0.1, 0.0, 0.0], [0.0, 0.0, 0.0]], [[0.1, 0.0, 0.0], [0.0, 0.0, 0.0]]])
    v = np.zeros_like(pts)
    v[0, 1, 1], v[1, 1, 1] = 1.0, -1.0
    params = SimParams(
        iterations=1,
        gravity=(0, 0, 0),
        damping=0.0,
        stretch_stiffness=0.0,
        stretch_limit=None,
        bend_stiffness=0.0,
    )
    model = _model(pts)
    return model, _rest(model), v, params


@pytest.mark.parametrize("friction", [0.5, 1.0])
def test_volume_friction_pulls_the_velocities_of_neighbours_together(friction):
    model, pts, v, params = _pair()
    gaps = []
    for volume in ((0.0, 0.0), (friction, 0.0)):
        x, vel = pts.copy(), v.copy()
        BaselinePBD(model, params, volume=volume).substep(
            x, vel, model.rest_roots, model.rest_frames, 1e-4
        )
        gaps.append(np.linalg.norm(vel[0, 1] - vel[1, 1]))
        np.testing.assert_array_equal(vel[:, 0], 0.0)  # pinned roots splat but keep theirs
    assert gaps[0] == pytest.approx(2.0)
    assert gaps[1] <= (1.0 - friction) * gaps[0] + 0.05


def test_volume_repulsion_pushes_hair_away_from_a_dense_tuft():
    rng = np.random.default_rng(0)
    count = 101
    angle = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
    pts = np.zeros((count, 2, 3))
    pts[:, 0, 0], pts[:, 0, 1] = 0.1 * np.cos(angle), 0.1 * np.sin(angle)  # roots on a ring
    pts[:-1, 1] = rng.uniform(-0.0015, 0.0015, (count - 1, 3))  # 100 tips in a 3 mm tuft …
    pts[-1, 1] = (0.008, 0.0, 0.0)  # … and one 8 mm (1.3 voxels) beside it
    model = _model(pts)
    params = SimParams(
        iterations=1,
        gravity=(0, 0, 0),
        stretch_stiffness=0.0,
        stretch_limit=None,
        bend_stiffness=0.0,
    )
    x, v = _rest(model), np.zeros_like(pts)
    BaselinePBD(model, params, volume=(0.0, 0.5)).substep(
        x, v, model.rest_roots, model.rest_frames, DT
    )
    voxel = np.ptp(x.reshape(-1, 3), axis=0).max() / 32  # the grid spans the ring
    push = 0.5 * voxel / DT  # half a voxel per substep
    np.testing.assert_allclose(np.linalg.norm(v[:, 1], axis=1), push, rtol=1e-9)
    assert v[-1, 1, 0] > 0.9 * push  # the lone tip is pushed away from the tuft
    outward = np.einsum("sk,sk->s", v[:-1, 1], x[:-1, 1] - x[:-1, 1].mean(axis=0))
    assert (outward > 0).mean() > 0.8  # the tuft spreads out


@pytest.mark.slow
def test_volume_grid_reproduces_follicle_apply_volume():
    rng = np.random.default_rng(3)
    x = (rng.normal(size=(200, 12, 3)) * 0.1).astype(np.float32)
    v = rng.normal(size=(200, 12, 3)).astype(np.float32)
    inv_mass = np.ones((200, 12), np.float32)
    inv_mass[:, 0] = 0.0
    for friction, repulsion in ((0.3, 0.0), (0.4, 0.2)):
        want = v.copy()
        apply_volume(x, want, 0.01, friction, repulsion, inv_mass=inv_mass)
        got = np.ascontiguousarray(v.astype(np.float64).transpose(2, 1, 0))
        free = (inv_mass > 0).T.astype(np.float64)
        at = np.ascontiguousarray(x.astype(np.float64).transpose(2, 1, 0))
        _VolumeGrid(x.size // 3).apply(at, got, free, 0.01, friction, repulsion)
        np.testing.assert_allclose(got.transpose(2, 1, 0), want, rtol=0, atol=1e-5)
