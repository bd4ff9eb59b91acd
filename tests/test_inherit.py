"""[groom].inherit: the guides' point and curve attributes carried onto the hairs by the
interpolation weights (Blender's "Interpolate Curves"), checked against hand blends of
the weights the groom reports."""

from __future__ import annotations

import colorsys

import numpy as np
import pytest

from follicle import ConfigError, HairCurves, InputError
from follicle.groom.builtin_guides import builtin_guides
from follicle.groom.generator import Groom
from follicle.groom.guides import Guides, load_guides
from follicle.io.dispatch import save
from follicle.mesh.head import builtin_head
from follicle.pipeline import grow
from follicle.scene import GroomParams, parse_scene
from meshes import plane

ROOTS = [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)]
RED, BLUE = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
# each guide red at the root, blue at the tip, at its own brightness
ROOT_RGB = np.array([RED * b for b in (1.0, 0.5, 0.8, 0.2)])
TIP_RGB = np.array([BLUE * b for b in (0.3, 0.9, 0.6, 1.0)])
ROOT_W = np.array([4e-4, 2e-4, 3e-4, 1e-4])
TIP_W = np.array([1e-4, 0.5e-4, 0.2e-4, 0.8e-4])
STIFF = np.array([0.5, 1.5, 2.5, 3.5])  # a float curve attribute
TAG = np.array([7, 8, 9, 10], dtype=np.int32)  # an integer curve attribute
OPACITY = np.array([0.2, 0.4, 0.6, 0.8])  # a look per guide: one value along each hair
SAMPLES = 3  # idw over 4 guides: every hair blends 3 of them (the 4th sets the radius)


def _guides(mesh, vertices: int = 5, **extra_point) -> Guides:
    """Four straight guides on the plane whose colour and width run linearly in arc
    length from root to tip (vertices evenly spaced)."""
    s = np.linspace(0.0, 1.0, vertices)[:, None]
    curves = [np.array([x, 0.0, z]) + s * np.array([0.05, 0.3, 0.0]) for x, z in ROOTS]
    color = np.concatenate([r + s * (t - r) for r, t in zip(ROOT_RGB, TIP_RGB, strict=True)])
    width = np.concatenate([r + s[:, 0] * (t - r) for r, t in zip(ROOT_W, TIP_W, strict=True)])
    data = {"color": color.astype(np.float32), "width": width.astype(np.float32), **extra_point}
    hc = HairCurves.from_polylines(
        curves, point_data=data, curve_data={"stiffness": STIFF, "tag": TAG, "opacity": OPACITY}
    )
    return Guides(hc, mesh)


@pytest.fixture(scope="module")
def mesh():
    return plane()


@pytest.fixture(scope="module")
def guides(mesh):
    return _guides(mesh)


def _params(**kw) -> GroomParams:
    base = {"count": 300, "seed": 5, "guide_samples": SAMPLES, "vertices": 9}
    return GroomParams(**{**base, **kw})


def _per_hair(curves: HairCurves, key: str) -> np.ndarray:
    return curves.point_data[key].reshape(curves.curve_count, -1, *curves.point_data[key].shape[1:])


def _weights(groom: Groom, hair: HairCurves) -> tuple[np.ndarray, np.ndarray]:
    return groom.guide_binding(hair.curve_data["hair_id"], k=SAMPLES + 1)


def test_red_to_blue_guides_grow_the_weighted_blend(mesh, guides):
    groom = Groom(mesh, guides, _params(inherit=["color", "width", "stiffness", "tag"]))
    hair = groom.generate()
    index, weight = _weights(groom, hair)
    assert (np.sort(weight, axis=1)[:, -2] > 0.05).mean() > 0.3  # hairs really blend
    t = np.linspace(0.0, 1.0, 9)[None, :, None]  # vertex i of 9 at t = i/8 of the guide
    w = weight[:, :, None, None]
    # the hand blend: each guide's linear ramp at t, weighed
    want = (
        w * (ROOT_RGB[index][:, :, None] + t[:, None] * (TIP_RGB - ROOT_RGB)[index][:, :, None])
    ).sum(1)
    color = _per_hair(hair, "color")
    np.testing.assert_allclose(color, want, atol=2e-6)
    np.testing.assert_allclose(color[:, 0], (weight[..., None] * ROOT_RGB[index]).sum(1), atol=2e-6)
    np.testing.assert_allclose(color[:, -1], (weight[..., None] * TIP_RGB[index]).sum(1), atol=2e-6)
    assert color[:, 0, 2].max() < 1e-6 and color[:, -1, 0].max() < 1e-6  # red root, blue tip
    width = _per_hair(hair, "width")
    tw = t[..., 0]
    want_w = (
        weight[:, :, None] * (ROOT_W[index][..., None] + tw * (TIP_W - ROOT_W)[index][..., None])
    ).sum(1)
    np.testing.assert_allclose(width, want_w, rtol=1e-5)
    # curve attributes: a float blended, an integer the heaviest guide's
    stiffness = hair.curve_data["stiffness"]
    assert stiffness.dtype == np.float32 and stiffness.shape == (hair.curve_count,)
    np.testing.assert_allclose(stiffness, (weight * STIFF[index]).sum(1), rtol=1e-5)
    tag = hair.curve_data["tag"]
    assert tag.dtype == np.int32
    np.testing.assert_array_equal(tag, TAG[index[np.arange(len(index)), np.argmax(weight, 1)]])
    # opacity was not inherited: the groom's own; inherited from the guides' curves, it
    # is their blend all along the hair
    np.testing.assert_array_equal(hair.point_data["opacity"], 1.0)
    groom.params = groom.params.replace(inherit=["opacity"])
    opacity = _per_hair(groom.generate(), "opacity")
    want_o = (weight * OPACITY[index]).sum(1)[:, None]
    np.testing.assert_allclose(opacity, np.broadcast_to(want_o, opacity.shape), rtol=1e-5)


def test_cut_hair_ends_on_the_colour_at_its_cut(mesh, guides):
    groom = Groom(mesh, guides, _params(inherit=["color"], cut=0.6))
    hair = groom.generate()
    index, weight = _weights(groom, hair)
    counts = hair.counts
    last = hair.offsets[1:] - 1
    ramp = ROOT_RGB + 0.6 * (TIP_RGB - ROOT_RGB)  # each guide's colour at t = 0.6
    np.testing.assert_allclose(
        hair.point_data["color"][last], (weight[..., None] * ramp[index]).sum(1), atol=2e-6
    )
    assert (counts == 6).all()  # 0.6 of 8 segments: P_0 … P_4 and the cut vertex at 4.8


def test_hue_variation_turns_an_inherited_colour_and_mutants_stay(mesh, guides):
    plain = Groom(mesh, guides, _params(inherit=["color"])).generate()
    varied = Groom(mesh, guides, _params(inherit=["color"], hue_variation=20.0)).generate()
    hsv = lambda c: np.array([colorsys.rgb_to_hsv(*x) for x in c.reshape(-1, 3)])  # noqa: E731
    a, b = hsv(plain.point_data["color"]), hsv(varied.point_data["color"])
    turn = ((b[:, 0] - a[:, 0]) * 360.0 + 180.0) % 360.0 - 180.0
    per_hair = turn.reshape(plain.curve_count, -1)
    assert np.abs(per_hair).max() <= 20.0 + 1e-3 and np.abs(per_hair).max() > 5.0
    np.testing.assert_allclose(
        per_hair, np.broadcast_to(per_hair[:, :1], per_hair.shape), atol=1e-3
    )  # one turn a hair
    np.testing.assert_allclose(b[:, 1:], a[:, 1:], atol=1e-5)  # saturation, value kept
    mutants = Groom(
        mesh, guides, _params(inherit=["color"], mutant_fraction=1.0, mutant_color=[0.5] * 3)
    ).generate()
    np.testing.assert_allclose(mutants.point_data["color"], 0.5, atol=1e-6)


@pytest.mark.slow
def test_chunks_fibres_clumps_and_follow(mesh, guides):
    inherit = ["color", "width", "stiffness", "tag"]
    params = _params(inherit=inherit, strand_count=3, clump_count=12, hue_variation=8.0, cut=0.8)
    whole = Groom(mesh, guides, params).generate()
    groom = Groom(mesh, guides, params)
    parts = [groom.generate(101, 0), groom.generate(1, 101), groom.generate(198, 102)]
    assert whole == HairCurves.concatenate(parts)
    assert whole == HairCurves.concatenate(list(groom.chunks(77)))
    # fibres take their hair's values; clumping moves vertices, not attributes
    single = Groom(mesh, guides, _params(inherit=inherit, hue_variation=8.0, cut=0.8)).generate()
    assert (whole.curve_data["strand_id"] == np.tile([0, 1, 2], single.curve_count)).all()
    for key in ("color", "width"):
        fibres = _per_hair(whole, key).reshape(
            single.curve_count, 3, *_per_hair(single, key).shape[1:]
        )
        for j in range(3):
            np.testing.assert_array_equal(fibres[:, j], _per_hair(single, key))
    for key in ("stiffness", "tag"):
        np.testing.assert_array_equal(whole.curve_data[key][::3], single.curve_data[key])
    # simulated guides move the hair; the attributes stay those of the rest guides
    moved = guides.rest_shapes(9) + guides.root_positions[:, None]
    moved = moved + np.linspace(0.0, 1.0, 9)[None, :, None] * np.array([0.1, -0.05, 0.07])
    followed = groom.follow(moved)
    assert not np.allclose(followed.points, whole.points, atol=1e-3)
    for key in ("color", "width"):
        np.testing.assert_array_equal(followed.point_data[key], whole.point_data[key])
    for key in ("stiffness", "tag"):
        np.testing.assert_array_equal(followed.curve_data[key], whole.curve_data[key])
    assert groom.regrow(whole, moved, [0, 1, 2, 3]) == followed


def test_unequal_segments_and_a_coincident_pair_resample_by_arc_length(mesh):
    """A guide as a tool exports it: segments of unequal length, two vertices at one
    place (a pair whose values jump), an integer point attribute."""
    steps = np.array([0.0, 0.01, 0.05, 0.0, 0.1, 0.02, 0.07])  # the 4th vertex repeats the 3rd
    s = np.cumsum(steps) / steps.sum()  # normalised arc length of each vertex
    curves = []
    for x, z in ROOTS:
        curves.append(np.array([x, 0.0, z]) + np.cumsum(steps)[:, None] * np.array([0.0, 1.0, 0.2]))
    rng = np.random.default_rng(4)
    value = rng.uniform(0.0, 1.0, (4, 7))
    color = np.stack([value, 1.0 - value, value**2], axis=-1).reshape(-1, 3)
    index_attr = np.tile(np.arange(7, dtype=np.int64), 4)
    hc = HairCurves.from_polylines(curves, point_data={"color": color, "knot": index_attr})
    guides = Guides(hc, mesh)
    n = 11
    t = np.linspace(0.0, 1.0, n)
    assert np.abs(t[:, None] - s[None, 2]).min() > 1e-3  # no vertex on the jump itself
    # each guide's colour at t by np.interp over its vertices' arc length
    ramps = color.reshape(4, 7, 3)
    table = np.array([[np.interp(t, s, ramps[g, :, c]) for c in range(3)] for g in range(4)])
    table = table.transpose(0, 2, 1)  # (guide, vertex, rgb)
    knot = []  # the nearest vertex; equidistant ones: the root side; of a pair, t's side
    for x in t:
        d = np.abs(x - s)
        near = np.flatnonzero(d == d.min())
        near = near[s[near] == s[near].min()]
        knot.append(near[-1] if x >= s[near[0]] else near[0])
    groom = Groom(mesh, guides, _params(vertices=n, inherit=["color", "knot"]))
    at_roots = groom.generate_at(guides.triangles, guides.bary)  # hairs on the guide roots
    np.testing.assert_allclose(_per_hair(at_roots, "color"), table, atol=2e-6)
    np.testing.assert_array_equal(_per_hair(at_roots, "knot"), np.tile(knot, (4, 1)))
    hair = groom.generate()
    index, weight = _weights(groom, hair)
    want = (weight[:, :, None, None] * table[index]).sum(1)
    np.testing.assert_allclose(_per_hair(hair, "color"), want, atol=2e-6)
    assert hair.point_data["knot"].dtype == np.int64  # every guide has the same knots
    np.testing.assert_array_equal(_per_hair(hair, "knot"), np.tile(knot, (hair.curve_count, 1)))


def test_no_inherit_changes_nothing(mesh, guides):
    bare_guides = Guides(HairCurves(guides.curves.points, guides.curves.offsets), mesh)
    plain = Groom(mesh, bare_guides, _params(clump_count=5, hue_variation=5.0)).generate()
    for g, params in (
        (bare_guides, _params(clump_count=5, hue_variation=5.0, inherit=[])),
        (guides, _params(clump_count=5, hue_variation=5.0)),  # attributes, none inherited
    ):
        hair = Groom(mesh, g, params).generate()
        assert set(hair.point_data) == {"normal", "color", "width", "opacity"}
        assert set(hair.curve_data) == set(plain.curve_data)
        assert hair == plain


def test_a_missing_or_unusable_attribute_is_refused_by_name(mesh, guides):
    with pytest.raises(InputError) as err:
        Groom(mesh, guides, _params(inherit=["colour"]))
    text = str(err.value)
    assert "[groom].inherit" in text and "'colour'" in text
    assert "['color', 'width']" in text and "['opacity', 'stiffness', 'tag']" in text
    with pytest.raises(InputError, match=r"\[groom\]\.inherit: 'normal' is made by the groom"):
        Groom(mesh, guides, _params(inherit=["normal"]))
    odd = _guides(mesh, color=np.zeros((20, 4)))
    with pytest.raises(InputError, match=r"'color' has \(4,\) value\(s\) per vertex, expected 3"):
        Groom(mesh, odd, _params(inherit=["color"]))
    groom = Groom(mesh, guides, _params())
    with pytest.raises(InputError, match=r"\[groom\]\.inherit: the guides have no attribute 'x'"):
        groom.params = groom.params.replace(inherit=["x"])
    with pytest.raises(ConfigError, match=r"\[groom\]\.inherit"):
        GroomParams(inherit=["color", "color"])


@pytest.mark.slow
def test_a_scene_grows_its_guides_colours(tmp_path):
    head = builtin_head()
    with pytest.raises(InputError, match="built-in guides have none"):
        Groom(head, load_guides("builtin:short", head), GroomParams(inherit=["color"]))
    curves = builtin_guides("short", head)
    t = np.concatenate([np.linspace(0.0, 1.0, c) for c in curves.counts])
    color = RED[None] * (1.0 - t[:, None]) + BLUE[None] * t[:, None]
    save(HairCurves(curves.points, curves.offsets, {"color": color}), tmp_path / "guides.npz")
    scene = parse_scene(
        {"guides": {"path": "guides.npz"}, "groom": {"count": 200, "inherit": ["color"]}},
        "scene.toml",
        tmp_path,
    )
    _, hair = grow(scene)
    color = hair.point_data["color"]
    roots, tips = color[hair.offsets[:-1]], color[hair.offsets[1:] - 1]
    np.testing.assert_allclose(roots, np.tile(RED, (len(roots), 1)), atol=1e-5)
    np.testing.assert_allclose(tips, np.tile(BLUE, (len(tips), 1)), atol=1e-5)
