"""Hair strands: fibres around each hair (Šik 2012 §2.2.7), in the hairs' root-local frames."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.errors import InputError
from follicle.frames import rotation_minimizing_frames
from follicle.groom.fibres import inherit, make_fibres, splay_profile

N = 17  # odd, so vertex 8 is t = ½ exactly


def _straight(n: int = 3, nv: int = N, length: float = 2.0) -> np.ndarray:
    """n hairs straight up the surface normal (local +z): T = z, N = x, B = y."""
    local = np.zeros((n, nv, 3))
    local[:, :, 2] = np.linspace(0.0, length, nv)
    return local


def _curved(n: int = 4, nv: int = N) -> np.ndarray:
    """n differently bent 3-D hairs rooted at the origin, growing off the surface."""
    s = np.linspace(0.0, 1.0, nv)
    out = np.empty((n, nv, 3))
    for h in range(n):
        k = 1.0 + h
        out[h, :, 0] = 0.4 * np.sin(k * s) * s
        out[h, :, 1] = 0.3 * (1.0 - np.cos(1.5 * k * s))
        out[h, :, 2] = s + 0.2 * s**2
    return out


def _plain(local, count=6, seed=7, **kw):
    """Fibres with no splay, twist, offset or randomize unless given; ids 0 … n − 1."""
    args = dict(
        splay_root=0.0,
        splay_centre=0.0,
        splay_tip=0.0,
        twist=0.0,
        aspect=1.0,
        offset=0.0,
        randomize=0.0,
    )
    args.update(kw)
    return make_fibres(local, np.arange(len(local), dtype=np.int64), seed, count, **args)


def _offsets(local, fibres, parent):
    return fibres - local[parent]


# ------------------------------------------------------------------ output layout
def test_layout_parent_strand_id_and_uv_in_unit_disc():
    local = _straight(3)
    fib, parent, sid, uv = _plain(local, count=4, splay_root=0.1, splay_centre=0.1, splay_tip=0.1)
    assert fib.shape == (12, N, 3) and fib.dtype == np.float64
    assert parent.dtype == np.int64 and sid.dtype == np.int64 and uv.dtype == np.float32
    np.testing.assert_array_equal(parent, [0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2])
    np.testing.assert_array_equal(sid, [0, 1, 2, 3] * 3)
    assert uv.shape == (12, 2)
    assert np.all(np.hypot(uv[:, 0], uv[:, 1]) <= 1.0 + 1e-6)
    # distinct fibres of a strand sit at distinct places
    assert len({tuple(r) for r in uv.tolist()}) == 12


# ------------------------------------------------------------------ splay
def test_splay_profile_values():
    np.testing.assert_allclose(splay_profile([0.0, 0.5, 1.0], 0.2, 0.5, 0.9), [0.2, 0.5, 0.9])
    # quadratic blend: t = ¼ is halfway in weight between root and centre
    np.testing.assert_allclose(splay_profile(0.25, 0.2, 0.6, 0.9), 0.25 * 0.2 + 0.75 * 0.6)
    np.testing.assert_allclose(splay_profile(0.75, 0.2, 0.6, 0.9), 0.25 * 0.9 + 0.75 * 0.6)


def test_splay_at_root_centre_tip_straight_hair():
    local = _straight(3)
    sr = np.array([0.05, 0.1, 0.0])
    sc = np.array([0.3, 0.2, 0.4])
    st = np.array([0.01, 0.6, 0.2])
    fib, parent, _, uv = _plain(local, count=8, splay_root=sr, splay_centre=sc, splay_tip=st)
    d = np.hypot(uv[:, 0], uv[:, 1]).astype(np.float64)
    off = _offsets(local, fib, parent)
    np.testing.assert_allclose(off[:, :, 2], 0.0, atol=1e-15)  # in the plane ⟂ hair
    dist = np.linalg.norm(off, axis=-1)
    for i, want in ((0, sr), (N // 2, sc), (N - 1, st)):
        np.testing.assert_allclose(dist[:, i], d * want[parent], rtol=1e-6, atol=1e-9)
    # and everywhere in between, the profile
    t = np.linspace(0.0, 1.0, N)
    prof = np.stack([splay_profile(t, sr[h], sc[h], st[h]) for h in parent])
    np.testing.assert_allclose(dist, d[:, None] * prof, rtol=1e-6, atol=1e-9)


def test_fibre_direction_matches_disc_sample_without_twist():
    local = _straight(2)
    fib, parent, _, uv = _plain(local, count=5, splay_root=0.5, splay_centre=0.5, splay_tip=0.5)
    off = _offsets(local, fib, parent)
    # u along the curve normal (local x), v along the binormal (local y), radius 0.5
    for i in (0, 5, N - 1):
        np.testing.assert_allclose(off[:, i, :2], 0.5 * uv, atol=1e-7)


# ------------------------------------------------------------------ twist
@pytest.mark.parametrize("twist", [1.3, -2.0, 4 * np.pi])
def test_twist_advances_angle_by_constant_step(twist):
    local = _straight(2)
    fib, parent, _, _ = _plain(
        local, count=6, splay_root=0.3, splay_centre=0.3, splay_tip=0.3, twist=twist
    )
    off = _offsets(local, fib, parent)
    phi0 = np.arctan2(off[:, 0, 1], off[:, 0, 0])
    r = np.hypot(off[:, 0, 0], off[:, 0, 1])
    step = twist / (N - 1)
    for k in range(N):
        phi = phi0 + k * step  # closed form after k vertices
        np.testing.assert_allclose(off[:, k, 0], r * np.cos(phi), atol=1e-12)
        np.testing.assert_allclose(off[:, k, 1], r * np.sin(phi), atol=1e-12)
    # root to tip the fibres turn by exactly ``twist``
    turn = np.arctan2(off[:, -1, 1], off[:, -1, 0]) - phi0
    np.testing.assert_allclose(np.cos(turn), np.cos(twist), atol=1e-12)
    np.testing.assert_allclose(np.sin(turn), np.sin(twist), atol=1e-12)


def test_twist_per_hair():
    local = _straight(2)
    fib, parent, _, _ = _plain(
        local,
        count=3,
        splay_root=0.3,
        splay_centre=0.3,
        splay_tip=0.3,
        twist=np.array([0.0, np.pi]),
    )
    off = _offsets(local, fib, parent)
    np.testing.assert_allclose(off[:3, -1], off[:3, 0], atol=1e-12)  # no twist
    np.testing.assert_allclose(off[3:, -1, :2], -off[3:, 0, :2], atol=1e-12)  # half a turn


# ------------------------------------------------------------------ aspect
def test_aspect_squashes_binormal_axis():
    local = _straight(2)
    common = dict(count=50, splay_root=0.4, splay_centre=0.4, splay_tip=0.4)
    round_, parent, _, uv = _plain(local, **common)
    flat, _, _, uv2 = _plain(local, aspect=0.25, **common)
    np.testing.assert_array_equal(uv, uv2)
    a = _offsets(local, round_, parent)
    b = _offsets(local, flat, parent)
    np.testing.assert_allclose(b[..., 0], a[..., 0], atol=1e-15)  # along N unchanged
    np.testing.assert_allclose(b[..., 1], 0.25 * a[..., 1], atol=1e-15)  # along B × aspect
    # the cross-section is the ellipse with semi-axes 0.4 and 0.1
    assert np.all((b[..., 0] / 0.4) ** 2 + (b[..., 1] / 0.1) ** 2 <= 1.0 + 1e-9)


# ------------------------------------------------------------------ offset and randomize
def test_offset_grows_as_t_cubed_along_normal():
    local = _straight(2)
    fib, parent, _, _ = _plain(local, count=3, offset=np.array([0.5, -1.0]))
    off = _offsets(local, fib, parent)
    t = np.linspace(0.0, 1.0, N)
    want = np.array([0.5, -1.0])[parent][:, None] * t**3
    np.testing.assert_allclose(off[..., 0], want, atol=1e-15)
    np.testing.assert_allclose(off[..., 1:], 0.0, atol=1e-15)


def test_randomize_scales_each_fibre_about_the_root():
    local = _straight(1)
    common = dict(count=400, splay_root=0.1, splay_centre=0.2, splay_tip=0.3, twist=1.0)
    base, _, _, _ = _plain(local, **common)
    rand, _, _, _ = _plain(local, randomize=0.6, **common)
    tip = np.linalg.norm(rand[:, -1], axis=-1) / np.linalg.norm(base[:, -1], axis=-1)
    # one factor per fibre, for all its vertices
    np.testing.assert_allclose(rand, tip[:, None, None] * base, rtol=1e-12, atol=1e-15)
    assert tip.min() >= 1.0 - 0.6 - 1e-12 and tip.max() <= 1.0
    assert tip.min() < 0.45 and tip.max() > 0.95  # ξ spread over [0, 1)
    np.testing.assert_allclose(tip.mean(), 1.0 - 0.6 * 0.5, atol=0.03)


def test_count_one_zero_splay_reproduces_hair_exactly():
    for local in (_straight(3), _curved(4)):
        fib, parent, sid, _ = _plain(local, count=1, twist=2.0, aspect=0.3)
        np.testing.assert_array_equal(fib, local)
        np.testing.assert_array_equal(parent, np.arange(len(local)))
        np.testing.assert_array_equal(sid, 0)


# ------------------------------------------------------------------ curved hair, RMF
def test_curved_hair_fibres_in_rmf_planes_at_splay_distance():
    local = _curved(4)
    n = len(local)
    fib, parent, _, uv = _plain(local, count=7, splay_root=0.02, splay_centre=0.08, splay_tip=0.05)
    flat = local.reshape(-1, 3)
    offs = np.arange(n + 1) * N
    tan, nor, bi = rotation_minimizing_frames(flat, offs, np.tile([1.0, 0, 0], (n, 1)))
    tan, nor, bi = (a.reshape(n, N, 3)[parent] for a in (tan, nor, bi))
    off = _offsets(local, fib, parent)
    d = np.hypot(uv[:, 0], uv[:, 1]).astype(np.float64)
    prof = splay_profile(np.linspace(0.0, 1.0, N), 0.02, 0.08, 0.05)
    # perpendicular to the hair, at the splay distance
    np.testing.assert_allclose(np.einsum("fik,fik->fi", off, tan), 0.0, atol=1e-12)
    np.testing.assert_allclose(
        np.linalg.norm(off, axis=-1), d[:, None] * prof, rtol=1e-6, atol=1e-9
    )
    # at a fixed angle in the rotation-minimising frame (no twist): same (u, v) everywhere
    u = np.einsum("fik,fik->fi", off, nor)
    v = np.einsum("fik,fik->fi", off, bi)
    np.testing.assert_allclose(u, uv[:, :1] * prof, atol=1e-7)
    np.testing.assert_allclose(v, uv[:, 1:] * prof, atol=1e-7)


def test_degenerate_hair_segments_are_handled():
    local = _straight(1, nv=6)
    local[0, 3] = local[0, 2]  # a repeated vertex
    fib, parent, _, uv = _plain(local, count=3, splay_root=0.1, splay_centre=0.1, splay_tip=0.1)
    assert np.all(np.isfinite(fib))
    dist = np.linalg.norm(_offsets(local, fib, parent), axis=-1)
    d = np.hypot(uv[:, 0], uv[:, 1]).astype(np.float64)
    np.testing.assert_allclose(dist, np.repeat(0.1 * d[:, None], 6, axis=1), rtol=1e-6)
    # a hair collapsed to its root still gets finite fibres around +z
    fib, _, _, _ = _plain(
        np.zeros((1, 4, 3)), count=2, splay_root=0.1, splay_centre=0.1, splay_tip=0.1
    )
    assert np.all(np.isfinite(fib)) and np.allclose(fib[..., 2], 0.0)


# ------------------------------------------------------------------ determinism, chunks
def _rich_args(n, rng):
    return dict(
        splay_root=rng.random(n) * 0.02,
        splay_centre=rng.random(n) * 0.05,
        splay_tip=rng.random(n) * 0.03,
        twist=rng.normal(size=n) * 3,
        aspect=rng.random(n) + 0.2,
        offset=rng.normal(size=n) * 0.01,
        randomize=rng.random(n),
    )


def test_deterministic_and_seed_dependent():
    rng = np.random.default_rng(3)
    local = _curved(5)
    ids = np.array([10, 11, 12, 500, 7])
    args = _rich_args(5, rng)
    a = make_fibres(local, ids, 42, 5, **args)
    b = make_fibres(local, ids, 42, 5, **args)
    for x, y in zip(a, b, strict=True):
        assert x.tobytes() == y.tobytes()
    c = make_fibres(local, ids, 43, 5, **args)
    assert not np.array_equal(a[3], c[3]) and not np.array_equal(a[0], c[0])
    # fibres depend on the hair id, not on the row
    d = make_fibres(local[::-1], ids[::-1], 42, 5, **{k: v[::-1] for k, v in args.items()})
    np.testing.assert_array_equal(d[0].reshape(5, 5, N, 3)[::-1].reshape(-1, N, 3), a[0])
    np.testing.assert_array_equal(d[3].reshape(5, 5, 2)[::-1].reshape(-1, 2), a[3])


@pytest.mark.parametrize("cuts", [[1], [3, 4], [1, 2, 5, 9]])
def test_chunk_independence_byte_for_byte(cuts):
    n, count = 11, 4
    rng = np.random.default_rng(5)
    local = np.concatenate([_curved(6), _straight(5)])
    local[:, 1:] += rng.normal(scale=0.01, size=(n, N - 1, 3))
    ids = np.arange(1000, 1000 + n, dtype=np.int64)
    args = _rich_args(n, rng)
    whole = make_fibres(local, ids, 99, count, **args)
    parts = []
    for lo, hi in zip([0, *cuts], [*cuts, n], strict=True):
        part = make_fibres(
            local[lo:hi], ids[lo:hi], 99, count, **{k: v[lo:hi] for k, v in args.items()}
        )
        parts.append((part[0], part[1] + lo, part[2], part[3]))
    for j in range(4):
        joined = np.concatenate([p[j] for p in parts])
        assert joined.dtype == whole[j].dtype
        assert joined.tobytes() == whole[j].tobytes()


def test_scalars_broadcast_like_arrays():
    local = _curved(3)
    ids = np.arange(3)
    a = make_fibres(local, ids, 1, 3, 0.1, 0.2, 0.3, 1.0, 0.5, 0.1, 0.3)
    b = make_fibres(local, ids, 1, 3, *(np.full(3, v) for v in (0.1, 0.2, 0.3, 1.0, 0.5, 0.1, 0.3)))
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def test_empty_chunk():
    fib, parent, sid, uv = make_fibres(
        np.zeros((0, 5, 3)), np.zeros(0, np.int64), 1, 3, 0.1, 0.1, 0.1
    )
    assert fib.shape == (0, 5, 3) and parent.shape == sid.shape == (0,) and uv.shape == (0, 2)


# ------------------------------------------------------------------ inherit
def test_inherit_repeats_per_vertex_arrays():
    nv = 4
    width = np.arange(3 * nv, dtype=np.float32)
    color = np.arange(3 * nv * 3, dtype=np.float32).reshape(-1, 3)
    _, parent, _, _ = _plain(_straight(3, nv=nv), count=2)
    got = inherit({"width": width, "color": color}, parent, nv)
    assert got["width"].shape == (6 * nv,) and got["color"].shape == (6 * nv, 3)
    for f, h in enumerate(parent):
        np.testing.assert_array_equal(
            got["width"][f * nv : (f + 1) * nv], width[h * nv : (h + 1) * nv]
        )
        np.testing.assert_array_equal(
            got["color"][f * nv : (f + 1) * nv], color[h * nv : (h + 1) * nv]
        )
    with pytest.raises(InputError, match="width"):
        inherit({"width": width[:-1]}, parent, nv)
    with pytest.raises(InputError, match="fibre_parent"):
        inherit({"width": width}, parent + 5, nv)
    with pytest.raises(InputError, match="vertices"):
        inherit({"width": width}, parent, 0)


# ------------------------------------------------------------------ bad input
_GOOD = dict(
    splay_root=0.1,
    splay_centre=0.1,
    splay_tip=0.1,
    twist=0.0,
    aspect=1.0,
    offset=0.0,
    randomize=0.0,
)


@pytest.mark.parametrize(
    "name, value",
    [
        ("splay_root", -0.1),
        ("splay_centre", np.array([0.1, np.nan])),
        ("splay_tip", np.ones(3)),
        ("twist", np.inf),
        ("aspect", -1.0),
        ("offset", np.ones((2, 1))),
        ("randomize", 1.5),
        ("randomize", -0.1),
        ("twist", "a lot"),
    ],
)
def test_bad_parameters_name_themselves(name, value):
    with pytest.raises(InputError, match=name):
        make_fibres(_straight(2), np.arange(2), 1, 3, **{**_GOOD, name: value})


@pytest.mark.parametrize(
    "local, ids, seed, count, name",
    [
        (np.zeros((2, 5)), np.arange(2), 1, 3, "local"),
        (np.zeros((2, 1, 3)), np.arange(2), 1, 3, "local"),
        (np.full((2, 5, 3), np.nan), np.arange(2), 1, 3, "local"),
        (np.zeros((2, 5, 3)), np.arange(3), 1, 3, "hair_ids"),
        (np.zeros((2, 5, 3)), np.array([0.0, 1.0]), 1, 3, "hair_ids"),
        (np.zeros((2, 5, 3)), np.arange(2), 1.5, 3, "seed"),
        (np.zeros((2, 5, 3)), np.arange(2), True, 3, "seed"),
        (np.zeros((2, 5, 3)), np.arange(2), 1, 0, "count"),
        (np.zeros((2, 5, 3)), np.arange(2), 1, 2.0, "count"),
    ],
)
def test_bad_arrays_name_themselves(local, ids, seed, count, name):
    with pytest.raises(InputError, match=name):
        make_fibres(local, ids, seed, count, **_GOOD)
