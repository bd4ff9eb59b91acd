"""PointGrid: exact k nearest neighbours, checked against cKDTree and a brute-force reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from follicle.errors import InputError
from follicle.groom.knn import PointGrid


def brute(points: np.ndarray, queries: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Reference: all distances, ranked by (distance², index); k clamped to n."""
    k = min(k, len(points))
    dx = queries[:, None, 0] - points[None, :, 0]
    dy = queries[:, None, 1] - points[None, :, 1]
    dz = queries[:, None, 2] - points[None, :, 2]
    d2 = dx * dx + dy * dy + dz * dz
    idx = np.broadcast_to(np.arange(len(points)), d2.shape)
    order = np.lexsort((idx, d2), axis=-1)[:, :k]  # by d², then the lower index
    return np.sqrt(np.take_along_axis(d2, order, axis=1)), order.astype(np.int64)


def check(points: np.ndarray, queries: np.ndarray, k: int) -> None:
    """Distances equal cKDTree's to 1e-12; indices equal the (distance, index) ranking."""
    d, i = PointGrid(points).query(queries, k)
    kk = min(k, len(points))
    assert d.shape == i.shape == (len(queries), kk)
    assert d.dtype == np.float64 and i.dtype == np.int64
    td, _ = cKDTree(points).query(queries, kk)
    np.testing.assert_allclose(d, np.reshape(td, d.shape), rtol=0, atol=1e-12)
    bd, bi = brute(points, queries, k)
    np.testing.assert_array_equal(i, bi)
    np.testing.assert_array_equal(d, bd)


def sphere(rng: np.random.Generator, n: int) -> np.ndarray:
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


@pytest.mark.parametrize("k", [1, 4, 10, 600])
@pytest.mark.slow
def test_random_cube(k):
    rng = np.random.default_rng(1)
    points = rng.random((500, 3))
    queries = rng.random((3000, 3)) * 1.4 - 0.2  # some just outside the box
    check(points, queries, k)


@pytest.mark.parametrize("k", [1, 4, 10])
def test_sphere_surface(k):
    rng = np.random.default_rng(2)
    points = sphere(rng, 1000)
    queries = sphere(rng, 4000) * rng.uniform(0.9, 1.1, size=(4000, 1))
    check(points, queries, k)


def test_cKDTree_indices_agree_without_ties():
    rng = np.random.default_rng(3)
    points = sphere(rng, 1000)
    queries = sphere(rng, 5000)
    _, i = PointGrid(points).query(queries, 4)
    _, ti = cKDTree(points).query(queries, 4)
    np.testing.assert_array_equal(i, ti)


@pytest.mark.parametrize("k", [1, 4, 10])
def test_two_tight_clusters_far_apart(k):
    rng = np.random.default_rng(4)
    points = np.concatenate(
        [rng.normal(size=(300, 3)) * 1e-3, rng.normal(size=(300, 3)) * 1e-3 + [100, 50, 0]]
    )
    queries = np.concatenate(
        [
            rng.normal(size=(1000, 3)) * 1e-3,
            rng.normal(size=(1000, 3)) * 1e-3 + [100, 50, 0],
            rng.random((500, 3)) * [100, 50, 1],  # in between
        ]
    )
    check(points, queries, k)


def test_duplicate_points():
    rng = np.random.default_rng(5)
    base = rng.random((50, 3))
    points = np.concatenate([base, base, base[:10]])  # every point at least twice
    queries = np.concatenate([rng.random((2000, 3)), base])  # incl. exactly on points
    for k in (1, 3, 7):
        check(points, queries, k)
    d, i = PointGrid(points).query(base[:1], 2)
    np.testing.assert_array_equal(d, [[0.0, 0.0]])
    np.testing.assert_array_equal(i, [[0, 50]])  # both copies, lower index first


def test_all_points_equal():
    points = np.ones((5, 3))
    d, i = PointGrid(points).query(np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]), 3)
    np.testing.assert_array_equal(i, [[0, 1, 2], [0, 1, 2]])
    np.testing.assert_allclose(d, [[np.sqrt(3)] * 3, [0.0] * 3], rtol=0, atol=1e-15)


def test_single_point():
    rng = np.random.default_rng(6)
    point = np.array([[0.5, -2.0, 3.0]])
    queries = rng.normal(size=(1000, 3)) * 10
    grid = PointGrid(point)
    assert grid.n == 1
    for k in (1, 3):
        d, i = grid.query(queries, k)
        assert d.shape == i.shape == (1000, 1)
        np.testing.assert_array_equal(i, 0)
        np.testing.assert_allclose(d[:, 0], np.linalg.norm(queries - point, axis=1), atol=1e-12)


def test_planar_points():
    rng = np.random.default_rng(7)
    points = np.column_stack([rng.random((800, 2)), np.full(800, 2.0)])  # flat in z
    queries = np.column_stack([rng.random((2000, 2)), rng.uniform(1.9, 2.1, 2000)])
    check(points, queries, 4)


def test_queries_far_outside_the_box():
    rng = np.random.default_rng(8)
    points = sphere(rng, 700)
    for scale in (1.5, 5.0, 1e3, 1e6):
        check(points, sphere(rng, 500) * scale, 4)
    check(points, rng.normal(size=(500, 3)) * 1e4, 10)


def test_coordinates_far_from_the_origin():
    rng = np.random.default_rng(9)
    offset = np.array([1e4, -3e4, 5e3])
    points = sphere(rng, 1000) * 0.1 + offset
    queries = sphere(rng, 3000) * rng.uniform(0.09, 0.11, size=(3000, 1)) + offset
    check(points, queries, 4)


def test_k_larger_than_n_is_clamped():
    rng = np.random.default_rng(10)
    points = rng.random((7, 3))
    queries = rng.random((100, 3))
    d, i = PointGrid(points).query(queries, 50)
    assert d.shape == i.shape == (100, 7)
    np.testing.assert_array_equal(np.sort(i, axis=1), np.tile(np.arange(7), (100, 1)))
    check(points, queries, 50)


def test_k_1_is_two_dimensional_and_empty_queries():
    rng = np.random.default_rng(11)
    grid = PointGrid(rng.random((20, 3)))
    d, i = grid.query(rng.random((5, 3)))
    assert d.shape == i.shape == (5, 1)
    d, i = grid.query(np.empty((0, 3)), 4)
    assert d.shape == i.shape == (0, 4)
    d, i = grid.query([0.5, 0.5, 0.5] * np.ones((1, 3)), np.int32(2))  # numpy integer k
    assert d.shape == (1, 2)


def test_ties_go_to_the_lower_index():
    # the six unit axis points, shuffled: the origin is equidistant from all of them
    axes = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [0, -1, 0], [0, 0, -1]], float)
    points = axes[[4, 0, 5, 2, 1, 3]]
    grid = PointGrid(points)
    d, i = grid.query(np.zeros((1, 3)), 4)
    np.testing.assert_array_equal(i, [[0, 1, 2, 3]])
    np.testing.assert_array_equal(d, [[1.0, 1.0, 1.0, 1.0]])
    # far along z (the k-d tree path): (±1, 0, 0) and (0, ±1, 0) tie at the boundary
    d, i = grid.query(np.array([[0.0, 0.0, 1000.0]]), 3)
    np.testing.assert_array_equal(i[0], [3, 0, 1])  # +z first, then the lowest of the tied
    # far along z again, 12 points tie (x² + y² = 25): more than the tree's k + 1
    ring = np.array(
        [
            [3, 4],
            [4, 3],
            [5, 0],
            [0, 5],
            [-3, 4],
            [-4, 3],
            [-5, 0],
            [0, -5],
            [3, -4],
            [4, -3],
            [-3, -4],
            [-4, -3],
        ],
        float,
    )
    ring = np.column_stack([ring, np.zeros(12)])[np.random.default_rng(12).permutation(12)]
    for k in (1, 2, 5):
        d, i = PointGrid(ring).query(np.array([[0.0, 0.0, 1000.0], [0.0, 0.0, -50.0]]), k)
        np.testing.assert_array_equal(i, np.tile(np.arange(k), (2, 1)))
    # lattice points, queried at the centres of the lattice cells (8 equidistant
    # corners, then 24 more), and at the lattice points themselves (6, then 12, …)
    g = np.arange(7.0)
    lattice = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    lattice = lattice[np.random.default_rng(13).permutation(len(lattice))]
    centres = lattice[(lattice < 6).all(axis=1)] + 0.5
    for k in (5, 10, 30):
        check(lattice, centres, k)
        check(lattice, lattice, k)


def test_batches_are_independent_bytewise():
    rng = np.random.default_rng(13)
    points = np.concatenate([sphere(rng, 500), rng.normal(size=(100, 3)) * 1e-3 + 5])
    a = np.concatenate([sphere(rng, 3000), rng.normal(size=(200, 3)) * 1e-3 + 5])
    b = np.concatenate([sphere(rng, 500) * 1e3, sphere(rng, 2000) * 1.05])  # far, near
    grid = PointGrid(points)
    for k in (1, 4, 9):
        d, i = grid.query(np.concatenate([a, b]), k)
        da, ia = grid.query(a, k)
        db, ib = grid.query(b, k)
        assert d.tobytes() == np.concatenate([da, db]).tobytes()
        assert i.tobytes() == np.concatenate([ia, ib]).tobytes()
        # and row by row in reverse order
        dr, ir = grid.query(np.concatenate([a, b])[::-1], k)
        assert dr[::-1].tobytes() == d.tobytes() and ir[::-1].tobytes() == i.tobytes()


def test_caller_mutating_points_does_not_change_the_grid():
    rng = np.random.default_rng(14)
    points = rng.random((100, 3))
    queries = rng.random((200, 3))
    grid = PointGrid(points)
    before = grid.query(queries, 3)
    points += 10.0
    after = grid.query(queries, 3)
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[1], after[1])


@pytest.mark.parametrize(
    "points, word",
    [
        (np.zeros((0, 3)), "points"),
        (np.zeros((5, 2)), "points"),
        (np.zeros(3), "points"),
        (np.array([[0.0, 0.0, np.nan]]), "points"),
        (np.array([[0.0, np.inf, 0.0], [1.0, 1.0, 1.0]]), "points"),
        ([["a", "b", "c"]], "points"),
    ],
)
def test_bad_points(points, word):
    with pytest.raises(InputError, match=word):
        PointGrid(points)


def test_bad_queries_and_k():
    grid = PointGrid(np.random.default_rng(15).random((10, 3)))
    ok = np.zeros((2, 3))
    for queries in (np.zeros((4, 2)), np.zeros(3), np.array([[0.0, np.nan, 0.0]])):
        with pytest.raises(InputError, match="queries"):
            grid.query(queries, 2)
    with pytest.raises(InputError, match="row 1"):
        grid.query(np.array([[0.0, 0.0, 0.0], [0.0, -np.inf, 0.0]]))
    for k in (0, -3, 1.5, "2", None, True):
        with pytest.raises(InputError, match="k"):
            grid.query(ok, k)
