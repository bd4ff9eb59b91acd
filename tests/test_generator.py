"""The groom pipeline (Šik 2012 §2.2.2): guides reproduced, chunking, rigid motion, every
property."""

from __future__ import annotations

import numpy as np
import pytest

from follicle import ConfigError, HairCurves, InputError, ResourceError
from follicle.groom.generator import Groom
from follicle.groom.guides import Guides, load_guides
from follicle.mesh.head import builtin_head
from follicle.mesh.skin import SkinMesh
from follicle.mesh.texture import Texture
from follicle.scene import GroomParams
from meshes import plane as _plane


def _straight_guides(mesh: SkinMesh, n: int = 5, vertices: int = 9, length: float = 0.4) -> Guides:
    """An n×n grid of straight guides standing on the plane (+Y), slightly leaning in x."""
    g = np.linspace(0.1, 0.9, n)
    s = np.linspace(0.0, 1.0, vertices)[:, None]
    curves = [np.array([x, 0.0, z]) + s * np.array([0.1, 1.0, 0.0]) * length for x in g for z in g]
    return Guides(HairCurves.from_polylines(curves), mesh)


@pytest.fixture(scope="module")
def head_groom() -> Groom:
    mesh = builtin_head()
    guides = load_guides("builtin:curly", mesh, vertices=12)
    return Groom(mesh, guides, GroomParams(seed=7))


def _same(a: HairCurves, b: HairCurves) -> None:
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.offsets, b.offsets)
    for k in a.point_data:
        np.testing.assert_array_equal(a.point_data[k], b.point_data[k])
    for k in a.curve_data:
        np.testing.assert_array_equal(a.curve_data[k], b.curve_data[k])


@pytest.mark.slow
def test_a_hair_at_a_guide_root_reproduces_the_guide():
    mesh = builtin_head()
    guides = load_guides("builtin:long", mesh, vertices=24)
    for method in ("idw", "barycentric", "offset"):
        groom = Groom(mesh, guides, GroomParams(interpolation=method, offset_angle=0.0))
        hair = groom.generate_at(guides.triangles[:20], guides.bary[:20])
        want = guides.curves.points.reshape(-1, 24, 3)[:20]
        np.testing.assert_allclose(hair.points.reshape(-1, 24, 3), want, atol=2e-6)


@pytest.mark.parametrize(
    "extra",
    [
        {},
        {
            "cut": 0.63,
            "random_scale": 0.5,
            "frizz_tip": 0.01,
            "kink_tip": 0.004,
            "curl_radius": 0.004,
            "clump_count": 40,
            "hue_variation": 10.0,
            "skip_threshold": 0.999,
        },
        {"strand_count": 3, "strand_twist": 90.0, "interpolation": "offset"},
        {"interpolation": "barycentric", "groups": "builtin:parting"},
    ],
)
@pytest.mark.slow
def test_chunked_equals_whole_byte_for_byte(extra):
    mesh = builtin_head()
    guides = load_guides("builtin:long", mesh, vertices=16)
    params = GroomParams(seed=3, **{k: v for k, v in extra.items() if k != "groups"})
    whole = Groom(mesh, guides, params).generate(1500)
    groom = Groom(mesh, guides, params)  # a fresh groom: no layout shared with `whole`
    parts = [groom.generate(600, 0), groom.generate(1, 600), groom.generate(899, 601)]
    _same(whole, HairCurves.concatenate(parts))
    _same(whole, HairCurves.concatenate(list(Groom(mesh, guides, params).chunks(700, 1500))))
    assert np.isfinite(whole.points).all() and np.isfinite(whole.point_data["normal"]).all()


@pytest.mark.slow
def test_rigidly_moved_mesh_moves_hair_rigidly(head_groom):
    p = head_groom.params.model_copy(update={"frizz_tip": 0.01, "clump_count": 30})
    head_groom.params = p
    rest = head_groom.generate(3000)
    a = np.radians(35.0)
    rot = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = [0.3, -1.2, 2.0]
    moved = head_groom.generate(3000, pose=head_groom.mesh.posed(transform=m))
    assert head_groom.mesh.at_rest  # the groom's mesh is not posed by it
    np.testing.assert_allclose(moved.points, rest.points @ rot.T + m[:3, 3], atol=1e-5)
    np.testing.assert_allclose(
        moved.point_data["normal"], rest.point_data["normal"] @ rot.T, atol=1e-5
    )


@pytest.mark.slow
def test_new_pose_and_property_changes_do_not_resample_roots(head_groom, monkeypatch):
    head_groom.generate(2000)
    calls = []
    real = head_groom.sampler.sample
    monkeypatch.setattr(
        head_groom.sampler, "sample", lambda *a, **k: calls.append(a) or real(*a, **k)
    )
    m = np.eye(4)
    m[:3, 3] = [0.0, 0.5, 0.0]
    head_groom.generate(2000, pose=head_groom.mesh.posed(transform=m))
    head_groom.params = head_groom.params.model_copy(update={"kink_tip": 0.003, "cut": 0.5})
    head_groom.generate(2000)
    assert calls == []  # Table 2.1: mesh update and property update keep the roots
    head_groom.params = head_groom.params.model_copy(update={"seed": 8})
    head_groom.generate(2000)
    assert any(c[2] == "random" for c in calls)  # a new seed is a first generation


def test_cut_keeps_the_original_parametrisation():
    mesh = _plane()
    guides = _straight_guides(mesh)
    params = GroomParams(cut=0.5, root_width=1e-4, tip_width=5e-5, vertices=9)
    hair = Groom(mesh, guides, params).generate(200)
    assert (hair.counts == 5).all()  # P_0 .. P_4, C(0.5) lands on vertex 4 of 9
    width = hair.point_data["width"].reshape(-1, 5)
    np.testing.assert_allclose(width[:, -1], 0.5 * (1e-4 + 5e-5), rtol=1e-6)
    full = Groom(mesh, guides, params.model_copy(update={"cut": 1.0})).generate(200)
    cut_len, full_len = (
        np.linalg.norm(np.diff(c.points.reshape(200, -1, 3), axis=1), axis=2).sum(axis=1)
        for c in (hair, full)
    )
    np.testing.assert_allclose(cut_len, 0.5 * full_len, rtol=1e-5)  # straight hairs
    cut = Groom(mesh, guides, params.model_copy(update={"cut": 0.3})).generate(200)
    assert (cut.counts == 4).all()  # t 0.3 is in segment 2 (of 8): P_0 .. P_2, C(0.3)
    assert np.allclose(cut.point_data["width"].reshape(-1, 4)[:, -1], 1e-4 - 0.3 * 5e-5)


def test_a_cut_map_removes_hair_where_it_is_zero(tmp_path):
    mesh = _plane()
    tex = np.zeros((4, 4), np.uint8)
    tex[:, :2] = 255  # u < 0.5: full length; u ≥ 0.5: cut at the root
    mesh.textures["cut"] = Texture(tex, wrap="clamp", name="cut")
    params = GroomParams(cut={"value": 1.0, "texture": "cut"})
    hair = Groom(mesh, _straight_guides(mesh), params).generate(1000)
    assert 450 < hair.curve_count < 700  # texels at u 0.375 / 0.625 blend bilinearly
    u = hair.curve_data["root_uv"][:, 0]
    assert (u < 0.625).all() and (u < 0.375).sum() > 300


@pytest.mark.parametrize("key", ["frizz_tip", "kink_root", "curl_radius", "hue_variation"])
def test_a_float_texture_that_turns_a_length_negative_is_refused_naming_it(key):
    """value × texture under a length or amplitude's least value (0): a float texture with
    negative texels somewhere is an InputError naming the key and the texture, not a
    groom grown with negative amplitudes (or curls silently skipped)."""
    mesh = _plane()
    tex = np.ones((4, 4), np.float32)
    tex[:, 3] = -0.5  # one column of texels below zero
    mesh.textures["signed"] = Texture(tex, wrap="clamp", name="signed")
    params = GroomParams(**{key: {"value": 0.01, "texture": "signed"}})
    with pytest.raises(InputError, match=rf"\[groom\]\.{key}: value × texture 'signed' is -"):
        Groom(mesh, _straight_guides(mesh), params).generate(2000)
    tex[:, 3] = 0.0  # the same texture at zero there grows
    mesh.textures["signed"] = Texture(tex, wrap="clamp", name="signed")
    assert Groom(mesh, _straight_guides(mesh), params).generate(2000).curve_count > 0


def test_scale_and_random_scale():
    mesh = _plane()
    guides = _straight_guides(mesh)

    def reach(hair: HairCurves) -> np.ndarray:
        tips, roots = hair.points[hair.offsets[1:] - 1], hair.points[hair.offsets[:-1]]
        return np.linalg.norm(tips - roots, axis=1)

    base = Groom(mesh, guides, GroomParams()).generate(2000)
    scaled = Groom(mesh, guides, GroomParams(scale=2.0, random_scale=1.0)).generate(2000)
    ratio = reach(scaled) / (2.0 * reach(base))  # 1 − ξ, ξ uniform in [0, 1)
    assert 0.0 < ratio.min() and ratio.max() <= 1.0 + 1e-6
    assert abs(ratio.mean() - 0.5) < 0.03


def test_full_clumping_gathers_every_tip_at_the_centre_hair():
    mesh = _plane()
    params = GroomParams(clump_count=1, clump_root=0.0, clump_tip=1.0, clump_noise=0.0)
    hair = Groom(mesh, _straight_guides(mesh), params).generate(300)
    tips = hair.points[hair.offsets[1:] - 1]
    assert np.ptp(tips, axis=0).max() < 1e-5
    roots = hair.points[hair.offsets[:-1]]
    assert np.ptp(roots[:, [0, 2]], axis=0).min() > 0.5  # roots stay spread out


def test_offset_translate_copies_the_nearest_guide_unturned():
    mesh = _plane()
    guides = _straight_guides(mesh)
    params = GroomParams(interpolation="offset", offset_mode="translate")
    hair = Groom(mesh, guides, params).generate(300)
    rel = hair.points.reshape(300, -1, 3) - hair.points[hair.offsets[:-1]][:, None]
    want = guides.rest_shapes(9)[0]  # every guide has the same shape
    np.testing.assert_allclose(rel, np.broadcast_to(want, rel.shape), atol=1e-6)


def test_offset_rotate_tilts_copies_within_the_angle():
    mesh = _plane()
    params = GroomParams(interpolation="offset", offset_angle=20.0)
    hair = Groom(mesh, _straight_guides(mesh), params).generate(500)
    d = hair.points[hair.offsets[1:] - 1] - hair.points[hair.offsets[:-1]]
    guide = np.array([0.1, 1.0, 0.0]) / np.hypot(0.1, 1.0)
    angle = np.degrees(np.arccos(np.clip(d @ guide / np.linalg.norm(d, axis=1), -1, 1)))
    assert angle.max() < 20.0 * np.sqrt(2) + 0.1 and angle.mean() > 5.0


def test_fibres_inherit_appearance_and_number_their_strands():
    mesh = _plane()
    params = GroomParams(strand_count=4, strand_splay_centre=0.01, hue_variation=30.0, vertices=9)
    hair = Groom(mesh, _straight_guides(mesh), params).generate(100)
    assert hair.curve_count == 400
    np.testing.assert_array_equal(hair.curve_data["strand_id"], np.tile(np.arange(4), 100))
    np.testing.assert_array_equal(hair.curve_data["hair_id"], np.repeat(np.arange(100), 4))
    color = hair.point_data["color"].reshape(100, 4, 9, 3)
    np.testing.assert_array_equal(color, np.broadcast_to(color[:, :1], color.shape))
    assert np.ptp(hair.points.reshape(100, 4, 9, 3)[:, :, 4], axis=1).max() > 1e-3


def test_skip_threshold_thins_straight_runs_and_keeps_bends():
    mesh = _plane()
    guides = _straight_guides(mesh)
    straight = Groom(mesh, guides, GroomParams(skip_threshold=0.999)).generate(100)
    assert (straight.counts == 2).all()  # a straight hair needs only its ends
    curly = Groom(
        mesh, guides, GroomParams(skip_threshold=0.999, curl_radius=0.02, curl_frequency=10.0)
    ).generate(100)
    assert curly.counts.min() > 4


def test_normals_are_unit_and_perpendicular_to_the_curve(head_groom):
    head_groom.params = GroomParams(seed=7, frizz_tip=0.01)
    hair = head_groom.generate(500)
    n = hair.point_data["normal"].astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    p = hair.points.reshape(500, -1, 3).astype(np.float64)
    t = np.gradient(p, axis=1)
    t /= np.linalg.norm(t, axis=2, keepdims=True)
    assert np.abs(np.sum(t * n.reshape(p.shape), axis=2))[:, 1:-1].max() < 1e-3


def test_a_colour_texture_colours_each_hair_by_its_root(tmp_path):
    mesh = _plane()
    rgb = np.zeros((2, 2, 3), np.uint8)
    rgb[:, 0] = (255, 0, 0)
    rgb[:, 1] = (0, 0, 255)
    path = tmp_path / "c.png"
    from PIL import Image

    Image.fromarray(rgb).save(path)
    spec = {"value": [1.0, 1.0, 1.0], "texture": str(path), "wrap": "clamp"}
    params = GroomParams(root_color=spec, tip_color=spec)
    hair = Groom(mesh, _straight_guides(mesh), params).generate(400)
    root_col = hair.point_data["color"][hair.offsets[:-1]]
    u = hair.curve_data["root_uv"][:, 0]
    left, right = u < 0.2, u > 0.8  # bilinear blend in between
    assert (root_col[left, 0] > 0.9).all() and (root_col[left, 2] < 0.1).all()
    assert (root_col[right, 2] > 0.9).all() and (root_col[right, 0] < 0.1).all()


def test_animated_frizz_moves_with_time_only_when_blended():
    mesh = _plane()
    guides = _straight_guides(mesh)
    still = GroomParams(frizz_tip=0.02, frizz_speed=1.0)
    g = Groom(mesh, guides, still)
    _same(g.generate(50, time=0.0), g.generate(50, time=0.3))
    g.params = still.model_copy(update={"frizz_blend": 1.0})
    assert np.abs(g.generate(50, time=0.0).points - g.generate(50, time=0.3).points).max() > 1e-4


def test_counts_that_do_not_fit_in_memory_are_refused_with_an_estimate(head_groom):
    with pytest.raises(ResourceError, match=r"need about [\d.]+ GiB .* Groom.chunks\(\)"):
        head_groom.generate(10**11)


def test_bad_arguments_name_themselves(head_groom):
    with pytest.raises(InputError, match=r"count: expected a whole number ≥ 0 \(got -1\)"):
        head_groom.generate(-1)
    with pytest.raises(InputError, match=r"chunk_size: expected a whole number ≥ 1 \(got 0\)"):
        list(head_groom.chunks(0, 10))
    with pytest.raises(InputError, match="ids: hair ids must be distinct"):
        head_groom.generate_at(np.array([0, 1]), np.full((2, 2), 0.3), ids=np.array([4, 4]))
    with pytest.raises(InputError, match="params: expected GroomParams"):
        head_groom.params = {"count": 3}


@pytest.mark.slow
def test_hairs_at_the_uv_pole_bend_like_their_guides():
    """Root frames follow the UV tangent, which spins around the crown's UV pole; hairs
    are turned to their guides' tangent, so none swings round in front of the face."""
    mesh = builtin_head()
    from follicle.groom.generator import load_texture
    from follicle.groom.groups import InterpolationGroups

    groups = InterpolationGroups(load_texture("builtin:parting"))
    guides = load_guides("builtin:long", mesh, groups=groups)
    hair = Groom(mesh, guides, GroomParams()).generate(16000)
    z_max = np.maximum.reduceat(hair.points[:, 2], hair.offsets[:-1])
    assert (z_max > 0.12).sum() == 0  # was 16 hairs with frames straight from the UVs


def test_each_textured_property_keeps_its_own_bounds():
    """Properties of one kind but other bounds validate apart: hue_variation takes up to
    180 degrees though a length stops at 10 m (typing caches ``Annotated`` aliases by
    their metadata's equality, which once let the first alias's bounds stand for all)."""
    assert GroomParams(hue_variation=150.0).hue_variation == 150.0
    with pytest.raises(ConfigError, match=r"hue_variation: must be ≤ 180"):
        GroomParams(hue_variation=181.0)
    with pytest.raises(ConfigError, match=r"curl_radius: must be ≤ 10"):
        GroomParams(curl_radius=11.0)
