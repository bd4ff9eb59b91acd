"""The built-in head: closed, sized like a head, outward normals, scalp map, SDF."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from follicle.errors import InputError
from follicle.mesh.head import (
    SCALP_TEXTURE,
    builtin_head,
    head_inside,
    head_signed_distance,
)
from follicle.mesh.texture import Texture


@pytest.fixture(scope="module")
def head():
    return builtin_head()


def test_size_and_triangles(head):
    assert head.name == "head"
    assert 3000 <= head.face_count <= 8000
    assert not head.degenerate_faces.any()
    lo, hi = head.bounds()
    assert 0.11 <= hi[1] <= 0.13  # crown
    assert -0.25 <= lo[1] <= -0.21  # bottom of the neck
    width_skull = np.ptp(head.vertices[np.abs(head.vertices[:, 1] - 0.06) < 0.01, 0])
    assert 0.14 <= width_skull <= 0.18
    assert 0.18 <= hi[2] - lo[2] <= 0.25  # back of the head to the nose tip
    assert hi[2] > 0.1  # the nose points to +Z


def test_closed_and_outward(head):
    welded = trimesh.Trimesh(head.vertices, head.faces)  # merges the UV-seam copies
    assert welded.is_watertight and welded.is_winding_consistent
    assert welded.euler_number == 2
    assert 0.003 < welded.volume < 0.007  # litres: a head and neck
    centres = head.vertices[head.faces].mean(axis=1)
    outward = np.sum(head.face_normals() * centres, axis=1) > 0
    assert outward.mean() > 0.9
    vn = head.vertex_normals()
    assert (np.sum(vn * head.vertices, axis=1) > 0).mean() > 0.9


def test_uvs_cover_unit_square(head):
    assert head.uvs is not None
    assert head.uvs.min() >= 0.0 and head.uvs.max() <= 1.0
    # no face wraps around the seam in u
    fu = head.uvs[head.faces, 0]
    assert np.ptp(fu, axis=1).max() < 0.1


def test_seam_normals_are_welded(head):
    _, inverse = np.unique(head.rest_vertices, axis=0, return_inverse=True)
    counts = np.bincount(inverse.ravel())
    dup = np.flatnonzero(counts[inverse.ravel()] > 1)
    vn = head.vertex_normals()
    groups = inverse.ravel()[dup]
    first = {}
    for i, g in zip(dup, groups, strict=True):
        first.setdefault(g, i)
        np.testing.assert_allclose(vn[i], vn[first[g]], atol=1e-12)


def _surface_along(directions) -> np.ndarray:
    """Head surface points along rays from the origin, by bisection on head_inside."""
    d = np.asarray(directions, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    lo, hi = np.zeros(len(d)), np.full(len(d), 0.5)
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        inside = head_inside(d * mid[:, None])
        lo, hi = np.where(inside, mid, lo), np.where(inside, hi, mid)
    return d * hi[:, None]


def _density_along(head, directions) -> np.ndarray:
    surface = _surface_along(directions)
    tri, bary, dist = head.closest_points(surface)
    assert dist.max() < 0.002
    return head.textures[SCALP_TEXTURE].sample(head.evaluate(tri, bary).uv)


def test_scalp_density(head):
    tex = head.textures[SCALP_TEXTURE]
    assert isinstance(tex, Texture) and tex.shape == (256, 256, 1)
    assert tex.data.min() >= 0.0 and tex.data.max() <= 1.0
    face = _density_along(head, [[0.0, 0.0, 1.0], [0.3, 0.0, 1.0], [0.0, -0.6, 1.0]])
    np.testing.assert_allclose(face, 0.0, atol=1e-6)  # eye height at the front, cheek, mouth
    scalp = _density_along(head, [[0.0, 1.0, 0.0], [0.0, 0.3, -1.0], [1.0, 0.9, -0.1]])
    np.testing.assert_allclose(scalp, 1.0, atol=1e-6)  # crown, back, side above the ear
    bare = _density_along(head, [[0.0, -5.0, 1.0], [0.0, -2.0, -1.0], [1.0, 0.02, -0.15]])
    np.testing.assert_allclose(bare, 0.0, atol=1e-6)  # neck front and back, ear
    # a soft forehead hairline: 0 at the brows, 1 well above, ramping near y = 8 cm
    angles = np.radians(np.linspace(10, 70, 61))
    dirs = np.stack([np.zeros_like(angles), np.sin(angles), np.cos(angles)], 1)
    ys = _surface_along(dirs)[:, 1]
    line = _density_along(head, dirs)
    assert line[0] == 0.0 and line[-1] == pytest.approx(1.0)
    assert np.all(np.diff(line) >= -1e-6)
    ramp = ys[(line > 0.05) & (line < 0.95)]
    assert 0.07 < ramp.min() and ramp.max() < 0.1 and np.ptp(ramp) < 0.02


def test_signed_distance_and_inside(head):
    assert head_signed_distance(head.vertices).__abs__().max() < 1e-9
    n = head.vertex_normals()
    sd_out = head_signed_distance(head.vertices + 0.005 * n)
    sd_in = head_signed_distance(head.vertices - 0.005 * n)
    assert np.median(sd_out) == pytest.approx(0.005, abs=0.001)
    assert np.median(sd_in) == pytest.approx(-0.005, abs=0.001)
    assert head_inside([[0.0, 0.0, 0.0], [0.0, -0.2, -0.02]]).tolist() == [True, True]
    assert head_inside([[0.0, 0.2, 0.0], [0.2, -0.2, 0.0]]).tolist() == [False, False]
    with pytest.raises(InputError, match="points"):
        head_signed_distance(np.zeros((2, 2)))


def test_deterministic():
    a, b = builtin_head(), builtin_head()
    assert a is not b
    assert a.rest_vertices.tobytes() == b.rest_vertices.tobytes()
    assert a.faces.tobytes() == b.faces.tobytes()
    assert a.textures[SCALP_TEXTURE].data.tobytes() == b.textures[SCALP_TEXTURE].data.tobytes()
