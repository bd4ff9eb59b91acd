"""The built-in bust (``builtin:bust``): a closed, consistently wound mesh of the size of
the built-in head plus neck and shoulders, with a seamless scalp chart, a scalp map that
is 1 on the scalp and 0 elsewhere, a signed distance that agrees with the mesh, and the
built-in guides grown on it."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import trimesh

import follicle
from follicle.groom.generator import load_texture
from follicle.mesh.bust import BUST_DATA, UV_CENTRE, bust_inside, bust_signed_distance
from follicle.mesh.head import PARTING_TEXTURE, SCALP_TEXTURE
from meshes import winding_number


@pytest.fixture(scope="module")
def bust():
    return follicle.load_mesh("builtin:bust")


def _welded(bust) -> trimesh.Trimesh:
    """The bust with its UV-seam copies merged: the closed surface."""
    return trimesh.Trimesh(bust.rest_vertices, bust.faces, process=True)


def _nearest(bust, point) -> int:
    return int(np.argmin(np.linalg.norm(bust.rest_vertices - np.asarray(point), axis=1)))


def test_the_bust_is_a_head_on_shoulders_of_the_built_in_heads_size(bust):
    head = follicle.load_mesh("builtin:head")
    assert bust.name == "bust" and 15_000 <= len(bust.faces) <= 40_000
    lo, hi = bust.bounds("rest")
    hlo, hhi = head.bounds("rest")
    assert abs(hi[1] - hhi[1]) < 0.005  # crown, within 5 mm of the head's (y = 0.12)
    assert hi[1] == pytest.approx(0.12, abs=0.005)
    assert lo[1] == pytest.approx(-0.40, abs=0.002)  # the flat cut
    assert 0.19 < hi[0] < 0.23 and 0.19 < -lo[0] < 0.23  # shoulders
    v = bust.rest_vertices
    face = v[(np.abs(v[:, 0]) < 0.01) & (v[:, 2] > 0.065) & (v[:, 1] > -0.2)]
    assert face[:, 1].min() == pytest.approx(-0.11, abs=0.006)  # chin
    # the nose tip (the face's most forward point, below the eyes): within 6 mm of the
    # head's; above the eyes, the brow within 16 mm of it
    assert v[v[:, 1] > -0.15, 2].max() == pytest.approx(hhi[2], abs=0.006)
    assert v[v[:, 1] > 0.0, 2].max() == pytest.approx(hhi[2], abs=0.016)


def test_the_bust_is_closed_consistently_wound_and_without_degenerate_triangles(bust):
    mesh = _welded(bust)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0.0  # outward normals
    assert mesh.euler_number == 2  # one sphere: no handles
    edges = np.linalg.norm(np.diff(bust.rest_vertices[bust.faces[:, [0, 1, 2, 0]]], axis=1), axis=2)
    twice_area = np.linalg.norm(
        np.cross(
            *(
                bust.rest_vertices[bust.faces[:, 1:]].transpose(1, 0, 2)
                - bust.rest_vertices[bust.faces[:, 0]]
            )
        ),
        axis=1,
    )
    assert (twice_area / edges.max(axis=1) ** 2).min() > 1e-3  # no needles or slivers
    assert edges.min() > 1e-5


def test_uvs_lie_in_the_unit_square_and_no_triangle_jumps_a_seam(bust):
    uv = bust.uvs
    assert uv.min() >= 0.0 and uv.max() <= 1.0
    span = np.ptp(uv[bust.faces], axis=1).max(axis=1)
    # the longest triangles in UV space touch a pole (the ears), where a quarter turn of
    # v is a few millimetres: a quarter, 0.25, at most
    assert span.max() <= 0.25 + 1e-6
    # on the scalp the largest triangles, 3 cm across at 12 cm from the centre, span
    # 0.03 / 0.12 / π ≈ 0.08 of u; a seam would jump by up to 1
    scalp = bust.textures[SCALP_TEXTURE].sample(bust.uvs)
    on_scalp = scalp[bust.faces].min(axis=1) > 0.0
    assert span[on_scalp].max() < 0.1


def test_scalp_map_is_one_on_the_scalp_and_zero_on_face_ears_neck_and_body(bust):
    density = bust.textures[SCALP_TEXTURE]
    places = {
        (0.0, 0.12, -0.01): 1.0,  # crown
        (0.0, 0.02, -0.11): 1.0,  # back of the head
        (0.06, 0.08, -0.02): 1.0,  # above the ear
        (0.0, 0.0, 0.09): 0.0,  # between the eyes
        (0.0, -0.03, 0.11): 0.0,  # nose
        (0.09, -0.005, -0.012): 0.0,  # ear
        (0.0, -0.15, -0.07): 0.0,  # nape of the neck, below the hairline
        (0.175, -0.21, 0.0): 0.0,  # shoulder
        (0.0, -0.30, 0.09): 0.0,  # chest
    }
    for point, want in places.items():
        i = _nearest(bust, point)
        assert np.linalg.norm(bust.rest_vertices[i] - point) < 0.012, point
        assert density.sample(bust.uvs[i : i + 1])[0] == pytest.approx(want, abs=1e-6), point


def test_the_parting_groups_split_at_the_mid_plane(bust):
    rgb = bust.textures[PARTING_TEXTURE].sample(bust.uvs)
    x = bust.rest_vertices[:, 0]
    away = np.abs(x) > 0.003
    red = rgb[:, 0] > 0.5
    assert np.array_equal(red[away], x[away] < 0.0)
    assert load_texture("builtin:parting", mesh=bust) is bust.textures[PARTING_TEXTURE]
    assert load_texture("builtin:scalp", mesh=bust) is bust.textures[SCALP_TEXTURE]


def test_the_ears_stand_out_from_the_head_between_brow_and_nose_base(bust):
    v = bust.rest_vertices
    level = np.abs(v[:, 1]) < 0.005
    cheek = v[level & (v[:, 2] > 0.03), 0]  # the face in front of the ears
    assert np.abs(v[level, 0]).max() > np.abs(cheek).max() + 0.01
    ear = v[(np.abs(v[:, 0]) > 0.08) & (v[:, 1] > -0.1)]
    assert 0.02 < ear[:, 1].max() < 0.04  # top of the ear ≈ brow line (y ≈ 0.03)
    assert -0.045 < ear[:, 1].min() < -0.02  # bottom ≈ nose base (y ≈ -0.035)


@pytest.mark.slow
def test_signed_distance_agrees_with_the_mesh(bust):
    mesh = _welded(bust)
    rng = np.random.default_rng(4)
    lo, hi = bust.bounds("rest")
    points = rng.uniform(lo - 0.02, hi + 0.02, size=(300, 3))
    d = bust_signed_distance(points)
    far = np.abs(d) > 0.002  # the mesh follows the field to well within 2 mm
    inside = winding_number(mesh.triangles, points[far]) > 0.5
    assert far.sum() > 250
    assert np.array_equal(inside, d[far] < 0.0)
    assert np.array_equal(bust_inside(points[far]), inside)
    assert np.abs(bust_signed_distance(bust.rest_vertices)).max() < 1e-3


def test_the_package_data_is_small():
    data = resources.files("follicle.mesh").joinpath(BUST_DATA)
    assert len(data.read_bytes()) < 1_000_000


@pytest.mark.slow
def test_built_in_long_guides_grow_on_the_bust_scalp_and_stay_outside(bust):
    guides = follicle.load_guides("builtin:long", bust)
    curves = guides.curves
    roots = curves.curve_data["root_uv"]
    assert bust.textures[SCALP_TEXTURE].sample(roots).min() > 0.5
    points = curves.points
    assert bust_signed_distance(points).min() > -0.001
    # long hair falls past the head onto the shoulders and back
    assert points[:, 1].min() < -0.15


def test_no_hair_grows_on_or_beside_the_ears(bust):
    """The UV poles lie in the ears, where texels of ear and head crowd together: the
    scalp map keeps 10 mm clear of each ear's flap (before, 6 of its 304 vertices had
    density up to 0.15 and hairs stuck out from the ears)."""
    from follicle.mesh.bust import ear_distance

    hair = follicle.Groom(bust, follicle.load_guides("builtin:long", bust)).generate(20000)
    roots = hair.points[hair.offsets[:-1]]
    assert ear_distance(roots).min() >= 0.0095  # a root's interpolation, half a texel
    density = bust.textures[SCALP_TEXTURE].sample(bust.uvs)
    assert density[ear_distance(bust.rest_vertices) < 0.010].max() < 0.01  # bilinear taps


def test_the_hair_bearing_scalp_keeps_its_surface():
    """The face and ears may be remodelled, the scalp may not: guide roots, the shipped
    hand-groomed guides and the settled demo sit on it. ``data/bust_scalp_radius.npz``
    holds, for each scalp-map texel with density > 0, where the bust of commit 40444bc
    (before the face was remodelled) met the texel's ray from the UV centre: the distance
    along the ray in 10 µm steps, each row stored as differences along it (0 off the
    scalp). The ray follows the UV map's definition (u the angle from +X over π,
    v = 1/2 + atan2(z, y) / 2π). Every such point must lie within 0.5 mm of today's bust,
    by its signed distance; and every texel the shipped scalp map gives hair has one."""
    with np.load(Path(__file__).parent / "data" / "bust_scalp_radius.npz") as data:
        radius = np.cumsum(data["radius_steps"], axis=1, dtype=np.int64) * 1e-5
    with np.load(resources.files("follicle.mesh").joinpath(BUST_DATA)) as data:
        hair = data["scalp"] > 0.0
    n = len(hair)
    assert radius.shape == (n, n) and hair.sum() > 20_000
    assert np.all(radius[hair] > 0.0)  # no hair where the old bust had none
    c = (np.arange(n) + 0.5) / n
    u = np.broadcast_to(c[None, :], (n, n))[hair]
    v = np.broadcast_to(1.0 - c[:, None], (n, n))[hair]  # rows run from v = 1 down
    a, phi = np.pi * u, 2.0 * np.pi * (v - 0.5)
    ray = np.stack([np.cos(a), np.sin(a) * np.cos(phi), np.sin(a) * np.sin(phi)], axis=1)
    before = np.asarray(UV_CENTRE) + radius[hair][:, None] * ray
    assert np.abs(bust_signed_distance(before)).max() < 0.0005
