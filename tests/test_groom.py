import numpy as np
import pytest

from follicle import HairCurves, InputError
from follicle.groom.generator import Groom
from follicle.groom.guides import Guides, resample_arclength
from follicle.groom.interpolate import blend_guides, idw_weights
from follicle.mesh.skin import SkinMesh
from follicle.scene import GroomParams


def _plane(size=1.0):
    """A square in the XZ plane facing +Y, UV-mapped, two triangles."""
    v = np.array([[0, 0, 0], [size, 0, 0], [size, 0, size], [0, 0, size]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    return SkinMesh(v, f, uvs=uv, name="plane")


def _upright_guides(mesh, xs, length=0.2, n=5):
    lines = [np.array([[x, 0, z], [x, length, z]]) for x, z in xs]
    return Guides(HairCurves.from_polylines(lines), mesh, n)


def test_idw_weights_match_hand_computed_values():
    guides = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], float)
    idx, w = idw_weights(guides, np.array([[0.5, 0, 0]]), samples=2)
    # distances 0.5, 0.5, 1.5 → r = 1.5; w = ((r-d)/(r d))² = (1/0.75)², (1/0.75)², 0
    assert sorted(idx[0, :2].tolist()) == [0, 1] and idx[0, 2] == 2
    np.testing.assert_allclose(w[0], [0.5, 0.5, 0.0], atol=1e-7)
    idx, w = idw_weights(guides, np.array([[0.25, 0, 0]]), samples=2)
    # d = 0.25, 0.75, 1.75: w ∝ (1.5/0.4375)², (1/1.3125)², 0
    a, b = (1.5 / 0.4375) ** 2, (1.0 / 1.3125) ** 2
    np.testing.assert_allclose(w[0], [a / (a + b), b / (a + b), 0], rtol=1e-6)
    idx, w = idw_weights(guides, np.array([[2, 0, 0]]), samples=3)
    assert idx[0, 0] == 2 and w[0, 0] == 1.0 and w[0, 1:].sum() == 0


def test_blend_mixes_local_shapes_and_scales_them():
    local = np.array(
        [[[0, 0, 0], [0, 0, 1], [0, 0, 2]], [[0, 0, 0], [1, 0, 1], [2, 0, 2]]], np.float32
    )
    idx = np.array([[0, 1], [1, 0]])
    w = np.array([[0.5, 0.5], [1.0, 0.0]], np.float32)
    out = blend_guides(local, idx, w, 2, scale=np.array([2.0, 1.0]))
    # early culling: only the first 2 vertices; hair 0 is (0.5, 0, 1) × 2, hair 1 guide 1
    np.testing.assert_allclose(out, [[[0, 0, 0], [1, 0, 2]], [[0, 0, 0], [1, 0, 1]]])


def test_resample_arclength_spaces_vertices_evenly():
    c = HairCurves.from_polylines([np.array([[0, 0, 0], [0, 1, 0], [0, 3, 0]])])
    out = resample_arclength(c, 4)
    np.testing.assert_allclose(out[0, :, 1], [0, 1, 2, 3])


def test_hairs_on_a_plane_copy_upright_guides_and_follow_the_pose():
    mesh = _plane()
    guides = _upright_guides(mesh, [(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9), (0.5, 0.5)])
    groom = Groom(mesh, guides, GroomParams(count=500, vertices=5, guide_samples=3))
    hair = groom.generate()
    arr = hair.as_array()
    assert hair.curve_count == 500 and arr.shape == (500, 5, 3)
    np.testing.assert_allclose(arr[:, 0, 1], 0, atol=1e-6)  # roots on the plane
    np.testing.assert_allclose(arr[:, -1, 1], 0.2, atol=1e-5)  # every hair 0.2 tall
    np.testing.assert_allclose(arr[:, -1, [0, 2]], arr[:, 0, [0, 2]], atol=1e-5)
    assert hair.curve_data["hair_id"].tolist() == list(range(500))
    np.testing.assert_allclose(hair.curve_data["root_uv"], arr[:, 0, [0, 2]], atol=1e-6)
    # widths taper root → tip, colours go root → tip
    w = hair.point_data["width"].reshape(500, 5)
    assert np.all(np.diff(w, axis=1) < 0)
    np.testing.assert_allclose(hair.point_data["color"][0], groom.params.root_color, atol=1e-6)
    # rotate the mesh 90° about Z: the same roots, hair now grows along -X
    rot = np.eye(4)
    rot[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    moved = groom.generate(pose=mesh.posed(transform=rot)).as_array()
    np.testing.assert_allclose(moved[:, -1] - moved[:, 0], [[-0.2, 0, 0]] * 500, atol=1e-5)


def test_growth_is_deterministic_and_chunk_independent(monkeypatch):
    import follicle.groom.generator as gen

    mesh = _plane()
    guides = _upright_guides(mesh, [(0.2, 0.2), (0.8, 0.3), (0.5, 0.8)])
    a = Groom(mesh, guides, GroomParams(count=300, vertices=5)).generate()
    monkeypatch.setattr(gen, "CHUNK", 64)
    b = Groom(mesh, guides, GroomParams(count=300, vertices=5)).generate()
    assert a == b
    c = Groom(mesh, guides, GroomParams(count=300, vertices=5, seed=1)).generate()
    assert not np.array_equal(a.points, c.points)


def test_growth_is_the_same_on_one_thread_and_on_all(monkeypatch):
    """Chunks grown side by side (follicle.threads) and one after another give the same
    bytes, with clumps and a cut map (uneven chunks) and a progress report in order."""
    import numba

    import follicle.groom.generator as gen

    monkeypatch.setattr(gen, "CHUNK", 50)
    mesh = _plane()
    guides = _upright_guides(mesh, [(0.2, 0.2), (0.8, 0.3), (0.5, 0.8), (0.3, 0.6)])
    params = GroomParams(count=700, vertices=6, clump_count=20, cut=0.6, random_scale=0.3)
    reports = []
    together = Groom(mesh, guides, params).generate(progress=lambda d, n: reports.append(d))
    threads = numba.get_num_threads()
    numba.set_num_threads(1)  # this thread only: generate runs its chunks in order
    try:
        alone = Groom(mesh, guides, params).generate()
    finally:
        numba.set_num_threads(threads)
    assert together == alone
    assert reports == sorted(reports) and reports[-1] == 700 and len(reports) > 1


def test_bad_groom_input():
    mesh = _plane()
    guides = _upright_guides(mesh, [(0.2, 0.2)])
    with pytest.raises(InputError, match="count"):
        Groom(mesh, guides).generate(count=-1)
    with pytest.raises(InputError, match="zero length"):
        Guides(HairCurves.from_polylines([np.zeros((3, 3))]), mesh)
    assert Groom(mesh, guides).generate(count=0).curve_count == 0
