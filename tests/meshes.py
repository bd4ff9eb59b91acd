"""Small meshes shared by the tests, and what tests measure of meshes."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from follicle.mesh.skin import SkinMesh


def plane(cells: int = 8) -> SkinMesh:
    """The unit square in the XZ plane facing +Y, UV = (x, z), cells×cells quads."""
    g = np.linspace(0.0, 1.0, cells + 1)
    x, z = np.meshgrid(g, g)
    verts = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], axis=1)
    row = cells + 1
    q = [i * row + j for i in range(cells) for j in range(cells)]
    faces = [f for a in q for f in ([a, a + row, a + 1], [a + 1, a + row, a + row + 1])]
    return SkinMesh(verts, faces, uvs=verts[:, [0, 2]], name="plane")


def winding_number(triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Generalized winding number of a closed outward-wound mesh's ``triangles`` (F, 3, 3)
    at ``points``: the triangles' solid angles over 4π (Van Oosterom and Strackee 1983),
    1 inside and 0 outside: containment that needs no ray casting."""
    out = np.empty(len(points))
    for i, p in enumerate(points):
        a, b, c = (triangles[:, k] - p for k in range(3))
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        det = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (
            la * lb * lc
            + np.einsum("ij,ij->i", a, b) * lc
            + np.einsum("ij,ij->i", b, c) * la
            + np.einsum("ij,ij->i", c, a) * lb
        )
        out[i] = 2.0 * np.arctan2(det, den).sum() / (4 * np.pi)
    return out


def skin_distance(mesh: SkinMesh, points: np.ndarray, rough: Callable[[np.ndarray], np.ndarray]):
    """Signed distance (m, negative inside) from ``points`` to ``mesh``'s rest surface:
    exact closest points, signed by the interpolated normal there, for the points that
    ``rough`` (an approximate signed distance, e.g. the built-in mesh's field) puts
    within 1 cm of the skin; ``rough`` itself for the rest."""
    p = np.asarray(points, np.float64)
    d = np.asarray(rough(p), np.float64).copy()
    near = np.flatnonzero(d < 0.01)
    tri, bary, dist = mesh.closest_points(p[near])
    surf = mesh.evaluate(tri, np.clip(bary, 0.0, 1.0))
    outside = np.sum((p[near] - surf.position) * surf.normal, axis=1) >= 0.0
    d[near] = np.where(outside, dist, -dist)
    return d
