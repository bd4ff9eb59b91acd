"""SkinMesh: evaluation in the seed's barycentric convention, poses, tangents,
closest points, validation; load_mesh round trips and errors."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from follicle.errors import FormatError, InputError
from follicle.io.mesh_load import load_mesh
from follicle.mesh.head import builtin_head
from follicle.mesh.sampling import DensitySampler
from follicle.mesh.skin import SkinMesh, SurfacePoints

TRI = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
TRI_UV = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


def _one_triangle(uvs=TRI_UV) -> SkinMesh:
    return SkinMesh(TRI, [[0, 1, 2]], uvs=uvs, name="tri")


def test_evaluate_single_triangle_by_hand():
    mesh = _one_triangle()
    sp = mesh.evaluate([0], [[0.2, 0.3]])
    assert isinstance(sp, SurfacePoints)
    # root = u·v0 + v·v1 + (1-u-v)·v2 = 0.2·(0,0,0) + 0.3·(1,0,0) + 0.5·(0,1,0)
    np.testing.assert_allclose(sp.position, [[0.3, 0.5, 0.0]])
    np.testing.assert_allclose(sp.uv, [[0.3, 0.5]])
    np.testing.assert_allclose(sp.normal, [[0.0, 0.0, 1.0]])
    np.testing.assert_allclose(sp.tangent, [[1.0, 0.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(sp.binormal, [[0.0, -1.0, 0.0]], atol=1e-12)  # T × N
    for arr in sp:
        assert arr.dtype == np.float64


def test_seed_barycentric_convention_corners():
    mesh = _one_triangle()
    sp = mesh.evaluate([0, 0, 0], [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    np.testing.assert_allclose(sp.position, TRI)  # (1,0) → v0, (0,1) → v1, (0,0) → v2
    np.testing.assert_allclose(sp.uv, TRI_UV)


def test_no_uvs_gives_zero_uv_and_fallback_tangent():
    mesh = SkinMesh(TRI + [0, 0, 0.0], [[0, 2, 1]], name="nouv")  # normal -Z
    sp = mesh.evaluate([0], [[0.3, 0.3]])
    np.testing.assert_array_equal(sp.uv, [[0.0, 0.0]])
    np.testing.assert_allclose(sp.normal, [[0, 0, -1.0]])
    assert abs(np.dot(sp.tangent[0], sp.normal[0])) < 1e-12
    np.testing.assert_allclose(mesh.face_tangents()[0], [0.0, 1.0, 0.0])  # edge v0→v1


def test_fallback_tangent_on_tilted_triangle_is_perpendicular():
    verts = np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.2], [0.1, 1.0, 0.7]])
    mesh = SkinMesh(verts, [[0, 1, 2]])
    t, n = mesh.face_tangents()[0], mesh.face_normals()[0]
    assert abs(t @ n) < 1e-12 and abs(np.linalg.norm(t) - 1) < 1e-12
    assert t @ (verts[1] - verts[0]) > 0


def test_face_tangent_from_uvs():
    verts = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0]])
    uvs = np.array([[0.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])  # uv = (-b, a) for p = a·e1 + b·e2
    mesh = SkinMesh(verts, [[0, 1, 2]], uvs=uvs)
    dpdu, dpdv, ok = mesh.face_uv_derivatives()
    assert ok[0]
    np.testing.assert_allclose(dpdu[0], [0.0, -3.0, 0.0])
    np.testing.assert_allclose(dpdv[0], [2.0, 0.0, 0.0])
    np.testing.assert_allclose(mesh.face_tangents()[0], [0.0, -1.0, 0.0])
    # a degenerate UV triangle falls back to the edge
    flat = SkinMesh(verts, [[0, 1, 2]], uvs=np.zeros((3, 2)))
    np.testing.assert_allclose(flat.face_tangents()[0], [1.0, 0.0, 0.0])


def test_posed_transform_moves_points_uv_stays_and_leaves_the_mesh_as_it_was():
    rest_mesh = _one_triangle()
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about Z
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rot, (1.0, 2.0, 3.0)
    mesh = rest_mesh.posed(transform=m)
    bary = [[0.2, 0.3], [0.6, 0.1]]
    rest = mesh.evaluate([0, 0], bary, pose="rest")
    cur = mesh.evaluate([0, 0], bary, pose="current")
    assert not mesh.at_rest and rest_mesh.at_rest and mesh.same_skin(rest_mesh)
    assert mesh.rest_vertices is rest_mesh.rest_vertices  # the rest data is shared
    np.testing.assert_allclose(cur.position, rest.position @ rot.T + (1, 2, 3))
    np.testing.assert_allclose(cur.normal, rest.normal @ rot.T, atol=1e-12)
    np.testing.assert_allclose(cur.tangent, rest.tangent @ rot.T, atol=1e-12)
    np.testing.assert_array_equal(cur.uv, rest.uv)
    np.testing.assert_array_equal(mesh.rest_vertices, TRI)
    lo, hi = mesh.bounds("current")
    np.testing.assert_allclose(lo, [0.0, 2.0, 3.0])
    np.testing.assert_allclose(hi, [1.0, 3.0, 3.0])
    np.testing.assert_allclose(  # the mesh it was made from keeps the rest pose
        rest_mesh.evaluate([0], [[0.2, 0.3]], "current").position, [[0.3, 0.5, 0]]
    )
    assert mesh.same_skin(_one_triangle().posed(vertices=TRI * 2.0))  # equal rest data
    assert not mesh.same_skin(SkinMesh(TRI * 2.0, [[0, 1, 2]]))  # another rest pose


def test_head_frames_orthonormal_and_rigid_pose_moves_them():
    mesh = builtin_head()
    tri, bary = DensitySampler(mesh).sample(400, seed=4)
    rest = mesh.evaluate(tri, bary, pose="rest")
    for vec in (rest.normal, rest.tangent, rest.binormal):
        np.testing.assert_allclose(np.linalg.norm(vec, axis=1), 1.0, atol=1e-9)
    for a, b in ((rest.normal, rest.tangent), (rest.normal, rest.binormal)):
        assert np.abs(np.sum(a * b, axis=1)).max() < 1e-9
    np.testing.assert_allclose(rest.binormal, np.cross(rest.tangent, rest.normal), atol=1e-12)
    # rotation by 2 rad about a tilted axis, then a translation
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + np.sin(2.0) * k + (1 - np.cos(2.0)) * k @ k
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rot, (-0.5, 0.25, 3.0)
    cur = mesh.posed(transform=m).evaluate(tri, bary, pose="current")
    np.testing.assert_allclose(cur.position, rest.position @ rot.T + m[:3, 3], atol=1e-5)
    for moved, still in zip(cur[1:4], rest[1:4], strict=True):
        np.testing.assert_allclose(moved, still @ rot.T, atol=1e-5)
    np.testing.assert_array_equal(cur.uv, rest.uv)


def test_posed_vertices_have_their_own_derived_data():
    rest = _one_triangle()
    assert rest.face_areas("current")[0] == pytest.approx(0.5)
    mesh = rest.posed(vertices=TRI * 2.0)
    assert mesh.face_areas("current")[0] == pytest.approx(2.0)
    assert mesh.face_areas("rest")[0] == pytest.approx(0.5)
    assert rest.face_areas("current")[0] == pytest.approx(0.5)  # cached before, unchanged
    np.testing.assert_allclose(mesh.vertices, TRI * 2.0)
    np.testing.assert_allclose(rest.vertices, TRI)


def test_posed_errors():
    mesh = _one_triangle()
    with pytest.raises(InputError, match=r"shape \(3, 3\)"):
        mesh.posed(vertices=np.zeros((4, 3)))
    with pytest.raises(InputError, match="vertex 1"):
        mesh.posed(vertices=[[0, 0, 0], [np.nan, 0, 0], [0, 1, 0]])
    with pytest.raises(InputError, match="4x4"):
        mesh.posed(transform=np.eye(3))
    with pytest.raises(InputError, match="affine"):
        mesh.posed(transform=np.ones((4, 4)))
    with pytest.raises(InputError, match="exactly one"):
        mesh.posed()
    with pytest.raises(InputError, match="pose"):
        mesh.face_normals("bind")


def test_vertex_normals_and_tangents_on_sphere():
    sphere = trimesh.creation.uv_sphere(radius=2.0, count=[24, 24])
    mesh = SkinMesh(sphere.vertices, sphere.faces)
    n = mesh.vertex_normals()
    radial = sphere.vertices / np.linalg.norm(sphere.vertices, axis=1, keepdims=True)
    assert np.min(np.sum(n * radial, axis=1)) > 0.99
    t = mesh.vertex_tangents()
    assert np.abs(np.sum(t * n, axis=1)).max() < 1e-9
    assert mesh.face_areas().sum() == pytest.approx(4 * np.pi * 4, rel=0.02)


def test_closest_points_exact():
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    mesh = SkinMesh(sphere.vertices, sphere.faces)
    rng = np.random.default_rng(1)
    q = rng.normal(size=(300, 3))
    q *= (rng.uniform(0.05, 0.3, size=300) / np.linalg.norm(q, axis=1))[:, None]
    tri, bary, dist = mesh.closest_points(q)
    brute = np.full(len(q), np.inf)
    for k in range(len(sphere.faces)):
        c = trimesh.triangles.closest_point(np.repeat(sphere.triangles[k : k + 1], len(q), 0), q)
        brute = np.minimum(brute, np.linalg.norm(c - q, axis=1))
    np.testing.assert_allclose(dist, brute, atol=1e-12)
    pos = mesh.evaluate(tri, bary).position
    np.testing.assert_allclose(np.linalg.norm(pos - q, axis=1), dist, atol=1e-12)
    # points on the surface come back where they are
    on = mesh.evaluate(tri, bary).position
    tri2, bary2, dist2 = mesh.closest_points(on)
    assert dist2.max() < 1e-12
    np.testing.assert_allclose(mesh.evaluate(tri2, bary2).position, on, atol=1e-12)


@pytest.mark.slow
def test_closest_points_far_from_the_skin_test_few_candidates_at_once(monkeypatch):
    """A point far from the skin (guides in other units, a hostile file's roots) has
    nearly every triangle as a candidate: 4,096 of them at once held gigabytes (a
    2.5 MB guide file ran out of 2 GiB). Runs of at most MAX_CANDIDATES are tested
    at once, with the same exact result."""
    import tracemalloc

    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.1)  # 1,280 triangles
    mesh = SkinMesh(sphere.vertices, sphere.faces)
    q = np.random.default_rng(2).normal(size=(4096, 3)) * 100.0
    mesh.closest_points(q[:1])  # the trees, cached, and the kernel: not counted
    monkeypatch.setattr("follicle.mesh.skin.MAX_CANDIDATES", 1 << 40)
    whole = mesh.closest_points(q)
    monkeypatch.setattr("follicle.mesh.skin.MAX_CANDIDATES", 20_000)
    tracemalloc.start()
    try:
        runs = mesh.closest_points(q)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    for a, b in zip(whole, runs, strict=True):
        np.testing.assert_array_equal(a, b)
    assert peak < 16 << 20, f"{peak / 2**20:.0f} MiB for 4,096 points"  # 5.2 M candidates: 0.5 GB


def test_degenerate_faces_reported():
    verts = np.vstack([TRI, [[2.0, 0.0, 0.0]]])
    mesh = SkinMesh(verts, [[0, 1, 2], [0, 1, 3]])  # second is collinear
    assert mesh.degenerate_faces.tolist() == [False, True]
    assert mesh.face_areas().tolist() == [0.5, 0.0]
    with pytest.raises(InputError, match="zero area"):
        SkinMesh(verts, [[0, 1, 3]])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"faces": np.zeros((0, 3), int)}, "has no faces"),
        ({"vertices": [[0, 0, 0], [1, 0, np.inf], [0, 1, 0]]}, "vertex 1 is not finite"),
        ({"faces": [[0, 1, 3]]}, "face 0 .* outside"),
        ({"faces": [[0, 1, -1]]}, "outside"),
        ({"vertices": np.zeros((3, 2))}, r"vertices must have shape \(V, 3\)"),
        ({"faces": [[0, 1, 2, 0]]}, r"faces must have shape \(F, 3\)"),
        ({"uvs": np.zeros((2, 2))}, r"uvs must have shape \(3, 2\)"),
        ({"uvs": [[0, 0], [np.nan, 0], [0, 1]]}, "uv 1 is not finite"),
        ({"textures": {"scalp": np.ones((2, 2))}}, "not a Texture"),
    ],
)
def test_validation_errors(kwargs, message):
    args = {"vertices": TRI, "faces": [[0, 1, 2]], "name": "bad"} | kwargs
    with pytest.raises(InputError, match=message):
        SkinMesh(**args)


def test_evaluate_errors():
    mesh = _one_triangle()
    with pytest.raises(InputError, match="out of range"):
        mesh.evaluate([1], [[0.2, 0.2]])
    with pytest.raises(InputError, match="bary"):
        mesh.evaluate([0], [[0.9, 0.9]])
    with pytest.raises(InputError, match="bary"):
        mesh.evaluate([0], [[0.2]])


def test_repr_and_trimesh():
    mesh = _one_triangle()
    assert "SkinMesh('tri', 3 vertices, 1 faces, uvs" in repr(mesh)
    tm = mesh.to_trimesh()
    np.testing.assert_array_equal(tm.vertices, TRI)
    np.testing.assert_array_equal(tm.visual.uv, TRI_UV)


# ---------------------------------------------------------------------- load_mesh
def _grid(n: int = 4) -> trimesh.Trimesh:
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    verts = np.stack([x.ravel(), y.ravel(), 0.1 * x.ravel() * y.ravel()], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    faces = np.concatenate(
        [np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)]
    )
    uv = verts[:, :2].copy()
    return trimesh.Trimesh(verts, faces, visual=trimesh.visual.TextureVisuals(uv=uv), process=False)


def test_load_obj_with_uvs(tmp_path):
    src = _grid()
    src.export(tmp_path / "grid.obj")
    mesh = load_mesh(tmp_path / "grid.obj")
    assert mesh.name == "grid" and mesh.face_count == len(src.faces)
    assert mesh.uvs is not None
    np.testing.assert_allclose(mesh.uvs, mesh.rest_vertices[:, :2], atol=1e-6)  # uv = (x, y)
    assert mesh.face_areas().sum() == pytest.approx(src.area, rel=1e-6)


@pytest.mark.parametrize("ext", ["ply", "stl", "off"])
def test_load_ply_stl_off(tmp_path, ext):
    src = trimesh.creation.icosphere(subdivisions=1, radius=0.5)
    path = tmp_path / f"ball.{ext}"
    src.export(path)
    mesh = load_mesh(str(path))
    assert mesh.face_count == len(src.faces)
    assert mesh.face_areas().sum() == pytest.approx(src.area, rel=1e-5)


def test_load_errors(tmp_path):
    with pytest.raises(FormatError, match="nope.obj"):
        load_mesh(tmp_path / "nope.obj")
    with pytest.raises(FormatError, match=r"\.fbx.*\.obj, \.ply"):
        load_mesh(tmp_path / "model.fbx")
    (tmp_path / "junk.ply").write_bytes(b"\x00\x13garbage" * 50)
    with pytest.raises(FormatError, match="junk.ply"):
        load_mesh(tmp_path / "junk.ply")
    (tmp_path / "junk.obj").write_text("this is not\na mesh\n")
    with pytest.raises(FormatError, match="junk.obj"):
        load_mesh(tmp_path / "junk.obj")
    with pytest.raises(FormatError, match="builtin:head"):
        load_mesh("builtin:torso")
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(InputError, match=r"nan.obj.*vertex 1"):
        load_mesh(tmp_path / "nan.obj")
    (tmp_path / "pts.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(InputError, match=r"pts.obj.*no faces"):
        load_mesh(tmp_path / "pts.obj")


def test_load_builtin_head():
    mesh = load_mesh("builtin:head")
    assert mesh.name == "head" and "scalp" in mesh.textures
