import numpy as np
import pytest

from follicle.errors import InputError
from follicle.groom.barycentric import GuideTriangulation

UP = np.array([0.0, 0.0, 1.0])


def _fibonacci_sphere(n):
    i = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * i / n)
    theta = np.pi * (1.0 + 5.0**0.5) * i
    return np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], axis=1)


def _random_sphere(n, seed):
    p = np.random.default_rng(seed).normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def _grid(n, spacing=1.0, z=0.0):
    x, y = np.meshgrid(np.arange(n) * spacing, np.arange(n) * spacing, indexing="ij")
    return np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], axis=1)


def _torus(n, seed, big=1.0, small=0.3):
    """Points spread evenly over a torus by area (rejection sampling) and their normals."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, 2 * np.pi, 8 * n)
    v = rng.uniform(0, 2 * np.pi, 8 * n)
    keep = rng.uniform(0, 1, 8 * n) < (big + small * np.cos(v)) / (big + small)
    u, v = u[keep][:n], v[keep][:n]
    normal = np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], axis=1)
    centre = np.stack([big * np.cos(u), big * np.sin(u), np.zeros_like(u)], axis=1)
    return centre + small * normal, normal


def _edge_counts(triangles):
    e = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    _, counts = np.unique(np.sort(e, axis=1), axis=0, return_counts=True)
    return counts


def _raw_barycentrics(roots, idx, q, n):
    """Barycentrics of q projected along n on the triangles idx, unclamped."""
    a, b, c = (roots[idx[:, i]] for i in range(3))
    den = np.einsum("ij,ij->i", np.cross(b - a, c - a), n)
    l0 = np.einsum("ij,ij->i", np.cross(b - q, c - q), n) / den
    l1 = np.einsum("ij,ij->i", np.cross(c - q, a - q), n) / den
    return np.stack([l0, l1, 1.0 - l0 - l1], axis=1)


def _check_weights(idx, w, s):
    assert idx.dtype == np.int64 and w.dtype == np.float32
    assert idx.shape == w.shape and idx.shape[1] == 3
    assert np.isfinite(w).all()
    assert (w >= 0).all()
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-6)
    assert ((idx >= 0) & (idx < s)).all()


# --------------------------------------------------------------------------- triangulation
def test_sphere_triangulation_is_a_closed_oriented_manifold():
    roots = _fibonacci_sphere(500)
    tri = GuideTriangulation(roots, roots)
    t = tri.triangles
    assert t.dtype == np.int64 and t.shape[1] == 3
    assert abs(len(t) - (2 * len(roots) - 4)) <= 0.05 * (2 * len(roots) - 4)
    counts = _edge_counts(t)
    assert counts.max() <= 2
    a, b, c = (roots[t[:, i]] for i in range(3))
    normal = np.cross(b - a, c - a)
    for i in range(3):  # wound right-handed about every corner's normal (outwards)
        assert (np.einsum("ij,ij->i", normal, roots[t[:, i]]) > 0).all()
    assert len(np.unique(np.sort(t, axis=1), axis=0)) == len(t)
    assert len(np.unique(t)) == len(roots)  # every guide is used


def test_random_roots_on_a_sphere_triangulate_like_the_convex_hull():
    # uneven spacing: some Delaunay neighbours are past the 12 nearest guides
    roots = _random_sphere(800, seed=3)
    tri = GuideTriangulation(roots, roots)
    assert len(tri.triangles) == 2 * len(roots) - 4
    assert (_edge_counts(tri.triangles) == 2).all()


def test_torus_triangulation_is_closed():
    roots, normals = _torus(1500, seed=4)
    tri = GuideTriangulation(roots, normals)
    counts = _edge_counts(tri.triangles)
    # Euler characteristic 0: T = 2 S on a closed torus; allow a few boundary edges
    assert counts.max() <= 2
    assert (counts == 1).sum() <= 0.01 * len(counts)
    assert abs(len(tri.triangles) - 2 * len(roots)) <= 0.01 * 2 * len(roots)


def test_grid_triangulation_splits_every_cell_in_two():
    roots = _grid(6)
    tri = GuideTriangulation(roots, np.tile(UP, (len(roots), 1)))
    assert len(tri.triangles) == 2 * 5 * 5
    counts = _edge_counts(tri.triangles)
    assert counts.max() == 2 and (counts == 1).sum() == 4 * 5  # the square's border
    a, b, c = (roots[tri.triangles[:, i]] for i in range(3))
    np.testing.assert_allclose(np.cross(b - a, c - a), np.tile([0, 0, 1.0], (50, 1)))


def test_triangulation_is_deterministic():
    roots = _random_sphere(300, seed=8)
    a = GuideTriangulation(roots, roots)
    b = GuideTriangulation(roots.copy(), roots.copy())
    assert a.triangles.tobytes() == b.triangles.tobytes()


# --------------------------------------------------------------------------- weights
def test_random_points_on_a_sphere_are_interpolated_from_their_triangle():
    roots = _fibonacci_sphere(500)
    tri = GuideTriangulation(roots, roots)
    q = _random_sphere(20000, seed=1)
    idx, w = tri.weights(q, q)
    _check_weights(idx, w, len(roots))
    t = tri.triangles
    mean_edge = np.linalg.norm(roots[t[:, 0]] - roots[t[:, 1]], axis=1).mean()
    reproduced = np.einsum("hk,hkj->hj", w, roots[idx])
    assert np.linalg.norm(reproduced - q, axis=1).max() < 0.2 * mean_edge
    # the three guides are a triangle of the triangulation, wound the same way
    known = {tuple(x) for r in range(3) for x in np.roll(t, r, axis=1)}
    assert all(tuple(x) in known for x in idx[:2000])
    raw = _raw_barycentrics(roots, idx, q, q)
    inside = raw.min(axis=1) >= -1e-6
    assert inside.mean() >= 0.99
    np.testing.assert_allclose(w[inside], raw[inside], atol=1e-6)  # inside: not clamped


def test_grid_cell_gets_exact_barycentrics():
    roots = _grid(6)
    tri = GuideTriangulation(roots, np.tile(UP, (len(roots), 1)))
    rng = np.random.default_rng(2)
    q = np.c_[rng.uniform(0.0, 5.0, (5000, 2)), np.zeros(5000)]
    idx, w = tri.weights(q, np.tile(UP, (len(q), 1)))
    _check_weights(idx, w, len(roots))
    # linear reproduction: the weights are the barycentrics of a triangle holding q
    np.testing.assert_allclose(np.einsum("hk,hkj->hj", w, roots[idx]), q, atol=1e-5)
    cell = np.floor(q[:, :2]).clip(0, 4)
    corner = roots[idx][:, :, :2]
    assert ((corner >= cell[:, None, :] - 1e-9) & (corner <= cell[:, None, :] + 1 + 1e-9)).all()


def test_float32_points_and_unnormalised_normals_are_accepted():
    roots = _grid(4)
    tri = GuideTriangulation(roots, np.tile(UP * 3.0, (len(roots), 1)))
    q = np.array([[1.25, 0.5, 0.0], [2.5, 2.75, 0.0]], np.float32)
    idx, w = tri.weights(q, np.tile([0, 0, 7], (2, 1)))
    _check_weights(idx, w, len(roots))
    np.testing.assert_allclose(np.einsum("hk,hkj->hj", w, roots[idx]), q, atol=1e-5)


@pytest.mark.parametrize("shape", ["sphere", "grid", "torus"])
def test_point_on_a_guide_root_copies_that_guide(shape):
    if shape == "sphere":
        roots = normals = _fibonacci_sphere(200)
    elif shape == "grid":
        roots, normals = _grid(5), np.tile(UP, (25, 1))
    else:
        roots, normals = _torus(400, seed=6)
    tri = GuideTriangulation(roots, normals)
    idx, w = tri.weights(roots, normals)
    _check_weights(idx, w, len(roots))
    on_guide = np.where(idx == np.arange(len(roots))[:, None], w, 0.0).sum(axis=1)
    np.testing.assert_allclose(on_guide, 1.0, atol=1e-6)


def test_guide_without_triangles_is_still_copied_exactly():
    # a duplicate root and a root far from the rest make no triangle
    roots = np.r_[_grid(4), [[1.0, 1.0, 0.0]], [[50.0, 50.0, 0.0]]]
    tri = GuideTriangulation(roots, np.tile(UP, (len(roots), 1)))
    assert not np.isin([17], tri.triangles).any()
    idx, w = tri.weights(roots[[16, 17]], np.tile(UP, (2, 1)))
    _check_weights(idx, w, len(roots))
    assert idx[1, 0] == 17 and w[1, 0] == 1.0
    np.testing.assert_allclose(np.einsum("hk,hkj->hj", w, roots[idx])[0], roots[16])


def test_query_outside_an_open_patch_gets_clamped_weights():
    roots = _grid(6)
    tri = GuideTriangulation(roots, np.tile(UP, (len(roots), 1)))
    q = np.array(
        [[7.0, 2.5, 0.0], [-3.0, -3.0, 0.0], [2.5, 40.0, 0.0], [2.0, 2.0, 5.0], [5.5, 0.5, -1]]
    )
    idx, w = tri.weights(q, np.tile(UP, (len(q), 1)))
    _check_weights(idx, w, len(roots))
    reproduced = np.einsum("hk,hkj->hj", w, roots[idx])
    assert reproduced[0, 0] == pytest.approx(5.0, abs=1e-6)  # on the right border
    np.testing.assert_allclose(reproduced[1], [0.0, 0.0, 0.0], atol=1e-6)  # the corner
    assert reproduced[2, 1] == pytest.approx(5.0, abs=1e-6)
    np.testing.assert_allclose(reproduced[3], [2.0, 2.0, 0.0], atol=1e-6)  # straight above


def test_thin_two_sided_shape_keeps_the_sides_apart():
    top = _grid(8, spacing=0.05, z=0.01)
    bottom = _grid(8, spacing=0.05, z=0.0) + [0.013, 0.021, 0.0]  # not aligned with the top
    roots = np.r_[top, bottom]
    normals = np.r_[np.tile(UP, (64, 1)), np.tile(-UP, (64, 1))]
    tri = GuideTriangulation(roots, normals)
    is_top = tri.triangles < 64
    assert (is_top.all(axis=1) | ~is_top.any(axis=1)).all()  # no triangle mixes the sides
    assert is_top.all(axis=1).sum() == 2 * 7 * 7
    rng = np.random.default_rng(7)
    q = np.c_[rng.uniform(-0.02, 0.37, (3000, 2)), np.full(3000, 0.01)]
    idx, w = tri.weights(q, np.tile(UP, (len(q), 1)))
    _check_weights(idx, w, len(roots))
    assert (idx < 64).all()
    qb = q - [0, 0, 0.01]
    idx, w = tri.weights(qb, np.tile(-UP, (len(q), 1)))
    assert (idx >= 64).all()


def test_weights_are_deterministic():
    roots = _random_sphere(300, seed=9)
    tri = GuideTriangulation(roots, roots)
    q = _random_sphere(5000, seed=10)
    a = tri.weights(q, q)
    b = GuideTriangulation(roots, roots).weights(q.copy(), q.copy())
    assert a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes()


def test_no_points():
    roots = _fibonacci_sphere(20)
    idx, w = GuideTriangulation(roots, roots).weights(np.zeros((0, 3)), np.zeros((0, 3)))
    assert idx.shape == (0, 3) and w.shape == (0, 3)


# --------------------------------------------------------------------------- few guides
def test_one_guide():
    tri = GuideTriangulation([[1.0, 2.0, 3.0]], [UP])
    assert tri.triangles.shape == (0, 3)
    idx, w = tri.weights([[0.0, 0.0, 0.0], [5.0, 5.0, 5.0]], [UP, UP])
    assert (idx == 0).all()
    np.testing.assert_array_equal(w, [[1, 0, 0], [1, 0, 0]])


def test_two_guides_project_on_the_segment():
    tri = GuideTriangulation([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], [UP, UP])
    assert tri.triangles.shape == (0, 3)
    q = [[0.5, 1.0, 0.0], [3.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]
    idx, w = tri.weights(q, [UP] * 4)
    _check_weights(idx, w, 2)
    np.testing.assert_array_equal(idx, [[0, 1, 0]] * 4)
    np.testing.assert_allclose(w, [[0.75, 0.25, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0]])


def test_collinear_guides_fall_back_to_segments():
    roots = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0]])
    tri = GuideTriangulation(roots, np.tile(UP, (4, 1)))
    assert tri.triangles.shape == (0, 3)
    idx, w = tri.weights([[2.25, 0.5, 0.0]], [UP])
    _check_weights(idx, w, 4)
    np.testing.assert_allclose(np.einsum("hk,hkj->hj", w, roots[idx]), [[2.25, 0, 0]], atol=1e-6)


def test_three_guides_make_one_triangle():
    roots = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.0, 1, 0]])
    tri = GuideTriangulation(roots, np.tile(UP, (3, 1)))
    np.testing.assert_array_equal(tri.triangles, [[0, 1, 2]])
    idx, w = tri.weights([[0.25, 0.25, 0.0]], [UP])
    np.testing.assert_array_equal(idx, [[0, 1, 2]])
    np.testing.assert_allclose(w, [[0.5, 0.25, 0.25]], atol=1e-7)


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("roots", "normals", "name"),
    [
        (np.zeros((0, 3)), np.zeros((0, 3)), "roots"),
        (np.zeros((4, 2)), np.zeros((4, 2)), "roots"),
        (np.zeros(3), np.zeros(3), "roots"),
        ([[0, 0, np.nan], [1, 0, 0]], [UP, UP], "roots"),
        ([[0, 0, 0], [1, 0, 0]], [UP], "normals"),
        ([[0, 0, 0], [1, 0, 0]], [UP, [0, 0, 0]], "normals"),
        ([[0, 0, 0], [1, 0, 0]], [UP, [0, np.inf, 0]], "normals"),
        ([[0, 0, 0], [1, 0, 0]], [[True, False, True]] * 2, "normals"),
    ],
)
def test_bad_guides_raise_input_error(roots, normals, name):
    with pytest.raises(InputError, match=name):
        GuideTriangulation(roots, normals)


@pytest.mark.parametrize("neighbours", [2, 65, 3.5, True])
def test_bad_neighbours_raise_input_error(neighbours):
    with pytest.raises(InputError, match="neighbours"):
        GuideTriangulation(_grid(3), np.tile(UP, (9, 1)), neighbours=neighbours)


@pytest.mark.parametrize(
    ("points", "normals", "name"),
    [
        (np.zeros((2, 4)), np.tile(UP, (2, 1)), "points"),
        ([[0, 0, np.inf]], [UP], "points"),
        ([[0, 0, 0]], [[0, 0, 0]], "normals"),
        ([[0, 0, 0]], [UP, UP], "normals"),
        ([[0, 0, 0]], [[np.nan, 0, 1]], "normals"),
    ],
)
def test_bad_points_raise_input_error(points, normals, name):
    tri = GuideTriangulation(_grid(3), np.tile(UP, (9, 1)))
    with pytest.raises(InputError, match=name):
        tri.weights(points, normals)
