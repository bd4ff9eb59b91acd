"""Barycentric guide weights over a triangulation of the guide roots (Le Muzic 2012, multi-strand).

Le Muzic's "multi-strand interpolation" makes each hair from the three guides whose roots form
the triangle that encloses the hair's root, weighted by its barycentric coordinates. The
guide roots are triangulated over the surface itself, not in UV space and not as a convex
hull, so it works on any triangle mesh (heads, planes, open patches, tori, thin two-sided
shapes) and with roots placed anywhere, e.g. by a density map.

Triangulation: each guide tries the triangles it makes with two of its nearest guides.
One is kept when no guide facing the same way lies inside its circumcircle, drawn in the
plane normal to the summed normals of the four guides concerned: on a plane this is
Delaunay, on a sphere the convex hull, and since the test depends only on the four
guides, the corners of a triangle agree on it and of the two ways to split a quad
exactly one is kept. Guides on an edge with one triangle retry with 3× the neighbours
(uneven spacing puts some Delaunay neighbours farther away). Flat, tilted and huge
triangles are never kept, edges in more than two triangles are thinned, slivers and
oversized triangles are peeled off the border, and triangles are wound right-handed
about the normals. Cocircular guides (grids) are told apart by a tiny fixed jitter.

Weights: a hair root is projected along its normal onto the triangles binned in its grid
cell, and the one holding it whose plane is nearest wins. Failing that (a boundary, a
coarse cell), it starts at the triangles around its nearest facing guide and walks
across edges towards the root; outside the triangulated region the best triangle's
coordinates are clamped to ≥ 0 and renormalised.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from ..kernels import kernel, prange
from ..validate import whole

__all__ = ["GuideTriangulation"]

_INSIDE = -1e-6  # a barycentric coordinate at least this holds the point
_MIN_COS = 0.3  # triangle normal · corner normal must reach this
_FLAT = 1e-3  # never kept: quality 4√3·area / Σ edge² below this (1: equilateral, 0: flat)
_HUGE = 8.0  # never kept: circumradius above this × the corners' largest spacing
_MIN_QUALITY = 0.05  # peeled from the boundary: quality below this, or
_MAX_RADIUS = 3.0  # circumradius above this × the corners' largest spacing
_GROW = 3  # guides on an edge with one triangle retry with this × the neighbours
_MARGIN = 0.15  # triangles are binned to cells with their box grown by this × longest edge
_WALK_STEPS = 32
_SORT_ABOVE = 30_000  # triangles; past this, hairs are visited in grid order
_SEARCH = 8  # nearest guides looked at for a hair off the binned triangles
_JOGGLE = 1e-8  # × median spacing: breaks ties between cocircular guides (grids)
_SAME = 1e-2  # × median spacing: closer roots are one root for the triangulation


# --------------------------------------------------------------------------- validation
def _vectors(name: str, value: object, what: str, allow_empty: bool) -> np.ndarray:
    """``value`` as a C-contiguous finite float64 (N, 3) array; errors name ``name``."""
    try:
        a = np.asarray(value)
    except Exception as exc:  # ragged lists and the like
        raise InputError(f"{name}: expected an (N, 3) array of {what}; got {exc}") from None
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(
            f"{name}: expected an (N, 3) array of {what} (one x, y, z row each), "
            f"got shape {a.shape}"
        )
    if a.dtype == np.bool_ or not (
        np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)
    ):
        raise InputError(f"{name}: expected real numbers, got dtype {a.dtype}")
    if not allow_empty and a.shape[0] == 0:
        raise InputError(f"{name}: need at least one guide, got an empty (0, 3) array")
    a = np.ascontiguousarray(a, dtype=np.float64)
    if not np.isfinite(a).all():
        bad = int(np.flatnonzero(~np.isfinite(a).all(axis=1))[0])
        raise InputError(f"{name}: row {bad} is not finite (NaN or inf); fix or drop that row")
    return a


def _directions(
    name: str, value: object, rows: int, rows_name: str
) -> tuple[np.ndarray, np.ndarray]:
    """Validated normals, one per row of ``rows_name``, and their squared lengths."""
    n = _vectors(name, value, "unit normals", allow_empty=True)
    if n.shape[0] != rows:
        raise InputError(
            f"{name}: expected one normal per row of {rows_name} ({rows}), got {n.shape[0]}"
        )
    length2 = np.einsum("ij,ij->i", n, n)
    if rows and not (length2 > 1e-20).all():
        bad = int(np.flatnonzero(~(length2 > 1e-20))[0])
        raise InputError(
            f"{name}: row {bad} has zero length; pass the unit surface normal at that root"
        )
    return n, length2


# --------------------------------------------------------------------------- triangulation
@kernel(inline="always")
def _dot(p, i, q, j):
    return p[i, 0] * q[j, 0] + p[i, 1] * q[j, 1] + p[i, 2] * q[j, 2]


@kernel(nogil=True)
def _in_circle(i0, i1, i2, d, p, n):
    """Is guide d inside the circumcircle of {i0 < i1 < i2}, all four projected on one plane?

    The plane is normal to the sum of the four normals and everything is computed from
    the four indices in sorted order, so the answer for any triangle of the four, tested
    against the fourth, comes from the same in-circle determinant (bit for bit).
    """
    j0, j1, j2, j3 = i0, i1, i2, d  # sort (i0 < i1 < i2 already): insert d
    parity = 1.0
    if d < i2:
        j2, j3 = d, i2
        parity = -parity
        if d < i1:
            j1, j2 = d, i1
            parity = -parity
            if d < i0:
                j0, j1 = d, i0
                parity = -parity
    mx = n[j0, 0] + n[j1, 0] + n[j2, 0] + n[j3, 0]
    my = n[j0, 1] + n[j1, 1] + n[j2, 1] + n[j3, 1]
    mz = n[j0, 2] + n[j1, 2] + n[j2, 2] + n[j3, 2]
    # an orthonormal basis (e, f) of the plane normal to m: e ⟂ m from the axis least
    # aligned with m, f = m × e
    if abs(mx) <= abs(my) and abs(mx) <= abs(mz):
        ex, ey, ez = 0.0, mz, -my
    elif abs(my) <= abs(mz):
        ex, ey, ez = -mz, 0.0, mx
    else:
        ex, ey, ez = my, -mx, 0.0
    fx, fy, fz = my * ez - mz * ey, mz * ex - mx * ez, mx * ey - my * ex
    le = 1.0 / np.sqrt(ex * ex + ey * ey + ez * ez)
    lf = 1.0 / np.sqrt(fx * fx + fy * fy + fz * fz)
    ex, ey, ez, fx, fy, fz = ex * le, ey * le, ez * le, fx * lf, fy * lf, fz * lf
    # 2-D coordinates of j0..j2 relative to j3
    ax, ay, az = p[j0, 0] - p[j3, 0], p[j0, 1] - p[j3, 1], p[j0, 2] - p[j3, 2]
    bx, by, bz = p[j1, 0] - p[j3, 0], p[j1, 1] - p[j3, 1], p[j1, 2] - p[j3, 2]
    cx, cy, cz = p[j2, 0] - p[j3, 0], p[j2, 1] - p[j3, 1], p[j2, 2] - p[j3, 2]
    au, av = ax * ex + ay * ey + az * ez, ax * fx + ay * fy + az * fz
    bu, bv = bx * ex + by * ey + bz * ez, bx * fx + by * fy + bz * fz
    cu, cv = cx * ex + cy * ey + cz * ez, cx * fx + cy * fy + cz * fz
    a2, b2, c2 = au * au + av * av, bu * bu + bv * bv, cu * cu + cv * cv
    det = au * (bv * c2 - b2 * cv) - av * (bu * c2 - b2 * cu) + a2 * (bu * cv - bv * cu)
    # orientation of the triangle itself (the three of j0..j3 other than d, in order)
    pu, pv, qu, qv, ru, rv = au, av, bu, bv, cu, cv
    if d == j0:
        pu, pv, qu, qv, ru, rv = bu, bv, cu, cv, 0.0, 0.0
    elif d == j1:
        pu, pv, qu, qv, ru, rv = au, av, cu, cv, 0.0, 0.0
    elif d == j2:
        pu, pv, qu, qv, ru, rv = au, av, bu, bv, 0.0, 0.0
    orient = (qu - pu) * (rv - pv) - (qv - pv) * (ru - pu)
    # det > 0: j3 inside the circle of (j0, j1, j2) counter-clockwise; parity moves d last
    return parity * det * orient > 0.0


@kernel(nogil=True)
def _shape(i0, i1, i2, p, n, spacing):
    """Shape tests of triangle {i0 < i1 < i2}: (ok, flipped, unit normal, circumcentre, r²).

    Not kept: corners whose normals face apart, flat triangles, triangles tilted more
    than about 70° from a corner's normal, and huge ones. flipped: wind it i0, i2, i1
    to turn right-handed about the normals.
    """
    if _dot(n, i0, n, i1) < 0.0 or _dot(n, i0, n, i2) < 0.0 or _dot(n, i1, n, i2) < 0.0:
        return False, False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    ax, ay, az = p[i1, 0] - p[i0, 0], p[i1, 1] - p[i0, 1], p[i1, 2] - p[i0, 2]
    bx, by, bz = p[i2, 0] - p[i0, 0], p[i2, 1] - p[i0, 1], p[i2, 2] - p[i0, 2]
    cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    c2 = cx * cx + cy * cy + cz * cz
    la = ax * ax + ay * ay + az * az
    lb = bx * bx + by * by + bz * bz
    lab = (bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2
    if c2 <= 0.0 or 2.0 * np.sqrt(3.0 * c2) < _FLAT * (la + lb + lab):
        return False, False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    flipped = (
        cx * (n[i0, 0] + n[i1, 0] + n[i2, 0])
        + cy * (n[i0, 1] + n[i1, 1] + n[i2, 1])
        + cz * (n[i0, 2] + n[i1, 2] + n[i2, 2])
    ) < 0.0
    s = (-1.0 if flipped else 1.0) / np.sqrt(c2)
    ux, uy, uz = cx * s, cy * s, cz * s  # unit normal, wound with the guide normals
    for v in (i0, i1, i2):
        if ux * n[v, 0] + uy * n[v, 1] + uz * n[v, 2] < _MIN_COS:
            return False, False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    # circumcentre on the triangle's plane: p0 + (|b|² (c × a) + |a|² (b × c)) / 2|c|²
    f = 0.5 / c2
    ox = (lb * (cy * az - cz * ay) + la * (by * cz - bz * cy)) * f
    oy = (lb * (cz * ax - cx * az) + la * (bz * cx - bx * cz)) * f
    oz = (lb * (cx * ay - cy * ax) + la * (bx * cy - by * cx)) * f
    r2 = ox * ox + oy * oy + oz * oz
    h = max(spacing[i0], max(spacing[i1], spacing[i2]))
    if r2 > (_HUGE * h) ** 2:
        return False, False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return True, flipped, ux, uy, uz, ox + p[i0, 0], oy + p[i0, 1], oz + p[i0, 2], r2


@kernel(nogil=True)
def _accept(i0, i1, i2, p, n, near, spacing):
    """Is triangle {i0 < i1 < i2} kept? Returns (kept, flipped).

    A pure function of the triangle (it looks at the neighbours of all three corners), so
    every corner that tries it reaches the same answer.
    """
    ok, flipped, ux, uy, uz, ox, oy, oz, r2 = _shape(i0, i1, i2, p, n, spacing)
    if not ok:
        return False, False
    # no guide facing the triangle's way inside its circumcircle (tested in the plane of
    # each four guides, so that of two triangles on a quad exactly one pair is kept)
    for v in (i0, i1, i2):
        for j in range(near.shape[1]):
            g = near[v, j]
            if g < 0:
                break
            if g == i0 or g == i1 or g == i2:
                continue
            x, y, z = p[g, 0] - ox, p[g, 1] - oy, p[g, 2] - oz
            if x * x + y * y + z * z >= 4.0 * r2:
                continue  # far outside
            if ux * n[g, 0] + uy * n[g, 1] + uz * n[g, 2] <= 0.0:
                continue  # another layer of the surface (the far side of a thin part)
            if _in_circle(i0, i1, i2, g, p, n):
                return False, False
    return True, flipped


@kernel(inline="always")
def _listed(near, u, g):
    for j in range(near.shape[1]):
        if near[u, j] == g:
            return True
        if near[u, j] < 0:
            return False
    return False


@kernel(parallel=True, nogil=True)
def _propose_kernel(rows, changed, p, n, near, spacing, out, count):
    """Kept triangles of each guide c = rows[i] and two of its neighbours into out[i].

    Only triangles with a ``changed`` corner are tried, each once, by the lowest-indexed
    corner that lists the other two. count[i] is how many were kept, even past out's
    capacity (the caller retries those).
    """
    k = near.shape[1]
    cap = out.shape[1]
    for i in prange(rows.shape[0]):
        c = rows[i]
        slot = 0
        for a in range(k):
            ga = near[c, a]
            if ga < 0:
                break
            for b in range(a + 1, k):
                gb = near[c, b]
                if gb < 0:
                    break
                if not (changed[c] or changed[ga] or changed[gb]):
                    continue
                if (ga < c and _listed(near, ga, c) and _listed(near, ga, gb)) or (
                    gb < c and _listed(near, gb, c) and _listed(near, gb, ga)
                ):
                    continue
                i0 = min(c, min(ga, gb))
                i2 = max(c, max(ga, gb))
                i1 = c + ga + gb - i0 - i2
                kept, flipped = _accept(i0, i1, i2, p, n, near, spacing)
                if kept:
                    if slot < cap:
                        out[i, slot, 0] = i0
                        out[i, slot, 1] = i2 if flipped else i1
                        out[i, slot, 2] = i1 if flipped else i2
                    slot += 1
        count[i] = slot


@kernel(nogil=True)
def _fill_neighbours(near, rows, idx, n, active, k):
    """near[rows[i]] = the first k[i] active neighbours in idx[i] facing the guide's way."""
    for i in range(rows.shape[0]):
        c = rows[i]
        near[c, :] = -1
        if not active[c]:
            continue
        m = 0
        for j in range(idx.shape[1]):
            g = idx[i, j]
            if m == k[i]:
                break
            if g == c or g >= near.shape[0] or not active[g] or _dot(n, c, n, g) < 0.0:
                continue
            near[c, m] = g
            m += 1


def _propose(
    rows: np.ndarray,
    changed: np.ndarray,
    p: np.ndarray,
    n: np.ndarray,
    near: np.ndarray,
    spacing: np.ndarray,
) -> np.ndarray:
    """Kept triangles (T, 3) with a ``changed`` corner made by the guides ``rows``, each once."""
    k = int((near[rows] >= 0).sum(axis=1).max(initial=0))
    cap = k + 8
    out = np.full((len(rows), cap, 3), -1, np.int64)
    count = np.zeros(len(rows), np.int64)
    _propose_kernel(rows, changed, p, n, near, spacing, out, count)
    fits = count <= cap
    tris = out[(np.arange(cap)[None, :] < count[:, None]) & fits[:, None]]
    if not fits.all():  # more than fitted: redo those guides with room for every pair
        big = np.full(((~fits).sum(), max(k * (k - 1) // 2, 1), 3), -1, np.int64)
        more = np.zeros(len(big), np.int64)
        _propose_kernel(rows[~fits], changed, p, n, near, spacing, big, more)
        tris = np.concatenate([tris, big[np.arange(big.shape[1])[None, :] < more[:, None]]])
    return tris


def _edges(tris: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Edge ids (T, 3) of the edge opposite each corner, and how many triangles share each."""
    a = tris[:, [1, 2, 0]]
    b = tris[:, [2, 0, 1]]
    keys = np.minimum(a, b) * np.int64(s) + np.maximum(a, b)
    _, inv, counts = np.unique(keys.ravel(), return_inverse=True, return_counts=True)
    return inv.reshape(-1, 3), counts


def _quality(p: np.ndarray, tris: np.ndarray) -> np.ndarray:
    a, b, c = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    edges = ((b - a) ** 2).sum(1) + ((c - b) ** 2).sum(1) + ((a - c) ** 2).sum(1)
    return 4.0 * np.sqrt(3.0) * area / edges


def _thin_edges(p: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Drop the worst-shaped triangles on edges shared by more than two, until none are."""
    quality = _quality(p, tris)
    while len(tris):
        edge, counts = _edges(tris, len(p))
        bad = counts[edge] > 2  # (T, 3)
        if not bad.any():
            break
        # on every crowded edge the lowest-quality triangle goes (ties: highest index)
        crowded = np.flatnonzero(bad.any(axis=1))
        drop = np.zeros(len(tris), bool)
        seen = np.zeros(len(counts), bool)
        for t in crowded[np.lexsort((-crowded, quality[crowded]))]:
            for e in edge[t][bad[t]]:
                if not seen[e]:
                    seen[e] = True
                    drop[t] = True
        tris, quality = tris[~drop], quality[~drop]
    return tris


def _peel(p: np.ndarray, tris: np.ndarray, spacing: np.ndarray) -> np.ndarray:
    """Peel slivers and oversized triangles off the boundary, layer by layer."""
    a, b, c = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
    la, lb, lc = (np.linalg.norm(e, axis=1) for e in (b - c, c - a, a - b))
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    radius = la * lb * lc / (2.0 * area2)  # area2 > 0: flat triangles are never kept
    bad = (_quality(p, tris) < _MIN_QUALITY) | (radius > _MAX_RADIUS * spacing[tris].max(axis=1))
    while bad.any():
        edge, counts = _edges(tris, len(p))
        drop = bad & (counts[edge] == 1).any(axis=1)
        if not drop.any():
            break
        tris, bad = tris[~drop], bad[~drop]
    return tris


# --------------------------------------------------------------------------- grid
@kernel(nogil=True)
def _bin_boxes(lo, hi, origin, cell, dims):
    """CSR (ptr, items) of the boxes [lo, hi] (N, 3) overlapping each grid cell."""
    m = lo.shape[0]
    d0, d1, d2 = dims[0], dims[1], dims[2]
    ptr = np.zeros(d0 * d1 * d2 + 1, np.int64)
    first = np.empty((m, 3), np.int64)
    last = np.empty((m, 3), np.int64)
    for i in range(m):
        for a in range(3):
            first[i, a] = min(max(int(np.floor((lo[i, a] - origin[a]) / cell)), 0), dims[a] - 1)
            last[i, a] = min(max(int(np.floor((hi[i, a] - origin[a]) / cell)), 0), dims[a] - 1)
    for i in range(m):
        for x in range(first[i, 0], last[i, 0] + 1):
            for y in range(first[i, 1], last[i, 1] + 1):
                for z in range(first[i, 2], last[i, 2] + 1):
                    ptr[(x * d1 + y) * d2 + z + 1] += 1
    for c in range(d0 * d1 * d2):
        ptr[c + 1] += ptr[c]
    items = np.empty(ptr[-1], np.int64)
    fill = ptr[:-1].copy()
    for i in range(m):
        for x in range(first[i, 0], last[i, 0] + 1):
            for y in range(first[i, 1], last[i, 1] + 1):
                for z in range(first[i, 2], last[i, 2] + 1):
                    cid = (x * d1 + y) * d2 + z
                    items[fill[cid]] = i
                    fill[cid] += 1
    return ptr, items


# --------------------------------------------------------------------------- weights
@kernel(inline="always")
def _cell_of(q0, q1, q2, origin, cell, dims):
    c0 = min(max(int(np.floor((q0 - origin[0]) / cell)), 0), dims[0] - 1)
    c1 = min(max(int(np.floor((q1 - origin[1]) / cell)), 0), dims[1] - 1)
    c2 = min(max(int(np.floor((q2 - origin[2]) / cell)), 0), dims[2] - 1)
    return c0, c1, c2


@kernel(inline="always")
def _bary(tv, tc, t, q0, q1, q2, v0, v1, v2):
    """Barycentrics of q projected along v onto triangle t (tc: its edge cross product)."""
    ax, ay, az = tv[t, 0, 0] - q0, tv[t, 0, 1] - q1, tv[t, 0, 2] - q2
    bx, by, bz = tv[t, 1, 0] - q0, tv[t, 1, 1] - q1, tv[t, 1, 2] - q2
    cx, cy, cz = tv[t, 2, 0] - q0, tv[t, 2, 1] - q1, tv[t, 2, 2] - q2
    f = 1.0 / (tc[t, 0] * v0 + tc[t, 1] * v1 + tc[t, 2] * v2)
    l0 = ((by * cz - bz * cy) * v0 + (bz * cx - bx * cz) * v1 + (bx * cy - by * cx) * v2) * f
    l1 = ((cy * az - cz * ay) * v0 + (cz * ax - cx * az) * v1 + (cx * ay - cy * ax) * v2) * f
    l2 = ((ay * bz - az * by) * v0 + (az * bx - ax * bz) * v1 + (ax * by - ay * bx) * v2) * f
    return l0, l1, l2


@kernel(inline="always")
def _faces(tc, t, n0, n1, n2):
    return tc[t, 0] * n0 + tc[t, 1] * n1 + tc[t, 2] * n2 > 0.0


@kernel(inline="always")
def _write(out_idx, out_w, h, tris, t, g, b0, b1, b2):
    """Hair h: triangle t with barycentrics clamped to ≥ 0 and renormalised, or guide g."""
    if t < 0:
        out_idx[h, 0] = g
        out_idx[h, 1] = g
        out_idx[h, 2] = g
        out_w[h, 0] = 1.0
        out_w[h, 1] = 0.0
        out_w[h, 2] = 0.0
        return
    b0 = max(b0, 0.0)
    b1 = max(b1, 0.0)
    b2 = max(b2, 0.0)
    total = b0 + b1 + b2
    out_idx[h, 0] = tris[t, 0]
    out_idx[h, 1] = tris[t, 1]
    out_idx[h, 2] = tris[t, 2]
    out_w[h, 0] = b0 / total
    out_w[h, 1] = b1 / total
    out_w[h, 2] = b2 / total


@kernel(parallel=True, nogil=True)
def _weights_kernel(
    order,
    q,
    qn,
    origin,
    cell,
    dims,
    tri_ptr,
    tri_items,
    loose_ptr,
    loose_items,
    p,
    hit2,
    tris,
    tv,
    tc,
    tn,
    out_idx,
    out_w,
):
    """Fast path: q (H, 3) on a guide without triangles, or projected along its normal qn
    into a triangle binned to its cell (the one with the nearest plane). Misses get
    out_idx[h, 0] = -1. Hairs are visited in ``order`` (empty: as given).
    """
    d1, d2 = dims[1], dims[2]
    for i in prange(q.shape[0]):
        h = order[i] if order.shape[0] else np.int64(i)  # one int type (prange: unsigned)
        q0, q1, q2 = q[h, 0], q[h, 1], q[h, 2]
        n0, n1, n2 = qn[h, 0], qn[h, 1], qn[h, 2]
        c0, c1, c2 = _cell_of(q0, q1, q2, origin, cell, dims)
        cid = (c0 * d1 + c1) * d2 + c2
        guide = -1
        for k in range(loose_ptr[cid], loose_ptr[cid + 1]):
            g = loose_items[k]
            dx, dy, dz = p[g, 0] - q0, p[g, 1] - q1, p[g, 2] - q2
            if dx * dx + dy * dy + dz * dz <= hit2:
                guide = g
                break
        if guide >= 0:
            _write(out_idx, out_w, h, tris, -1, guide, 1.0, 0.0, 0.0)
            continue
        best = -1
        best_plane = np.inf
        b0 = b1 = b2 = 0.0
        for k in range(tri_ptr[cid], tri_ptr[cid + 1]):
            t = tri_items[k]
            if not _faces(tc, t, n0, n1, n2):
                continue
            l0, l1, l2 = _bary(tv, tc, t, q0, q1, q2, n0, n1, n2)
            if min(l0, min(l1, l2)) >= _INSIDE:
                plane = abs(
                    (q0 - tv[t, 0, 0]) * tn[t, 0]
                    + (q1 - tv[t, 0, 1]) * tn[t, 1]
                    + (q2 - tv[t, 0, 2]) * tn[t, 2]
                )
                if plane < best_plane:
                    best, best_plane = t, plane
                    b0, b1, b2 = l0, l1, l2
        if best >= 0:
            _write(out_idx, out_w, h, tris, best, -1, b0, b1, b2)
        else:
            out_idx[h, 0] = -1


@kernel(parallel=True, nogil=True)
def _search_kernel(
    rows,
    q,
    qn,
    nearest,
    dist2,
    gn,
    has_tri,
    hit2,
    tris,
    tv,
    tc,
    tn,
    adj,
    vt_ptr,
    vt_idx,
    out_idx,
    out_w,
):
    """Slow path for hairs ``rows``: start at the triangles around the nearest guide facing
    the hair (``nearest`` (M, k) guides by distance), take one that holds the hair's
    projection, else walk across edges towards it, keeping the triangle that comes
    nearest (largest smallest barycentric).
    """
    for i in prange(rows.shape[0]):
        h = rows[i]
        q0, q1, q2 = q[h, 0], q[h, 1], q[h, 2]
        n0, n1, n2 = qn[h, 0], qn[h, 1], qn[h, 2]
        g = -1
        facing = False
        for j in range(nearest.shape[1]):  # facing with triangles, else with triangles
            c = nearest[i, j]
            if not has_tri[c]:
                continue
            if gn[c, 0] * n0 + gn[c, 1] * n1 + gn[c, 2] * n2 > 0.0:
                g = c
                facing = True
                break
            if g < 0:
                g = c
        if dist2[i] <= hit2 or g < 0:  # on a guide root, or no triangle near
            _write(out_idx, out_w, h, tris, -1, nearest[i, 0], 1.0, 0.0, 0.0)
            continue
        # along n onto the triangles facing n; with none, along each triangle's normal
        best = -1
        best_min = -np.inf
        best_plane = np.inf
        b0 = b1 = b2 = 0.0
        for _attempt in range(2):
            for k in range(vt_ptr[g], vt_ptr[g + 1]):
                t = vt_idx[k]
                if facing:
                    if not _faces(tc, t, n0, n1, n2):
                        continue
                    l0, l1, l2 = _bary(tv, tc, t, q0, q1, q2, n0, n1, n2)
                else:
                    l0, l1, l2 = _bary(tv, tc, t, q0, q1, q2, tc[t, 0], tc[t, 1], tc[t, 2])
                mn = min(l0, min(l1, l2))
                plane = abs(
                    (q0 - tv[t, 0, 0]) * tn[t, 0]
                    + (q1 - tv[t, 0, 1]) * tn[t, 1]
                    + (q2 - tv[t, 0, 2]) * tn[t, 2]
                )
                if mn >= _INSIDE and best_min >= _INSIDE:
                    better = plane < best_plane
                else:
                    better = mn > best_min
                if better:
                    best, best_min, best_plane = t, mn, plane
                    b0, b1, b2 = l0, l1, l2
            if best >= 0:
                break
            facing = False
        # walk across the edge of the most negative coordinate while outside
        t = best
        l0, l1, l2 = b0, b1, b2
        prev = -1
        for _ in range(_WALK_STEPS):
            if best_min >= _INSIDE:
                break
            pick = -1
            low = _INSIDE
            for e in range(3):
                le = l0 if e == 0 else (l1 if e == 1 else l2)
                if le < low:
                    nt = adj[t, e]
                    if nt >= 0 and nt != prev and (not facing or _faces(tc, nt, n0, n1, n2)):
                        pick = e
                        low = le
            if pick < 0:
                break
            prev = t
            t = adj[t, pick]
            if facing:
                l0, l1, l2 = _bary(tv, tc, t, q0, q1, q2, n0, n1, n2)
            else:
                l0, l1, l2 = _bary(tv, tc, t, q0, q1, q2, tc[t, 0], tc[t, 1], tc[t, 2])
            mn = min(l0, min(l1, l2))
            if mn > best_min:
                best, best_min = t, mn
                b0, b1, b2 = l0, l1, l2
        _write(out_idx, out_w, h, tris, best, -1, b0, b1, b2)


# --------------------------------------------------------------------------- public
class GuideTriangulation:
    """Triangulation of guide roots over a surface (given by root positions and unit normals).

    ``triangles`` (T, 3) int64 indexes ``roots``, wound right-handed about the normals;
    ``roots`` and ``normals`` (unit) are kept as float64. ``neighbours``: how many nearest
    guides each guide makes triangles with (3× that on the border of the triangulation).
    """

    def __init__(self, roots: np.ndarray, normals: np.ndarray, neighbours: int = 12) -> None:
        whole(neighbours, "neighbours", 3, 64, what="a whole number of nearest guides")
        self.roots = _vectors("roots", roots, "guide root positions", allow_empty=False)
        s = len(self.roots)
        n, length2 = _directions("normals", normals, s, "roots")
        self.normals = n / np.sqrt(length2)[:, None]
        self.triangles = np.zeros((0, 3), np.int64)
        if s >= 3:
            self._triangulate(int(neighbours))
        self._prepare()

    # ----------------------------------------------------------------- construction
    def _triangulate(self, k: int) -> None:
        p, n = self.roots, self.normals
        s = len(p)
        tree = cKDTree(p)
        dist, idx = tree.query(p, k=min(s, 2 * k + 1))
        nn = dist[:, 1]
        scale = float(np.median(nn[nn > 0])) if (nn > 0).any() else 0.0
        if scale <= 0.0:
            return  # every root in one place
        # coincident roots: only the first of each group is triangulated
        active = np.ones(s, bool)
        for i, j in sorted(tree.query_pairs(scale * _SAME)):
            if active[i]:
                active[j] = False
        every = np.arange(s, dtype=np.int64)
        near = np.full((s, _GROW * k), -1, np.int64)
        _fill_neighbours(near, every, idx.astype(np.int64), n, active, np.full(s, k, np.int64))
        # local spacing: mean distance to up to 6 nearest facing neighbours (inf: none)
        six = near[:, :6]
        d = np.linalg.norm(p[np.maximum(six, 0)] - p[:, None, :], axis=2)
        count = (six >= 0).sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            spacing = np.where(count > 0, np.where(six >= 0, d, 0.0).sum(axis=1) / count, np.inf)
        rng = np.random.default_rng(0x6A0661E)
        jog = (p - p.mean(axis=0)) + rng.uniform(-1.0, 1.0, p.shape) * (_JOGGLE * scale)
        tris = _thin_edges(p, _propose(every, active, jog, n, near, spacing))
        # guides on an edge with one triangle (a hole, or the border) look farther: with
        # uneven spacing some Delaunay neighbours are past the nearest k. Only triangles
        # with such a corner can change; they are made again.
        if len(tris):
            edge, counts = _edges(tris, s)
            rim = np.zeros(s, bool)
            one = counts[edge] == 1  # (T, 3): the edge opposite corner i
            for i in range(3):
                rim[tris[one[:, i], (i + 1) % 3]] = True
                rim[tris[one[:, i], (i + 2) % 3]] = True
            rows = np.flatnonzero(rim)
            if len(rows) and _GROW * k > k:
                _, idx = tree.query(p[rows], k=min(s, 2 * _GROW * k + 1))
                _fill_neighbours(
                    near,
                    rows,
                    idx.reshape(len(rows), -1).astype(np.int64),
                    n,
                    active,
                    np.full(len(rows), _GROW * k, np.int64),
                )
                lists = rim | (rim[near] & (near >= 0)).any(axis=1)
                again = _propose(np.flatnonzero(lists & active), rim, jog, n, near, spacing)
                tris = _thin_edges(p, np.concatenate([tris[~rim[tris].any(axis=1)], again]))
        self.triangles = np.ascontiguousarray(_peel(p, tris, spacing), dtype=np.int64)

    def _prepare(self) -> None:
        """Per-triangle geometry, adjacency, vertex→triangle CSR and the grid."""
        p, tris = self.roots, self.triangles
        s, t = len(p), len(tris)
        tv = np.ascontiguousarray(p[tris])  # (T, 3, 3)
        self._tv = tv
        self._tc = np.ascontiguousarray(np.cross(tv[:, 1] - tv[:, 0], tv[:, 2] - tv[:, 0]))
        length = np.linalg.norm(self._tc, axis=1)[:, None]
        self._tn = np.ascontiguousarray(self._tc / np.where(length > 0, length, 1.0))
        adj = np.full((t, 3), -1, np.int64)
        if t:
            edge, _ = _edges(tris, s)
            flat = edge.ravel()
            order = np.argsort(flat, kind="stable")
            e = flat[order]
            pair = np.flatnonzero(e[1:] == e[:-1])  # the two triangles on each edge
            a, b = order[pair], order[pair + 1]
            adj.ravel()[a] = b // 3
            adj.ravel()[b] = a // 3
        self._adj = adj
        corners = tris.ravel()
        self._vt_idx = (np.argsort(corners, kind="stable") // 3).astype(np.int64)
        self._vt_ptr = np.zeros(s + 1, np.int64)
        np.cumsum(np.bincount(corners, minlength=s), out=self._vt_ptr[1:])
        self._has_tri = np.diff(self._vt_ptr) > 0
        # uniform grid of the triangles (boxes grown by a margin) and loose guides
        lo, hi = p.min(axis=0), p.max(axis=0)
        extent = hi - lo
        diag = float(np.linalg.norm(extent))
        edges = np.linalg.norm(tv - np.roll(tv, 1, axis=1), axis=2)  # (T, 3)
        cell = float(np.median(edges)) if t else diag / max(s, 1) ** (1.0 / 3.0)
        cell = max(cell, diag * 1e-6, 1e-12)
        cap = 8 * s + 4096
        dims = np.floor(extent / cell).astype(np.int64) + 1
        while int(np.prod(dims)) > cap:
            cell *= 1.25
            dims = np.floor(extent / cell).astype(np.int64) + 1
        self._origin, self._cell, self._dims = lo, cell, dims
        loose = np.flatnonzero(~self._has_tri)
        ptr, items = _bin_boxes(p[loose], p[loose], lo, cell, dims)
        self._loose_ptr, self._loose_items = ptr, loose[items].astype(np.int64)
        grow = (_MARGIN * edges.max(axis=1, initial=0.0) + 1e-9 * diag)[:, None]
        self._tri_ptr, self._tri_items = _bin_boxes(
            tv.min(axis=1) - grow, tv.max(axis=1) + grow, lo, cell, dims
        )
        self._hit2 = (1e-9 * max(cell, diag)) ** 2
        self._tree: cKDTree | None = None

    # ----------------------------------------------------------------- queries
    def weights(self, points: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(idx int64 (H, 3), w float32 (H, 3)) for hair roots ``points`` with unit ``normals``.

        Weights are ≥ 0 and sum to 1; a root on a guide root gets weight 1 on that guide.
        With one guide every hair copies it; with two, or when no triangle was made, the
        hair is projected onto the segment between its two nearest guides (clamped).
        """
        q = _vectors("points", points, "hair root positions", allow_empty=True)
        qn, _ = _directions("normals", normals, len(q), "points")
        h, s = len(q), len(self.roots)
        idx = np.zeros((h, 3), np.int64)
        w = np.zeros((h, 3), np.float32)
        if h == 0:
            return idx, w
        if s == 1:
            w[:, 0] = 1.0
            return idx, w
        if len(self.triangles) == 0:
            if s == 2:
                near = np.tile(np.array([0, 1], np.int64), (h, 1))
            else:
                near = cKDTree(self.roots).query(q, k=2)[1].astype(np.int64)
            return self._segment(q, near)
        order = np.zeros(0, np.int64)
        if len(self.triangles) > _SORT_ABOVE and h > len(self.triangles):
            # many triangles do not stay in cache: visit the hairs cell by cell
            cells = np.clip(np.floor((q - self._origin) / self._cell), 0, self._dims - 1)
            key = (cells[:, 0] * self._dims[1] + cells[:, 1]) * self._dims[2] + cells[:, 2]
            order = np.argsort(key.astype(np.int64), kind="stable")
        _weights_kernel(
            order,
            q,
            qn,
            self._origin,
            self._cell,
            self._dims,
            self._tri_ptr,
            self._tri_items,
            self._loose_ptr,
            self._loose_items,
            self.roots,
            self._hit2,
            self.triangles,
            self._tv,
            self._tc,
            self._tn,
            idx,
            w,
        )
        rows = np.flatnonzero(idx[:, 0] < 0)
        if len(rows):  # off the binned triangles: a border, a hole, far from the guides
            if self._tree is None:
                self._tree = cKDTree(self.roots)
            dist, nearest = self._tree.query(q[rows], k=min(s, _SEARCH))
            nearest = nearest.reshape(len(rows), -1).astype(np.int64)
            dist2 = dist.reshape(len(rows), -1)[:, 0] ** 2
            _search_kernel(
                rows,
                q,
                qn,
                nearest,
                dist2,
                self.normals,
                self._has_tri,
                self._hit2,
                self.triangles,
                self._tv,
                self._tc,
                self._tn,
                self._adj,
                self._vt_ptr,
                self._vt_idx,
                idx,
                w,
            )
        return idx, w

    def _segment(self, q: np.ndarray, near: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weights of each point's projection on the segment between guides near[:, 0:2]."""
        a, b = self.roots[near[:, 0]], self.roots[near[:, 1]]
        ab = b - a
        length2 = np.einsum("ij,ij->i", ab, ab)
        safe = np.where(length2 > 0, length2, 1.0)
        t = np.clip(np.einsum("ij,ij->i", q - a, ab) / safe, 0.0, 1.0)
        idx = np.stack([near[:, 0], near[:, 1], near[:, 0]], axis=1)
        w = np.stack([1.0 - t, t, np.zeros_like(t)], axis=1).astype(np.float32)
        return idx, w
