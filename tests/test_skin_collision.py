"""[groom].skin_collision: grown hairs pushed off the skin with their lengths kept,
measured against the exact surface (a plane's height, the bust's closest points)."""

from __future__ import annotations

import numpy as np
import pytest

from follicle import ConfigError, HairCurves
from follicle.groom.generator import Groom
from follicle.groom.guides import Guides
from follicle.mesh.skin import SkinMesh
from follicle.mesh.texture import Texture
from follicle.scene import GroomParams
from meshes import plane


def _diving_guides(mesh, n: int = 4, vertices: int = 12) -> Guides:
    """An n×n grid of guides on the unit plane that rise 4 cm and dive 6 cm through it."""
    g = np.linspace(0.3, 0.7, n)
    s = np.linspace(0.0, 1.0, vertices)
    arc = np.stack([0.25 * s, 0.4 * s * (0.4 - s), np.zeros_like(s)], axis=1)
    curves = [np.array([x, 0.0, z]) + arc for x in g for z in g]
    return Guides(HairCurves.from_polylines(curves), mesh)


# roots in the plane's middle only (u, v in 0.25 … 0.625): no hair reaches past its
# edge, where an open mesh's field has no inside or outside to speak of
_MIDDLE = Texture(np.pad(np.ones((6, 6)), 5), wrap="clamp", name="middle")


def _lengths(hair: HairCurves) -> np.ndarray:
    """Each hair's polyline length (float64 from the float32 points)."""
    p = hair.points.astype(np.float64)
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    inside = np.ones(len(seg), bool)
    inside[hair.offsets[1:-1] - 1] = False  # the joins between hairs
    return np.add.reduceat(np.where(inside, seg, 0.0), hair.offsets[:-1])


@pytest.fixture(scope="module")
def diving():
    mesh = plane(8)
    guides = _diving_guides(mesh)
    grow = {
        on: Groom(mesh, guides, GroomParams(skin_collision=on), density=_MIDDLE)
        for on in (False, True)
    }
    return {on: groom.generate(2000) for on, groom in grow.items()}, grow


def test_hairs_through_a_plane_end_above_it_with_their_lengths(diving):
    hair, _ = diving
    off, on = hair[False], hair[True]
    assert off.points[:, 1].min() < -0.03  # grown as interpolated: 3 cm through the plane
    np.testing.assert_array_equal(off.offsets, on.offsets)
    above = np.delete(on.points[:, 1], on.offsets[:-1])  # all but the roots (on it)
    assert above.min() > 0.0  # the plane's signed distance is y
    # lengths kept (float32 points: ~1e-7 of a 30 cm hair)
    np.testing.assert_allclose(_lengths(on), _lengths(off), rtol=1e-6)
    # roots stay where they grow, on the plane
    np.testing.assert_array_equal(on.points[on.offsets[:-1]], off.points[off.offsets[:-1]])


def test_vertices_nearer_than_the_clearance_are_pushed_to_it():
    mesh = plane(8)
    guides = _diving_guides(mesh)
    groom = Groom(mesh, guides, GroomParams(skin_clearance=0.005), density=_MIDDLE)
    hair = groom.generate(500)
    tips = hair.points[hair.offsets[1:] - 1]
    # the field of a flat plane is exact: a pushed tip sits at the clearance, give or
    # take the push-outs' last step
    assert tips[:, 1].min() > 0.005 - 1e-4


def test_collision_is_deterministic_and_per_hair(diving):
    hair, grow = diving
    again = grow[True].generate(2000)
    np.testing.assert_array_equal(again.points, hair[True].points)
    parts = [grow[True].generate(count, start) for start, count in ((0, 700), (700, 1300))]
    joined = HairCurves.concatenate(parts)
    np.testing.assert_array_equal(joined.points, hair[True].points)
    np.testing.assert_array_equal(joined.offsets, hair[True].offsets)


def test_hairs_clear_of_the_skin_keep_their_bytes():
    """Straight guides standing on the plane: nothing comes near it, nothing changes."""
    mesh = plane(8)
    g = np.linspace(0.2, 0.8, 4)
    s = np.linspace(0.0, 1.0, 9)[:, None]
    curves = [np.array([x, 0.0, z]) + s * np.array([0.1, 1.0, 0.0]) * 0.3 for x in g for z in g]
    guides = Guides(HairCurves.from_polylines(curves), mesh)
    off = Groom(mesh, guides, GroomParams(skin_collision=False)).generate(500)
    on = Groom(mesh, guides, GroomParams()).generate(500)
    np.testing.assert_array_equal(on.points, off.points)
    np.testing.assert_array_equal(on.point_data["normal"], off.point_data["normal"])


def test_skin_clearance_is_checked():
    with pytest.raises(
        ConfigError, match=r"\[groom\]\.skin_clearance: .*greater than or equal to 0"
    ):
        GroomParams(skin_clearance=-0.001)


def test_a_mesh_facing_away_from_the_hair_keeps_it_on_its_side():
    """Faces wound the other way (normals into the skin, as some imported meshes have):
    the guides grow on the field's inner side, and the hair is kept on that side rather
    than crushed through the mesh."""
    flat = plane(8)
    mesh = SkinMesh(flat.rest_vertices, flat.faces[:, ::-1], uvs=flat.uvs, name="back")
    hair = Groom(mesh, _diving_guides(mesh), GroomParams(), density=_MIDDLE).generate(500)
    above = np.delete(hair.points[:, 1], hair.offsets[:-1])
    assert above.min() > 0.0
