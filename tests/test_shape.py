"""Frizz, Kink (Šik 2012 §2.2.5) and Curl (Almeida 2014 §3.1.2) on hairs in root-local frames."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.errors import InputError
from follicle.frames import rotation_minimizing_frames
from follicle.groom.shape import curl, curl_phase, frizz, kink
from follicle.noise import noise3


def _straight(n: int, n_verts: int, length: float = 1.0) -> np.ndarray:
    """n hairs straight up the normal (local z), root at the origin."""
    local = np.zeros((n, n_verts, 3))
    local[:, :, 2] = np.linspace(0.0, length, n_verts)
    return local


def _bent(n: int, n_verts: int) -> np.ndarray:
    """n hairs on a quarter circle of radius 0.5 from +z over towards +x (and a bit of y)."""
    a = np.linspace(0.0, 0.5 * np.pi, n_verts)
    one = np.stack([0.5 * (1 - np.cos(a)), 0.1 * np.sin(a) ** 2, 0.5 * np.sin(a)], axis=-1)
    return np.repeat(one[None], n, axis=0)


def _frizz_vector(root, freq, offset=(0.0, 0.0, 0.0), blend=0.0) -> np.ndarray:
    """F_combined of Šik 2012 §2.2.5 evaluated directly, z folded to -|z|."""
    root = np.asarray(root, float)
    freq = np.asarray(freq, float)
    static = np.array(noise3(*(freq * root)))
    dynamic = np.array(noise3(*(freq * (root + np.asarray(offset, float)))))
    f = (1.0 - blend) * static + blend * dynamic
    f[2] = -abs(f[2])
    return f


def _frizz_profile(t, fr, ft):
    return min(fr * 4.0 * (t - t * t) + ft * t * t, max(fr, ft))


ROOTS = np.array([[0.13, -0.42, 0.77], [1.9, 0.31, -0.58], [-0.64, 1.27, 0.05]])
FREQ = np.array([2.3, 1.7, 3.1])


# -------------------------------------------------------------------------------- frizz
@pytest.mark.parametrize("fr, ft", [(0.1, 0.3), (0.4, 0.1), (0.0, 0.25), (0.2, 0.0)])
def test_frizz_follows_the_min_profile_at_root_middle_and_tip(fr, ft):
    local = _straight(3, 3)  # t = 0, 1/2, 1
    before = local.copy()
    frizz(local, ROOTS, fr, ft, FREQ)
    cap = max(fr, ft)
    for h in range(3):
        f = _frizz_vector(ROOTS[h], FREQ)
        assert np.all(local[h, 0] == 0.0)  # root unchanged
        for i, t in ((1, 0.5), (2, 1.0)):
            d = local[h, i] - before[h, i]
            np.testing.assert_allclose(d, f * _frizz_profile(t, fr, ft), rtol=0, atol=1e-15)
            assert np.linalg.norm(d) <= np.linalg.norm(f) * cap + 1e-15
    # the closed forms: min(fr + ft/4, cap) in the middle, ft at the tip
    assert _frizz_profile(0.5, fr, ft) == min(fr + ft / 4, cap)
    assert _frizz_profile(1.0, fr, ft) == ft


def test_frizz_profile_at_many_vertices_is_capped_by_the_larger_amplitude():
    local = _straight(1, 41)
    before = local.copy()
    fr, ft = 0.3, 0.2
    frizz(local, ROOTS[:1], fr, ft, FREQ)
    f = _frizz_vector(ROOTS[0], FREQ)
    t = np.linspace(0.0, 1.0, 41)
    amp = np.minimum(fr * 4 * (t - t * t) + ft * t * t, 0.3)
    np.testing.assert_allclose(local[0] - before[0], amp[:, None] * f, rtol=0, atol=1e-15)
    assert amp.max() == 0.3 and np.sum(amp == 0.3) > 5  # the cap is reached mid-hair


def test_frizz_depends_on_the_rest_root_not_on_the_current_pose():
    straight, bent = _straight(3, 9), _bent(3, 9)
    a, b = straight.copy(), bent.copy()
    frizz(a, ROOTS, 0.1, 0.2, FREQ)
    frizz(b, ROOTS, 0.1, 0.2, FREQ)
    # bent hairs have z > 0 everywhere above the root, so no clamping in either pose;
    # the same displacement up to the round-off of (p + d) - p
    np.testing.assert_allclose(a - straight, b - bent, rtol=0, atol=1e-16)
    # another rest root gives another bend
    c = straight.copy()
    frizz(c, ROOTS + 0.37, 0.1, 0.2, FREQ)
    assert np.abs((c - straight) - (a - straight)).max() > 1e-3


def test_frizz_z_is_folded_towards_the_skin_and_never_below_it():
    rng = np.random.default_rng(7)
    roots = rng.uniform(-5, 5, (2000, 3))
    local = _straight(2000, 16)
    before = local.copy()
    frizz(local, roots, 0.05, 0.1, FREQ)
    d = local - before
    assert np.all(d[:, :, 2] <= 0.0)  # F.z = -|F.z|: hairs never grow along the normal
    assert np.any(d[:, 1:, 2] < -1e-3)
    # huge amplitudes: the fold would push vertices under the skin; they stop at z = 0
    local = _straight(2000, 16)
    frizz(local, roots, 3.0, 3.0, FREQ)
    assert np.all(local[:, :, 2] >= 0.0)
    assert np.sum(local[:, :, 2] == 0.0) > 2000 + 100  # roots, and some clamped vertices
    # x, y still follow the profile where z is clamped
    f = _frizz_vector(roots[0], FREQ)
    t = np.linspace(0, 1, 16)
    amp = np.minimum(3.0 * 4 * (t - t * t) + 3.0 * t * t, 3.0)
    np.testing.assert_allclose(local[0, :, :2], amp[:, None] * f[:2], rtol=0, atol=1e-14)


def test_frizz_vertex_below_the_skin_plane_keeps_its_height():
    local = np.array([[[0.0, 0.0, 0.0], [0.3, 0.0, -0.2], [0.6, 0.0, -0.1]]])
    before = local.copy()
    frizz(local, ROOTS[:1], 0.5, 0.5, FREQ)
    np.testing.assert_array_equal(local[:, :, 2], before[:, :, 2])
    assert np.abs(local[0, 1:, :2] - before[0, 1:, :2]).min() > 0.0


@pytest.mark.parametrize("blend", [0.0, 0.25, 1.0])
def test_frizz_animation_blends_static_and_offset_noise(blend):
    offset = np.array([0.8, -0.3, 0.5])  # direction · speed · time
    local = _straight(3, 3)
    before = local.copy()
    frizz(local, ROOTS, 0.1, 0.3, FREQ, offset=offset, blend=blend)
    for h in range(3):
        f = _frizz_vector(ROOTS[h], FREQ, offset, blend)
        np.testing.assert_allclose(local[h, 2] - before[h, 2], 0.3 * f, rtol=0, atol=1e-15)
    # per-hair offsets and blends (n, 3) and (n,) give the same as the shared ones
    per_hair = _straight(3, 3)
    frizz(
        per_hair,
        ROOTS,
        [0.1] * 3,
        [0.3] * 3,
        np.tile(FREQ, (3, 1)),
        offset=np.tile(offset, (3, 1)),
        blend=np.full(3, blend),
    )
    np.testing.assert_array_equal(per_hair, local)


def test_frizz_animated_with_zero_offset_is_the_static_frizz():
    a, b = _straight(3, 5), _straight(3, 5)
    frizz(a, ROOTS, 0.1, 0.3, FREQ)
    frizz(b, ROOTS, 0.1, 0.3, FREQ, offset=(0.0, 0.0, 0.0), blend=1.0)
    np.testing.assert_array_equal(a, b)


# --------------------------------------------------------------------------------- kink
def test_kink_is_per_vertex_noise_with_a_linear_amplitude():
    local = _bent(3, 6)
    before = local.copy()
    # an orthonormal rest frame per hair: rows T, B = T × N, N
    normal = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
    tangent = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.8, 0.0, -0.6]])
    binormal = np.cross(tangent, normal)
    kr, kt = 0.02, 0.1
    kink(local, ROOTS, kr, kt, FREQ, rest_frame=(tangent, binormal, normal))
    t = np.linspace(0.0, 1.0, 6)
    for h in range(3):
        assert np.all(local[h, 0] == 0.0)
        for i in range(1, 6):
            x, y, z = before[h, i]
            w = ROOTS[h] + x * tangent[h] + y * binormal[h] + z * normal[h]
            k = np.array(noise3(*(FREQ * w)))
            expected = k * ((1 - t[i]) * kr + t[i] * kt)
            np.testing.assert_allclose(local[h, i] - before[h, i], expected, rtol=0, atol=1e-15)


def test_kink_with_one_noise_vector_grows_linearly_from_root_to_tip():
    # frequency 0: every vertex samples noise3(0, 0, 0), so only the amplitude varies
    local = _straight(1, 11)
    before = local.copy()
    kink(local, ROOTS[:1], 0.02, 0.1, (0.0, 0.0, 0.0))
    k = np.linalg.norm(noise3(0.0, 0.0, 0.0))
    d = np.linalg.norm(local - before, axis=2)[0]
    t = np.linspace(0.0, 1.0, 11)
    np.testing.assert_allclose(d[1:], k * (0.02 + 0.08 * t[1:]), rtol=1e-13)
    np.testing.assert_allclose(np.diff(d[1:]), k * 0.008, rtol=1e-11)  # equal steps
    assert d[0] == 0.0


def test_kink_default_frame_is_the_world_axes():
    a, b = _bent(3, 6), _bent(3, 6)
    kink(a, ROOTS, 0.05, 0.05, FREQ)
    eye = np.eye(3)
    kink(b, ROOTS, 0.05, 0.05, FREQ, rest_frame=tuple(np.tile(e, (3, 1)) for e in eye))
    np.testing.assert_array_equal(a, b)
    # every vertex gets its own vector: equal amplitudes, different displacements
    d = (a - _bent(3, 6))[0, 1:]
    assert np.unique(np.round(d, 12), axis=0).shape[0] == 5


def test_kink_depends_only_on_the_local_hair_and_the_rest_root():
    # the current pose is no input: the same local hair and rest root give the same kink
    a = _bent(3, 8)
    kink(a, ROOTS, 0.03, 0.06, FREQ)
    b = _bent(3, 8)
    kink(b, ROOTS.copy(), 0.03, 0.06, FREQ)
    np.testing.assert_array_equal(a, b)
    c = _bent(3, 8)
    kink(c, ROOTS + 0.2, 0.03, 0.06, FREQ)
    assert np.abs(c - a).max() > 1e-4


# --------------------------------------------------------------------------------- curl
def _winding(local: np.ndarray) -> np.ndarray:
    return np.unwrap(np.arctan2(local[:, 1], local[:, 0]))


def test_curl_winds_a_straight_hair_into_a_helix_of_radius_a():
    n_verts, length, radius, freq, ramp = 201, 1.0, 0.05, 5.0, 0.1
    local = _straight(1, n_verts, length)
    curl(local, radius, freq, ramp=ramp)
    hair = local[0]
    z = np.linspace(0.0, length, n_verts)
    t = z / length
    assert np.all(hair[0] == 0.0)  # root fixed
    np.testing.assert_array_equal(hair[:, 2], z)  # offsets are perpendicular to the axis
    dist = np.hypot(hair[:, 0], hair[:, 1])
    out = t >= ramp
    np.testing.assert_allclose(dist[out], radius, rtol=0, atol=1e-15)
    # inside the ramp the radius grows in by smoothstep from 0
    u = t[~out] / ramp
    np.testing.assert_allclose(dist[~out], radius * u * u * (3 - 2 * u), rtol=0, atol=1e-15)
    assert np.all(np.diff(dist[~out]) > 0)
    # θ = 2π f s; the first normal is the root tangent (local x)
    angle = np.arctan2(hair[1:, 1], hair[1:, 0])
    np.testing.assert_allclose(
        np.angle(np.exp(1j * (angle - 2 * np.pi * freq * z[1:]))), 0.0, atol=1e-12
    )
    theta = _winding(hair[out])
    turns = (theta[-1] - theta[0]) / (2 * np.pi)
    assert turns == pytest.approx(freq * (length - z[out][0]), abs=1e-9)  # 4.5 turns
    # segments away from the ramp: chord of the helix, sqrt(h² + (2A sin(π f h))²)
    h = length / (n_verts - 1)
    seg = np.linalg.norm(np.diff(hair, axis=0), axis=1)
    chord = np.hypot(h, 2 * radius * np.sin(np.pi * freq * h))
    np.testing.assert_allclose(seg[out[:-1]], chord, rtol=1e-12)
    assert seg.sum() > length * 1.2  # sqrt(1 + (2π A f)²) ≈ 1.18 plus ramp


def test_curl_frequency_rising_to_the_tip():
    n_verts, f0, f1 = 401, 2.0, 8.0
    local = _straight(1, n_verts)
    curl(local, 0.02, f0, frequency_tip=f1, ramp=0.0)
    z = np.linspace(0.0, 1.0, n_verts)
    theta = _winding(local[0, 1:])
    # f(s) = f0 + (f1 - f0) s on a unit hair: θ = 2π (f0 s + (f1 - f0) s² / 2)
    expected = 2 * np.pi * (f0 * z + 0.5 * (f1 - f0) * z * z)[1:]
    np.testing.assert_allclose(theta - theta[0], expected - expected[0], atol=1e-10)
    assert (theta[-1] - theta[0] + expected[0]) / (2 * np.pi) == pytest.approx(5.0)
    np.testing.assert_allclose(np.hypot(local[0, 1:, 0], local[0, 1:, 1]), 0.02, atol=1e-15)


def test_curl_on_a_bent_hair_offsets_perpendicular_to_the_strand():
    n_verts, radius = 40, 0.03
    local = _bent(2, n_verts)
    before = local.copy()
    curl(local, [radius, 2 * radius], 6.0, ramp=0.0, phase=[0.0, 1.0])
    tan, _, _ = rotation_minimizing_frames(before[0], [0, n_verts], [[1.0, 0.0, 0.0]])
    for h, r in ((0, radius), (1, 2 * radius)):
        d = local[h] - before[h]
        assert np.all(d[0] == 0.0)
        np.testing.assert_allclose(np.linalg.norm(d[1:], axis=1), r, rtol=1e-12)
        np.testing.assert_allclose(np.einsum("ij,ij->i", d, tan), 0.0, atol=1e-15)


def test_curl_phase_turns_the_helix_start():
    phase = curl_phase(11, np.arange(4))
    assert np.all((phase >= 0) & (phase < 2 * np.pi)) and len(np.unique(phase)) == 4
    np.testing.assert_array_equal(phase, curl_phase(11, np.arange(4)))
    np.testing.assert_array_equal(phase[2:], curl_phase(11, np.array([2, 3])))
    assert not np.array_equal(phase, curl_phase(12, np.arange(4)))
    local = _straight(4, 11)
    curl(local, 0.1, 0.0, phase=phase, ramp=0.0)
    # zero frequency: every vertex sits at angle `phase` about the axis
    for h in range(4):
        ang = np.arctan2(local[h, 1:, 1], local[h, 1:, 0]) % (2 * np.pi)
        np.testing.assert_allclose(ang, phase[h], atol=1e-12)


# ---------------------------------------------------------------------------- all three
def _apply_all(local, roots, zero=False):
    s = 0.0 if zero else 1.0
    curl(local, 0.05 * s, 3.0, frequency_tip=5.0, phase=0.3)
    frizz(local, roots, 0.1 * s, 0.2 * s, FREQ, offset=(0.1, 0.2, 0.3), blend=0.5)
    kink(local, roots, 0.02 * s, 0.04 * s, 10 * FREQ)


def test_zero_amplitudes_and_radius_leave_hairs_unchanged_exactly():
    local = _bent(3, 12)
    local[1, 5, 0] = -0.0
    before = local.copy()
    _apply_all(local, ROOTS, zero=True)
    assert local.tobytes() == before.tobytes()


def test_same_input_same_bytes_and_chunking_does_not_matter():
    rng = np.random.default_rng(3)
    roots = rng.uniform(-2, 2, (500, 3))
    a = _bent(500, 16) + rng.normal(0, 0.01, (500, 16, 3)) * (np.arange(16) > 0)[:, None]
    b, c = a.copy(), a.copy()
    _apply_all(a, roots)
    _apply_all(b, roots)
    assert a.tobytes() == b.tobytes()
    head, tail = c[:123].copy(), c[123:].copy()
    _apply_all(head, roots[:123])
    _apply_all(tail, roots[123:])
    assert np.concatenate([head, tail]).tobytes() == a.tobytes()


def test_curve_parameter_defaults_to_the_original_parametrisation():
    t = np.linspace(0.0, 1.0, 9)
    a, b, c = _bent(3, 9), _bent(3, 9), _bent(3, 9)
    for local, tt in ((a, None), (b, t), (c, np.tile(t, (3, 1)))):
        frizz(local, ROOTS, 0.1, 0.2, FREQ, t=tt)
        kink(local, ROOTS, 0.05, 0.1, FREQ, t=tt)
        curl(local, 0.02, 4.0, frequency_tip=6.0, t=tt)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)


def test_a_cut_hair_keeps_its_original_parametrisation():
    # cutting keeps t = i / (N_uncut - 1) (Šik 2012 §2.2.8): the kept part deforms as before
    full = _bent(3, 9)
    cut = full[:, :5].copy()
    t_cut = np.linspace(0.0, 1.0, 9)[:5]
    for local, t in ((full, None), (cut, t_cut)):
        frizz(local, ROOTS, 0.1, 0.2, FREQ, t=t)
        kink(local, ROOTS, 0.05, 0.1, FREQ, t=t)
    np.testing.assert_array_equal(cut, full[:, :5])


def test_empty_chunks_and_root_only_hairs_are_no_ops():
    for shape in ((0, 16, 3), (4, 1, 3)):
        local = np.zeros(shape)
        roots = np.zeros((shape[0], 3))
        frizz(local, roots, 0.1, 0.2, FREQ)
        kink(local, roots, 0.1, 0.2, FREQ)
        curl(local, 0.1, 2.0)
        assert np.all(local == 0.0)


# ---------------------------------------------------------------------------- bad input
def test_bad_local_is_refused_without_changing_anything():
    roots = ROOTS
    with pytest.raises(InputError, match="local: expected a float64"):
        frizz(_straight(3, 4).astype(np.float32), roots, 0.1, 0.1, FREQ)
    with pytest.raises(InputError, match="local: expected a float64"):
        kink(_straight(3, 4).tolist(), roots, 0.1, 0.1, FREQ)
    with pytest.raises(InputError, match=r"local: expected shape"):
        curl(np.zeros((3, 4, 2)), 0.1, 1.0)
    with pytest.raises(InputError, match="C-contiguous"):
        frizz(_straight(3, 8)[:, ::2], roots, 0.1, 0.1, FREQ)
    ro = _straight(3, 4)
    ro.flags.writeable = False
    with pytest.raises(InputError, match="writeable"):
        kink(ro, roots, 0.1, 0.1, FREQ)
    nan = _straight(3, 4)
    nan[1, 2, 0] = np.nan
    with pytest.raises(InputError, match="local: vertices must be finite"):
        frizz(nan, roots, 0.1, 0.1, FREQ)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"rest_roots": np.zeros((2, 3))}, "rest_roots: expected shape"),
        ({"rest_roots": np.full((3, 3), np.inf)}, "rest_roots: values must be finite"),
        ({"amp_root": -0.1}, "amp_root: values must be >= 0"),
        ({"amp_tip": np.ones(4)}, r"amp_tip: expected a number or shape \(3,\)"),
        ({"amp_tip": "much"}, "amp_tip: expected numbers"),
        ({"frequency": [1.0, 2.0]}, r"frequency: expected shape \(3,\) or \(3, 3\)"),
        ({"offset": [0, 0, np.nan]}, "offset: values must be finite"),
        ({"blend": 1.5}, "blend: values must be <= 1"),
        ({"t": np.linspace(0, 2, 4)}, r"t: curve parameters must lie in \[0, 1\]"),
        ({"t": np.zeros((2, 4))}, r"t: expected shape \(4,\) or \(3, 4\)"),
    ],
)
def test_bad_frizz_parameters_name_the_parameter(kwargs, match):
    args = {"rest_roots": ROOTS, "amp_root": 0.1, "amp_tip": 0.1, "frequency": FREQ}
    args.update(kwargs)
    local = _straight(3, 4)
    before = local.copy()
    with pytest.raises(InputError, match=match):
        frizz(local, **args)
    np.testing.assert_array_equal(local, before)


def test_bad_kink_and_curl_parameters_name_the_parameter():
    local = _straight(3, 4)
    with pytest.raises(InputError, match="rest_frame: expected a tuple"):
        kink(local, ROOTS, 0.1, 0.1, FREQ, rest_frame=np.zeros((3, 3, 3)))
    with pytest.raises(InputError, match=r"rest_frame: expected three arrays of shape \(3, 3\)"):
        kink(local, ROOTS, 0.1, 0.1, FREQ, rest_frame=(np.zeros((3, 3)),) * 2 + (np.zeros(3),))
    with pytest.raises(InputError, match="amp_tip: values must be >= 0"):
        kink(local, ROOTS, 0.1, -1.0, FREQ)
    with pytest.raises(InputError, match="radius: values must be >= 0"):
        curl(local, -0.1, 1.0)
    with pytest.raises(InputError, match="frequency_tip: values must be finite"):
        curl(local, 0.1, 1.0, frequency_tip=np.inf)
    with pytest.raises(InputError, match=r"phase: expected a number or shape \(3,\)"):
        curl(local, 0.1, 1.0, phase=[0.0, 1.0])
    for ramp, message in (
        (-0.1, r"ramp: must be in \[0, 1\] \(got -0.1\)"),
        (1.5, r"ramp: must be in \[0, 1\] \(got 1.5\)"),
        ([0.1, 0.2], r"ramp: expected a number in \[0, 1\] \(got \[0.1, 0.2\]\)"),
    ):
        with pytest.raises(InputError, match=message):
            curl(local, 0.1, 1.0, ramp=ramp)
    np.testing.assert_array_equal(local, _straight(3, 4))
