"""Interpolation groups: colours to ids, partings that never mix, per-group vertex counts."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from follicle import HairCurves, InputError
from follicle.groom.generator import Groom
from follicle.groom.groups import InterpolationGroups
from follicle.groom.guides import Guides
from follicle.mesh.skin import SkinMesh
from follicle.mesh.texture import Texture
from follicle.scene import GroomParams
from meshes import plane as _plane

RED, BLUE, GREEN = (255, 0, 0), (0, 0, 255), (0, 255, 0)


def _split_texture(left=RED, right=BLUE, size: int = 8) -> Texture:
    """Left half of UV space (u < 0.5) one colour, right half another."""
    rgb = np.zeros((size, size, 3), np.uint8)
    rgb[:, : size // 2] = left
    rgb[:, size // 2 :] = right
    return Texture(rgb, wrap="clamp", name="split")


def _combed_guides(mesh: SkinMesh, groups: InterpolationGroups | None) -> Guides:
    """Guides on a grid; those at x < 0.5 lean to −x, the others to +x (a parting)."""
    lines = []
    for x in np.linspace(0.05, 0.95, 10):
        for z in np.linspace(0.05, 0.95, 5):
            lean = -0.3 if x < 0.5 else 0.3
            lines.append(np.array([[x, 0, z], [x + lean * 0.5, 0.2, z], [x + lean, 0.3, z]]))
    return Guides(HairCurves.from_polylines(lines), mesh, groups=groups)


def test_colours_become_groups_in_order_of_first_appearance():
    rgb = np.zeros((4, 4, 3), np.uint8)
    rgb[:] = BLUE
    rgb[0, 0] = GREEN  # the first texel (top-left) → group 0
    rgb[3, 3] = RED
    groups = InterpolationGroups(Texture(rgb, wrap="clamp"))
    assert groups.count == 3
    assert [groups.label(g) for g in range(3)] == ["#00ff00", "#0000ff", "#ff0000"]
    # nearest texel, v = 0 at the bottom row: (0.1, 0.9) is the top-left texel
    ids = groups.group_of(np.array([[0.1, 0.9], [0.5, 0.5], [0.9, 0.1], [1.5, -3.0]]))
    np.testing.assert_array_equal(ids, [0, 1, 2, 2])
    assert InterpolationGroups().group_of(np.zeros((3, 2))).tolist() == [0, 0, 0]


def test_group_vertices_are_validated_against_the_colours():
    tex = _split_texture()
    groups = InterpolationGroups(tex, {"#FF0000": 7})
    assert groups.vertex_count(0, 5) == 7 and groups.vertex_count(1, 5) == 5
    with pytest.raises(InputError, match=r"no interpolation group has colour '#00ff00'.*#0000ff"):
        InterpolationGroups(tex, {"#00ff00": 7})
    with pytest.raises(
        InputError,
        match=r"group_vertices\['#ff0000'\]: expected a whole number of vertices ≥ 2 \(got 1\)",
    ):
        InterpolationGroups(tex, {"#ff0000": 1})


def test_a_parting_never_mixes_groups():
    mesh = _plane()
    params = GroomParams(count=4000, guide_samples=4)
    parted = Groom(mesh, _combed_guides(mesh, InterpolationGroups(_split_texture())), params)
    hair = parted.generate()
    roots_x = hair.points[hair.offsets[:-1], 0]
    lean = hair.points[hair.offsets[1:] - 1, 0] - roots_x
    left = roots_x < 0.5
    # every hair leans the way of its own side's guides, right up to the parting line
    assert lean[left].max() < -0.29 and lean[~left].min() > 0.29
    # without groups the hairs near the parting blend both sides
    blended = Groom(mesh, _combed_guides(mesh, None), params).generate()
    near = np.abs(blended.points[blended.offsets[:-1], 0] - 0.5) < 0.05
    blended_lean = (
        blended.points[blended.offsets[1:] - 1, 0] - blended.points[blended.offsets[:-1], 0]
    )
    assert np.abs(blended_lean[near]).min() < 0.2


def test_each_group_has_its_own_vertex_count():
    mesh = _plane()
    groups = InterpolationGroups(_split_texture(), {"#0000ff": 9})
    groom = Groom(mesh, _combed_guides(mesh, groups), GroomParams(count=500, vertices=4))
    hair = groom.generate()
    left = hair.curve_data["root_uv"][:, 0] < 0.5
    assert set(hair.counts[left]) == {4} and set(hair.counts[~left]) == {9}
    assert len(hair.point_data["width"]) == hair.point_count
    # a hair's shape does not depend on which other hairs share its chunk
    np.testing.assert_array_equal(groom.generate(count=200).points, hair[:200].points)


def test_a_group_without_guides_is_an_error_naming_its_colour(caplog):
    mesh = _plane()
    rgb = np.zeros((8, 8, 3), np.uint8)
    rgb[:] = RED
    rgb[:, 6:] = GREEN  # u ≥ 0.75 is green, and every guide root is at u ≤ 0.3
    guides = [np.array([[x, 0, 0.5], [x, 0.2, 0.5]]) for x in (0.1, 0.2, 0.3)]
    groups = InterpolationGroups(Texture(rgb, wrap="clamp"))
    g = Guides(HairCurves.from_polylines(guides), mesh, groups=groups)
    with pytest.raises(InputError, match="interpolation group #00ff00 has hairs but no guides"):
        Groom(mesh, g, GroomParams(count=1000)).generate()
    with caplog.at_level(logging.WARNING, logger="follicle"):
        only_red = Texture(np.full((2, 2, 3), 255, np.uint8) * np.array([1, 0, 0], np.uint8))
        g = Guides(HairCurves.from_polylines(guides), mesh, groups=InterpolationGroups(only_red))
        Groom(mesh, g, GroomParams(count=10, guide_samples=4)).generate()
    assert "has 3 guide(s), fewer than the 4 its hairs blend (idw)" in caplog.text


def test_guides_far_from_the_mesh_warn_with_the_distance(caplog):
    mesh = _plane()
    lines = [np.array([[0.5, 0.3, 0.5], [0.5, 0.5, 0.5]]), np.array([[0.2, 0, 0.2], [0.2, 1, 0.2]])]
    with caplog.at_level(logging.WARNING, logger="follicle"):
        guides = Guides(HairCurves.from_polylines(lines), mesh)
    assert "1 root(s) lie off mesh 'plane' (farthest: guide 0, 0.3 away" in caplog.text
    np.testing.assert_allclose(guides.root_positions[0], [0.5, 0.0, 0.5], atol=1e-9)
    with pytest.raises(InputError, match="vertex 1 is not finite"):  # NaN guides never load
        HairCurves.from_polylines([np.array([[0, 0, 0], [np.nan, 1, 0]])])


@pytest.mark.slow
def test_builtin_guides_on_the_builtin_head_part_by_default():
    """Unset groups on the built-in head with built-in guides mean builtin:parting: the
    hairs rooted on the mid-line then keep out of the skull; "none" turns groups off and
    those hairs blend a left- and a right-combed guide into the head again. Skin
    collision is off: it would push them out again, hiding what the groups do."""
    from follicle.mesh.sdf import SDF
    from follicle.pipeline import groom_scene
    from follicle.scene import Scene
    from follicle.sim.collision import clearance, colliders

    def deepest(groups: str | None) -> tuple[int, float]:
        groom = {"groups": groups, "skin_collision": False}
        groom = groom_scene(Scene(mesh={"path": "builtin:head"}, groom=groom))
        hair = groom.generate(count=6000)
        sdf = SDF.from_mesh(groom.mesh.vertices, groom.mesh.faces)
        x = hair.points.reshape(hair.curve_count, -1, 3)
        depth = -clearance(x[:, 1:], colliders([], sdf.sample_args))
        return groom.guides.groups.count, float(depth.max())

    groups, depth = deepest(None)
    assert groups == 2 and depth < 0.006  # at most the SDF's voxel, on the parting
    assert deepest("builtin:parting") == (groups, depth)
    groups, depth = deepest("none")
    assert groups <= 1 and depth > 0.03  # through the skull
