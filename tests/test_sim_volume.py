"""Voxel-grid hair interaction (Almeida 2014 §3.2, Le Muzic 2012 §5.1.3): splat, blur,
friction, repulsion."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from follicle.errors import InputError
from follicle.sim.volume import GridSpec, VolumeGrid, _bounds, apply_volume, grid_for, volume_step

# 5 × 5 × 5 vertices, h = 0.5, vertex (i, j, k) at 0.5·(i, j, k)
SMALL = GridSpec(origin=np.zeros(3), voxel=0.5, shape=(5, 5, 5))


def one(p: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """A single particle at ``p`` at rest, as (1, 1, 3) float32 arrays."""
    return np.array([[p]], dtype=np.float32), np.zeros((1, 1, 3), np.float32)


def cloud(rng: np.random.Generator, s: int, n: int, lo: float, hi: float) -> np.ndarray:
    return rng.uniform(lo, hi, size=(s, n, 3)).astype(np.float32)


def reference(x: np.ndarray, v: np.ndarray, spec: GridSpec) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 3.2 and the numerator of eq. 3.3 written out with np.add.at (no blur)."""
    p = x.reshape(-1, 3).astype(np.float64)
    f = (p - spec.origin) / spec.voxel
    base = np.floor(f).astype(np.int64)
    t = f - base
    dens = np.zeros(spec.shape)
    mom = np.zeros(spec.shape + (3,))
    for corner in np.ndindex(2, 2, 2):
        d = np.array(corner)
        w = np.prod(np.where(d == 1, t, 1 - t), axis=1)
        idx = base + d
        ok = np.all((idx >= 0) & (idx < np.array(spec.shape)), axis=1)
        np.add.at(dens, tuple(idx[ok].T), w[ok])
        np.add.at(mom, tuple(idx[ok].T), w[ok, None] * v.reshape(-1, 3)[ok])
    return dens, mom


# --- density and velocity (eq. 3.2, 3.3, box blur) ------------------------------------


def test_particle_on_a_vertex_gives_density_one_there_only():
    grid = VolumeGrid.splat(*one((1.0, 0.5, 1.5)), spec=SMALL, blur_passes=0)
    expected = np.zeros(SMALL.shape)
    expected[2, 1, 3] = 1.0
    np.testing.assert_array_equal(grid.density, expected)


def test_particle_halfway_along_x_splits_one_half_each():
    grid = VolumeGrid.splat(*one((0.75, 0.5, 1.5)), spec=SMALL, blur_passes=0)
    expected = np.zeros(SMALL.shape)
    expected[1, 1, 3] = expected[2, 1, 3] = 0.5
    np.testing.assert_array_equal(grid.density, expected)


def test_splat_matches_the_tent_sums_and_is_a_partition_of_unity():
    rng = np.random.default_rng(1)
    x = cloud(rng, 37, 11, -0.2, 0.3)
    v = rng.normal(size=x.shape).astype(np.float32)
    grid = VolumeGrid.splat(x, v, blur_passes=0)
    dens, mom = reference(x, v, grid.spec)
    np.testing.assert_allclose(grid.density, dens, rtol=0, atol=1e-12)
    np.testing.assert_allclose(grid.density.sum(), x.shape[0] * x.shape[1], rtol=1e-12)
    # sums are fixed point (see follicle.sim.volume): each of a vertex's at most
    # S·N contributions is rounded by at most half a unit, 2⁻⁴¹ in weight, 2⁻³⁷ in momentum
    filled = dens > 1e-12
    np.testing.assert_allclose(
        grid.velocity[filled] * grid.density[filled, None],
        mom[filled],
        rtol=0,
        atol=x.shape[0] * x.shape[1] * 2.0**-37,
    )
    solid = dens > 0.1  # there V = momentum / D keeps 1e-9
    np.testing.assert_allclose(grid.velocity[solid], mom[solid] / dens[solid, None], atol=1e-9)
    assert not grid.velocity[~filled].any()


def test_blur_is_the_clamped_3x3x3_mean():
    """Interior vertex: 27 neighbours; corner vertex (0,0,0): 8; edge-face mixes: 12."""
    inner = VolumeGrid.splat(*one((1.0, 1.0, 1.0)), spec=SMALL, blur_passes=1).density
    expected = np.zeros(SMALL.shape)
    expected[1:4, 1:4, 1:4] = 1 / 27
    np.testing.assert_allclose(inner, expected, rtol=1e-15, atol=0)

    corner = VolumeGrid.splat(*one((0.0, 0.0, 0.0)), spec=SMALL, blur_passes=1).density
    assert corner[0, 0, 0] == pytest.approx(1 / 8, rel=1e-15)  # its 2 × 2 × 2 neighbourhood
    assert corner[1, 0, 0] == pytest.approx(1 / 12, rel=1e-15)  # 3 × 2 × 2
    assert corner[1, 1, 1] == pytest.approx(1 / 27, rel=1e-15)
    assert corner[2:].sum() == 0


def test_blur_preserves_the_total_away_from_the_border():
    """Mass two or more vertices from the border stays in the grid: the sum is kept."""
    rng = np.random.default_rng(2)
    spec = GridSpec(origin=np.zeros(3), voxel=0.1, shape=(12, 12, 12))
    x = cloud(rng, 50, 8, 0.4, 0.7)  # splats onto vertices 4 … 7
    grid = VolumeGrid.splat(x, np.zeros_like(x), spec=spec, blur_passes=2)
    np.testing.assert_allclose(grid.density.sum(), 400, rtol=1e-12)
    assert grid.density[[0, -1]].sum() == 0  # two passes reach vertices 2 … 9 only


@pytest.mark.parametrize("blur", [1, 3])
def test_fitted_grid_leaves_room_for_the_blur(blur):
    """The margin grows with the passes: the blurred density still sums to the count."""
    rng = np.random.default_rng(15)
    x = rng.normal(size=(30, 7, 3)).astype(np.float32)
    grid = VolumeGrid.splat(x, np.zeros_like(x), blur_passes=blur)
    np.testing.assert_allclose(grid.density.sum(), 210, rtol=1e-12)
    d = grid.density
    assert d[0].sum() == d[-1].sum() == d[:, 0].sum() == d[:, :, -1].sum() == 0


@pytest.mark.parametrize("blur", [0, 2])
def test_uniform_velocity_is_sampled_back_exactly(blur):
    rng = np.random.default_rng(3)
    x = cloud(rng, 400, 10, 0.0, 1.0)
    u = np.array([0.3, -1.25, 2.0], np.float32)
    v = np.broadcast_to(u, x.shape).copy()
    grid = VolumeGrid.splat(x, v, spec=grid_for(x, resolution=8), blur_passes=blur)
    inside = rng.uniform(0.2, 0.8, size=(500, 3))  # every cell here holds particles
    for pts in (x.reshape(-1, 3), inside):
        want = np.broadcast_to(u, pts.shape)
        np.testing.assert_allclose(grid.sample_velocity(pts), want, rtol=0, atol=1e-6)
    far = np.array([[5.0, 5.0, 5.0], [-3.0, 0.5, 0.5]])
    assert not grid.sample_velocity(far).any() and not grid.sample_density(far).any()


def test_gradient_is_the_central_difference_of_the_density():
    """Eq. 3.7 with r = h on the interpolated density, and it points into the cluster."""
    rng = np.random.default_rng(4)
    x = rng.normal(scale=0.1, size=(200, 5, 3)).astype(np.float32)
    grid = VolumeGrid.splat(x, np.zeros_like(x), blur_passes=1)
    h = grid.spec.voxel
    pts = rng.uniform(-0.2, 0.2, size=(300, 3))
    steps = [grid.sample_density(pts + h * e) - grid.sample_density(pts - h * e) for e in np.eye(3)]
    expected = np.stack(steps, axis=1) / (2 * h)
    np.testing.assert_allclose(grid.density_gradient(pts), expected, rtol=1e-9, atol=1e-9)
    ring = np.array([[0.25, 0, 0], [0, -0.25, 0], [0, 0, 0.25]])
    inward = np.einsum("ij,ij->i", grid.density_gradient(ring), -ring)
    assert (inward > 0).all()


# --- friction and repulsion (eq. 3.4 – 3.7) --------------------------------------------


def test_friction_one_replaces_v_by_the_grid_velocity():
    rng = np.random.default_rng(5)
    x = cloud(rng, 60, 8, 0.0, 0.5)
    v0 = rng.normal(size=x.shape).astype(np.float32)
    v = v0.copy()
    grid = apply_volume(x, v, dt=0.01, friction=1.0, repulsion=0.0)
    want = grid.sample_velocity(x[:, 1:].reshape(-1, 3)).reshape(60, 7, 3)
    np.testing.assert_allclose(v[:, 1:], want, rtol=1e-6, atol=1e-6)
    assert np.abs(v[:, 1:] - v0[:, 1:]).max() > 0.1
    np.testing.assert_array_equal(v[:, 0], v0[:, 0])  # roots pinned by default


def test_zero_friction_and_repulsion_leave_v_bit_for_bit():
    rng = np.random.default_rng(6)
    x = cloud(rng, 30, 6, 0.0, 0.5)
    v = rng.normal(size=x.shape).astype(np.float32)
    v[::2, 3] = -0.0
    before = v.tobytes()
    apply_volume(x, v, dt=0.01, friction=0.0, repulsion=0.0)
    assert v.tobytes() == before


def test_friction_slows_interleaved_opposite_streams():
    """Alternate strands move at +u and −u through the same cells: their relative speed drops."""
    rng = np.random.default_rng(7)
    x = cloud(rng, 200, 10, 0.0, 1.0)
    v = np.zeros_like(x)
    v[0::2, :, 0] = 1.0
    v[1::2, :, 0] = -1.0
    apply_volume(x, v, dt=0.01, friction=0.5, repulsion=0.0, resolution=4)  # ~30 per cell
    relative = v[0::2, 1:, 0].mean() - v[1::2, 1:, 0].mean()
    assert 0 < relative < 0.6 * 2.0  # (1 − s)·2 = 1.0 when the grid velocity is ~0


def test_repulsion_pushes_an_edge_particle_out_by_s_h_over_dt():
    rng = np.random.default_rng(8)
    ball = rng.normal(scale=0.05, size=(300, 4, 3))
    x = np.concatenate([ball, np.zeros((1, 4, 3))]).astype(np.float32)
    edge = np.array([0.06, 0.05, -0.04], np.float32)
    x[-1, 1:] = edge  # three particles at the rim of the cluster, root at the centre
    v = np.zeros_like(x)
    s, dt = 0.2, 0.01
    grid = apply_volume(x, v, dt=dt, friction=0.0, repulsion=s)
    dv = v[-1, 1].astype(np.float64)
    out = edge / np.linalg.norm(edge)
    assert np.linalg.norm(dv) == pytest.approx(s * grid.spec.voxel / dt, rel=1e-5)
    assert dv @ out > 0.8 * np.linalg.norm(dv)
    assert not v[:, 0].any()  # roots stay


def test_particles_with_zero_inverse_mass_are_untouched():
    rng = np.random.default_rng(9)
    x = cloud(rng, 40, 8, 0.0, 0.3)
    v0 = rng.normal(size=x.shape).astype(np.float32)
    inv_mass = np.ones((40, 8), np.float32)
    pinned = rng.random((40, 8)) < 0.3
    inv_mass[pinned] = 0.0
    v = v0.copy()
    apply_volume(x, v, dt=0.01, friction=0.7, repulsion=0.1, resolution=4, inv_mass=inv_mass)
    np.testing.assert_array_equal(v[pinned], v0[pinned])
    assert (v[~pinned] != v0[~pinned]).any(axis=1).all()
    assert (v[:, 0] != v0[:, 0]).any()  # roots with inv_mass 1 move like the rest


@pytest.mark.parametrize("blur", [0, 1])
def test_a_lone_particle_is_not_pushed_by_its_own_density(blur):
    """Splat-then-interpolate is symmetric: a particle's own tent has no slope at it."""
    x = np.array([[[0, 0, 0], [0.3, 0.7, 0.1]], [[1, 1, 1], [1.37, 0.2, 1.9]]], np.float32)
    v = np.zeros_like(x)
    apply_volume(x, v, dt=0.01, friction=0.0, repulsion=1.0, blur_passes=blur)
    assert not v.any()


# --- determinism and awkward input ------------------------------------------------------


def test_same_bytes_with_one_and_two_threads():
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has a single thread here")
    rng = np.random.default_rng(10)
    x = rng.normal(scale=0.1, size=(257, 13, 3)).astype(np.float32)
    v0 = rng.normal(size=x.shape).astype(np.float32)
    runs = []
    saved = numba.get_num_threads()
    try:
        for threads in (1, 2):
            numba.set_num_threads(threads)
            v = v0.copy()
            grid = apply_volume(x, v, dt=0.01, friction=0.3, repulsion=0.1, blur_passes=2)
            runs.append((grid.density.tobytes(), grid.velocity.tobytes(), v.tobytes()))
    finally:
        numba.set_num_threads(saved)
    assert runs[0] == runs[1]


def test_strand_order_does_not_change_the_fields():
    rng = np.random.default_rng(11)
    x = rng.normal(scale=0.1, size=(100, 6, 3)).astype(np.float32)
    v = rng.normal(size=x.shape).astype(np.float32)
    order = rng.permutation(100)
    a = VolumeGrid.splat(x, v, spec=grid_for(x))
    b = VolumeGrid.splat(x[order], v[order], spec=grid_for(x))
    np.testing.assert_allclose(a.density, b.density, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.velocity, b.velocity, rtol=0, atol=1e-9)


def test_grid_covers_the_points_with_a_one_voxel_margin():
    rng = np.random.default_rng(12)
    pts = rng.uniform([0, 0, 0], [2.0, 1.0, 0.5], size=(1000, 3))
    spec = grid_for(pts, resolution=20)
    assert spec.voxel == pytest.approx(np.ptp(pts, axis=0).max() / 20)
    top = spec.origin + spec.voxel * (np.array(spec.shape) - 1)
    assert (pts.min(axis=0) - spec.origin >= spec.voxel * (1 - 1e-9)).all()
    assert (top - pts.max(axis=0) >= spec.voxel * (1 - 1e-9)).all()
    assert grid_for(pts, voxel_size=0.25).voxel == 0.25
    capped = grid_for(pts, voxel_size=1e-4)  # would be 20,000 × 10,000 × 5,000 cells
    assert np.prod(np.array(capped.shape) - 1) <= 128**3
    wide = grid_for(pts, resolution=20, margin=3)
    assert (pts.min(axis=0) - wide.origin >= 3 * wide.voxel * (1 - 1e-9)).all()
    assert wide.shape[0] == spec.shape[0] + 4


@pytest.mark.parametrize(
    "x",
    [
        np.full((20, 5, 3), 0.25, np.float32),  # one point
        np.concatenate(
            [np.random.default_rng(13).random((20, 5, 2)), np.full((20, 5, 1), 0.3)], axis=2
        ),  # flat: z = 0.3, float64
    ],
    ids=["point", "flat"],
)
@pytest.mark.slow
def test_degenerate_clouds_give_finite_results(x):
    spec = grid_for(x)
    assert spec.voxel > 0 and min(spec.shape) >= 4  # one cell + two margins on every axis
    grid = VolumeGrid.splat(x, np.ones_like(x), blur_passes=0)
    assert grid.density.sum() == pytest.approx(100, rel=1e-12)
    v = np.ones(x.shape, np.float32)
    grid = apply_volume(x, v, dt=0.01, friction=0.5, repulsion=0.5)
    assert np.isfinite(v).all()
    assert all(np.isfinite(a).all() for a in (grid.density, grid.velocity, grid.gradient))


GOOD = {"dt": 0.01, "friction": 0.5, "repulsion": 0.1}


@pytest.mark.parametrize(
    ("change", "name"),
    [
        ({"x": np.zeros((4, 3))}, "x"),
        ({"x": np.zeros((4, 5, 3), np.int32)}, "x"),
        ({"x": np.full((4, 5, 3), np.nan)}, "x"),
        ({"v": np.zeros((4, 5, 3), np.float16)}, "v"),  # float16: not updated in place
        ({"v": np.zeros((4, 5, 3, 2), np.float32)[..., 0]}, "v"),  # not contiguous
        ({"v": np.zeros((4, 6, 3), np.float32)}, "v"),
        ({"v": np.full((4, 5, 3), np.inf, np.float32)}, "v"),
        ({"dt": 0.0}, "dt"),
        ({"dt": float("nan")}, "dt"),
        ({"friction": 1.5}, "friction"),
        ({"friction": -0.1}, "friction"),
        ({"repulsion": -1.0}, "repulsion"),
        ({"resolution": 1}, "resolution"),
        ({"resolution": 8.5}, "resolution"),
        ({"voxel_size": 0.0}, "voxel_size"),
        ({"blur_passes": -1}, "blur_passes"),
        ({"inv_mass": np.ones((4, 4), np.float32)}, "inv_mass"),
        ({"inv_mass": -np.ones((4, 5), np.float32)}, "inv_mass"),
    ],
)
def test_bad_input_names_the_argument(change, name):
    args = {"x": np.zeros((4, 5, 3), np.float32), "v": np.zeros((4, 5, 3), np.float32)}
    args.update(GOOD)
    args.update(change)
    with pytest.raises(InputError, match=name):
        apply_volume(**args)


def test_bad_grid_spec_and_points_are_rejected():
    with pytest.raises(InputError, match="voxel"):
        GridSpec(origin=np.zeros(3), voxel=-1.0, shape=(4, 4, 4))
    with pytest.raises(InputError, match="shape"):
        GridSpec(origin=np.zeros(3), voxel=1.0, shape=(4, 1, 4))
    with pytest.raises(InputError, match="points"):
        VolumeGrid.splat(*one((0, 0, 0)), spec=SMALL).sample_density(np.zeros((2, 2)))
    with pytest.raises(InputError, match="margin"):
        grid_for(np.zeros((3, 3)), margin=0)
    with pytest.raises(InputError, match="spec"):
        VolumeGrid.splat(*one((0, 0, 0)), spec=(0, 0, 0))


def test_many_particles_stay_finite():
    rng = np.random.default_rng(14)
    x = rng.normal(scale=0.1, size=(4096, 32, 3)).astype(np.float32)
    v = rng.normal(scale=0.1, size=x.shape).astype(np.float32)
    grid = apply_volume(x, v, dt=1 / 60, friction=0.1, repulsion=0.05)
    assert np.isfinite(v).all() and np.isfinite(grid.density).all()
    assert grid.density.sum() > 0


@pytest.mark.parametrize("count", [1, 7, 50_000])
def test_unchecked_step_equals_apply_volume(count):
    """The simulator's volume_step (no input scans) gives apply_volume's bytes, and its
    one-pass bounds fit the same grid as the points' numpy bounds."""
    rng = np.random.default_rng(count)
    x = rng.normal(0.0, 0.05, (count, 4, 3))
    v0 = rng.normal(0.0, 0.3, (count, 4, 3))
    free = np.ones((count, 4), dtype=np.bool_)
    free[:, 0] = False
    a, b = v0.copy(), v0.copy()
    ga = apply_volume(x, a, 1 / 120, 0.2, 0.05, blur_passes=1, resolution=16)
    gb = volume_step(x, b, free, 1 / 120, 0.2, 0.05, 1, 16)
    assert a.tobytes() == b.tobytes()
    assert ga.density.tobytes() == gb.density.tobytes()
    if count == 1:  # its 4 particles lie voxels apart: each meets only its own splat
        np.testing.assert_allclose(a, v0, rtol=0, atol=1e-12)
    else:
        assert np.abs(a - v0).max() > 1e-3
    lo, hi = _bounds(x.reshape(-1, 3))
    np.testing.assert_array_equal(lo, x.reshape(-1, 3).min(axis=0))
    np.testing.assert_array_equal(hi, x.reshape(-1, 3).max(axis=0))
