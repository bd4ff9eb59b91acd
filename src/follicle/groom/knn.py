"""PointGrid: exact k-nearest-neighbour queries against a small, fixed point set.

Hair interpolation asks, for millions of hair roots, which few guide roots (hundreds to
~10⁵ points on a surface) lie nearest; ``cKDTree.query`` needs ~0.3–0.6 s per million
queries for that on two cores. Here a uniform grid, sized to the point spacing, keeps
for each cell the points of its 3×3×3 block sorted by distance from the cell's centre:
a query scans its cell's list nearly nearest-first (few top-k insertions), stops once
the triangle inequality rules out the rest of the list, and searches one more shell of
cells only when the block cannot prove the answer. The queries left over (far from
every point, or in a cell with an overlong list, as with tightly clustered points) go
to a k-d tree, whose candidates are re-ranked by the same distance and tie rule.

Results are exact: the distances of ``scipy.spatial.cKDTree.query`` and its indices,
except that equal distances are always ordered by the lower point index. So every row
depends only on its own query: querying a concatenation gives the concatenation of the
answers, byte for byte.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from ..arrays import as_points
from ..kernels import kernel, prange
from ..validate import whole

__all__ = ["PointGrid"]

_CELL_FACTOR = 1.4  # cell edge / median distance from a point to its 4th nearest other
_SPACING_SAMPLE = 2000  # points whose neighbours estimate that median
_CELLS_PER_POINT = 8.0  # the dense cell table holds at most this many cells per point …
_MIN_CELLS = 4096  # … or this many, whichever is more
_REL_SLACK = 1e-12  # the stopping test treats a bound as this much (relative) smaller
_REACH = 2  # Chebyshev radius (in cells) searched around a query before the k-d tree
_LIST_MAX = 256  # a query whose cell lists more points goes to the k-d tree
_NEIGHBOURS = np.array(  # the 27 cell offsets of a 3×3×3 block, nearest first
    sorted(
        ((x, y, z) for z in (-1, 0, 1) for y in (-1, 0, 1) for x in (-1, 0, 1)),
        key=lambda o: (o[0] ** 2 + o[1] ** 2 + o[2] ** 2, o[2], o[1], o[0]),
    ),
    dtype=np.int64,
)


class PointGrid:
    """Exact k-nearest-neighbour queries against a fixed point set, on a uniform grid.

    The cell edge is 1.4× the median distance from a point to its 4th nearest other
    (so a 3×3×3 block usually holds the few nearest), enlarged where needed to keep the
    dense cell table at most max(8 · n, 4096) cells. Points are stored sorted by cell
    with one start offset per cell (CSR), and each cell has a list of the points of its
    3×3×3 block sorted by distance from its centre (at most 27 · n entries of 8 bytes).
    A cKDTree over the points answers the queries the grid cannot settle cheaply.
    Ties in distance are broken by the lower point index.
    """

    n: int

    def __init__(self, points: np.ndarray) -> None:
        pts = as_points("points", points, allow_empty=False).copy()  # ours, not the caller's
        self.n = int(pts.shape[0])
        lo = pts.min(axis=0)
        hi = pts.max(axis=0)
        extent = hi - lo
        span = float(extent.max())

        self._tree = cKDTree(pts)
        self._orig = pts
        h = 0.0
        if self.n > 1 and span > 0.0:
            sample = pts[:: max(1, self.n // _SPACING_SAMPLE)]  # strided: deterministic
            dist, _ = self._tree.query(sample, k=min(5, self.n))
            far = dist[:, -1]
            far = far[far > 0.0]  # duplicates say nothing about the spacing
            if far.size:
                h = _CELL_FACTOR * float(np.median(far))
        if not h > 0.0:  # one point, or all points equal
            h = span if span > 0.0 else 1.0
        max_cells = max(_CELLS_PER_POINT * self.n, float(_MIN_CELLS))
        while True:
            dims = np.maximum(np.ceil(extent / h), 1.0)
            if float(np.prod(dims)) <= max_cells:
                break
            h *= max(1.01, (float(np.prod(dims)) / max_cells) ** (1.0 / 3.0))
        dims = dims.astype(np.int64)

        inv_h = 1.0 / h
        cell3 = np.floor((pts - lo) * inv_h).astype(np.int64)
        np.clip(cell3, 0, dims - 1, out=cell3)
        cell = (cell3[:, 2] * dims[1] + cell3[:, 1]) * dims[0] + cell3[:, 0]
        order = np.argsort(cell, kind="stable")
        ncell = int(np.prod(dims))
        starts = np.zeros(ncell + 1, dtype=np.int64)
        np.cumsum(np.bincount(cell, minlength=ncell), out=starts[1:])

        self._points = np.ascontiguousarray(pts[order])
        self._index = order.astype(np.int64)
        self._starts = starts
        self._list_starts, self._list_pos, self._list_dist = _build_lists(
            self._points, starts, dims, lo, h
        )
        self._dims = dims
        self._lo = lo
        self._hi = hi
        self._h = h
        self._inv_h = inv_h
        # Absolute slack for the stopping test: covers rounding in cell assignment and in
        # the cell-face positions (a few ulps of the coordinates' magnitude).
        scale = float(np.abs(lo).max() + np.abs(hi).max()) + span + h
        self._eps = 1e-10 * scale

    def query(self, queries: np.ndarray, k: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """(distances float64 (H, k), indices int64 (H, k)), nearest first, like cKDTree.query.

        ``k`` is clamped to ``n``; the result is always 2-D. Equal distances are ordered
        by the lower point index.
        """
        q = as_points("queries", queries)
        kk = min(whole(k, "k", 1), self.n)
        dist = np.empty((q.shape[0], kk), dtype=np.float64)
        index = np.empty((q.shape[0], kk), dtype=np.int64)
        if q.shape[0] == 0:
            return dist, index
        hard = np.empty(q.shape[0], dtype=np.uint8)
        _query_kernel(
            q,
            self._points,
            self._index,
            self._starts,
            self._list_starts,
            self._list_pos,
            self._list_dist,
            self._dims,
            self._lo,
            self._hi,
            self._h,
            self._inv_h,
            self._eps,
            _REACH,
            _LIST_MAX,
            dist,
            index,
            hard,
        )
        rows = np.flatnonzero(hard)
        if rows.size:
            self._tree_query(q, rows, dist, index)
        return dist, index

    def _tree_query(
        self, q: np.ndarray, rows: np.ndarray, dist: np.ndarray, index: np.ndarray
    ) -> None:
        """Fill ``rows`` from the k-d tree: k + 1 candidates re-ranked by our distance and
        tie rule; where the (k+1)-th cannot prove that ranking (near ties), every point
        within the k-th distance."""
        k = dist.shape[1]
        m = min(self.n, k + 1)
        cd, ci = self._tree.query(q[rows], m, workers=-1)
        cd = np.reshape(cd, (rows.size, m))
        ci = np.reshape(ci, (rows.size, m)).astype(np.int64, copy=False)
        beyond = cd[:, -1] if m < self.n else np.full(rows.size, np.inf)
        ok = np.empty(rows.size, dtype=np.bool_)
        _rank_kernel(q, rows, self._orig, ci, np.ascontiguousarray(beyond), dist, index, ok)
        for f in np.flatnonzero(~ok):
            qi = int(rows[f])
            radius = float(dist[qi, -1]) * (1.0 + 1e-9) + 1e-300
            cand = np.asarray(self._tree.query_ball_point(q[qi], radius), dtype=np.int64)
            one = np.array([qi], dtype=np.int64)
            _rank_kernel(q, one, self._orig, cand[None, :], np.array([radius]), dist, index, ok)

    def __repr__(self) -> str:
        d = self._dims
        return f"PointGrid(n={self.n}, cells={d[0]}×{d[1]}×{d[2]}, cell_size={self._h:.4g})"


# ---------------------------------------------------------------------- build
@kernel(parallel=True, nogil=True)
def _build_lists(pts, starts, dims, lo, h):
    """Per cell, the points of its 3×3×3 block sorted by distance from the cell's centre.

    Returns (list_starts int64 (cells + 1), positions int32 into ``pts``, distances
    float32 rounded down so that they stay lower bounds).
    """
    nx, ny, nz = dims[0], dims[1], dims[2]
    ncell = nx * ny * nz
    counts = np.zeros(ncell + 1, dtype=np.int64)
    for c in prange(ncell):
        x = c % nx
        y = (c // nx) % ny
        z = c // (nx * ny)
        m = 0
        for zz in range(max(z - 1, 0), min(z + 1, nz - 1) + 1):
            for yy in range(max(y - 1, 0), min(y + 1, ny - 1) + 1):
                row = (zz * ny + yy) * nx
                m += starts[row + min(x + 1, nx - 1) + 1] - starts[row + max(x - 1, 0)]
        counts[c + 1] = m
    list_starts = np.cumsum(counts)
    total = list_starts[ncell]
    pos = np.empty(total, dtype=np.int32)
    dist = np.empty(total, dtype=np.float32)
    for c in prange(ncell):
        s = list_starts[c]
        e = list_starts[c + 1]
        if s == e:
            continue
        x = c % nx
        y = (c // nx) % ny
        z = c // (nx * ny)
        ox = lo[0] + (x + 0.5) * h
        oy = lo[1] + (y + 0.5) * h
        oz = lo[2] + (z + 0.5) * h
        at = s
        for o in range(27):  # centre, faces, edges, corners: nearly sorted already
            xx = x + _NEIGHBOURS[o, 0]
            yy = y + _NEIGHBOURS[o, 1]
            zz = z + _NEIGHBOURS[o, 2]
            if xx < 0 or xx >= nx or yy < 0 or yy >= ny or zz < 0 or zz >= nz:
                continue
            cell = (zz * ny + yy) * nx + xx
            for p in range(starts[cell], starts[cell + 1]):
                dx = pts[p, 0] - ox
                dy = pts[p, 1] - oy
                dz = pts[p, 2] - oz
                # shrunk by 1e-7 before rounding to float32 (and capped below float32's
                # largest) so that the stored D stays a lower bound
                d = min(math.sqrt(dx * dx + dy * dy + dz * dz) * (1.0 - 1e-7), 3e38)
                pos[at] = p
                dist[at] = np.float32(d)
                at += 1
        # sort the list by the stored D (the scan stops at the first D too far)
        if e - s > 64:
            order = np.argsort(dist[s:e], kind="mergesort")
            pos[s:e] = pos[s:e][order]
            dist[s:e] = dist[s:e][order]
        else:
            for j in range(s + 1, e):
                dj = dist[j]
                pj = pos[j]
                i = j
                while i > s and dist[i - 1] > dj:
                    dist[i] = dist[i - 1]
                    pos[i] = pos[i - 1]
                    i -= 1
                dist[i] = dj
                pos[i] = pj
    return list_starts, pos, dist


# ---------------------------------------------------------------------- kernel
@kernel(inline="always")
def _offer(d2, ip, out_d, out_i, qi, k):
    """Insert (d2, ip) into row qi's sorted top-k buffer; return the new k-th distance²."""
    j = k - 1
    while j > 0:
        dj = out_d[qi, j - 1]
        if dj < d2 or (dj == d2 and out_i[qi, j - 1] < ip):
            break
        out_d[qi, j] = dj
        out_i[qi, j] = out_i[qi, j - 1]
        j -= 1
    out_d[qi, j] = d2
    out_i[qi, j] = ip
    return out_d[qi, k - 1]


@kernel(inline="always")
def _scan(pts, index, start, stop, qx, qy, qz, out_d, out_i, qi, k):
    """Offer points start … stop−1 to row qi's top-k buffer; return the k-th distance²."""
    worst = out_d[qi, k - 1]
    for p in range(start, stop):
        worst = _consider(pts, index, p, qx, qy, qz, out_d, out_i, qi, k, worst)
    return worst


@kernel(inline="always")
def _consider(pts, index, p, qx, qy, qz, out_d, out_i, qi, k, worst):
    """Offer point p to row qi's top-k when it beats the k-th (ties: lower index); new k-th d²."""
    dx = qx - pts[p, 0]
    dy = qy - pts[p, 1]
    dz = qz - pts[p, 2]
    d2 = dx * dx + dy * dy + dz * dz
    if d2 > worst:
        return worst
    ip = index[p]
    if d2 == worst and ip > out_i[qi, k - 1]:
        return worst
    return _offer(d2, ip, out_d, out_i, qi, k)


@kernel(inline="always")
def _gap2(v, c, origin, h, eps):
    """Squared lower bound on the distance along one axis from v to a point of slab c."""
    g = max(origin + c * h - v, v - (origin + (c + 1) * h), 0.0) - eps
    return g * g if g > 0.0 else 0.0


@kernel(inline="always")
def _outside(v, lo, hi):
    """Distance from v to the interval [lo, hi] (0 inside)."""
    if v < lo:
        return lo - v
    if v > hi:
        return v - hi
    return 0.0


@kernel(inline="always")
def _offset(a):
    """0, −1, 1, −2, 2, … for a = 0, 1, 2, 3, 4, …: rows from the centre outward."""
    m = (a + 1) // 2
    return -m if a & 1 else m


@kernel(inline="always")
def _unvisited_bound2(qx, qy, qz, cx, cy, cz, r, dims, lo, hi, h, eps):
    """Lower bound on the squared distance to a point outside the block of radius r.

    Over the block's faces with cells beyond them, the distance to the part of the
    points' bounding box beyond the face; inf when the block covers the whole grid.
    """
    q = (qx, qy, qz)
    c = (cx, cy, cz)
    out = (_outside(qx, lo[0], hi[0]), _outside(qy, lo[1], hi[1]), _outside(qz, lo[2], hi[2]))
    b2 = np.inf
    for a in range(3):
        side2 = out[(a + 1) % 3] ** 2 + out[(a + 2) % 3] ** 2  # beyond the box on the others
        if c[a] - r > 0:
            d = max(q[a] - (lo[a] + (c[a] - r) * h) - eps, 0.0)
            b2 = min(b2, d * d + side2)
        if c[a] + r < dims[a] - 1:
            d = max(lo[a] + (c[a] + r + 1) * h - q[a] - eps, 0.0)
            b2 = min(b2, d * d + side2)
    return b2


@kernel(nogil=True)
def _shells(
    qx, qy, qz, cx, cy, cz, pts, index, starts, dims, lo, hi, h, eps, reach, worst, out_d, out_i, qi
):
    """Search the shells of cells at Chebyshev distance 2 … reach around (cx, cy, cz).

    Row qi holds the top-k of the 3×3×3 block (k-th distance² ``worst``). Returns True
    when the row is then proven, False when the k-d tree must take over.
    """
    nx, ny, nz = dims[0], dims[1], dims[2]
    k = out_d.shape[1]
    keep = 1.0 - _REL_SLACK
    for r in range(2, reach + 1):
        # rows of constant (y, z) from the centre outward, skipping cells that cannot
        # hold a point nearer than the k-th
        for a in range(2 * r + 1):
            dz = _offset(a)
            z = cz + dz
            if z < 0 or z >= nz:
                continue
            gz2 = _gap2(qz, z, lo[2], h, eps)
            if gz2 * keep > worst:
                continue
            for b in range(2 * r + 1):
                dy = _offset(b)
                y = cy + dy
                if y < 0 or y >= ny:
                    continue
                g2 = gz2 + _gap2(qy, y, lo[1], h, eps)
                if g2 * keep > worst:
                    continue
                row = (z * ny + y) * nx
                if dz == r or dz == -r or dy == r or dy == -r:
                    x0 = max(cx - r, 0)
                    x1 = min(cx + r, nx - 1)
                    while x0 < cx and (g2 + _gap2(qx, x0, lo[0], h, eps)) * keep > worst:
                        x0 += 1
                    while x1 > cx and (g2 + _gap2(qx, x1, lo[0], h, eps)) * keep > worst:
                        x1 -= 1
                    worst = _scan(
                        pts,
                        index,
                        starts[row + x0],
                        starts[row + x1 + 1],
                        qx,
                        qy,
                        qz,
                        out_d,
                        out_i,
                        qi,
                        k,
                    )
                else:
                    for x in (cx - r, cx + r):
                        if 0 <= x < nx and (g2 + _gap2(qx, x, lo[0], h, eps)) * keep <= worst:
                            c = row + x
                            worst = _scan(
                                pts,
                                index,
                                starts[c],
                                starts[c + 1],
                                qx,
                                qy,
                                qz,
                                out_d,
                                out_i,
                                qi,
                                k,
                            )
        b2 = _unvisited_bound2(qx, qy, qz, cx, cy, cz, r, dims, lo, hi, h, eps)
        if b2 == np.inf or b2 * keep > worst:
            return True
    return False


@kernel(parallel=True, nogil=True)
def _query_kernel(
    queries,
    pts,
    index,
    starts,
    list_starts,
    list_pos,
    list_dist,
    dims,
    lo,
    hi,
    h,
    inv_h,
    eps,
    reach,
    list_max,
    out_d,
    out_i,
    hard,
):
    """Top-k rows from the grid; hard[q] = 1 marks rows left to the k-d tree."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    k = out_d.shape[1]
    big = index.shape[0]
    keep = 1.0 - _REL_SLACK  # a bound b² rules out a cell or shell only if b²·keep > worst
    grow = 1.0 + _REL_SLACK
    for qi in prange(queries.shape[0]):
        qx = queries[qi, 0]
        qy = queries[qi, 1]
        qz = queries[qi, 2]
        fx = (qx - lo[0]) * inv_h
        fy = (qy - lo[1]) * inv_h
        fz = (qz - lo[2]) * inv_h
        if not (-1.0 <= fx <= nx + 1.0 and -1.0 <= fy <= ny + 1.0 and -1.0 <= fz <= nz + 1.0):
            hard[qi] = 1  # more than a cell outside the grid: the tree is faster
            continue
        cx = min(max(int(math.floor(fx)), 0), nx - 1)
        cy = min(max(int(math.floor(fy)), 0), ny - 1)
        cz = min(max(int(math.floor(fz)), 0), nz - 1)
        c = (cz * ny + cy) * nx + cx
        first = list_starts[c]
        last = list_starts[c + 1]
        if last - first > list_max:
            hard[qi] = 1
            continue
        for j in range(k):
            out_d[qi, j] = np.inf
            out_i[qi, j] = big
        worst = np.inf
        # the 3×3×3 block: the cell's list, nearest its centre first; by the triangle
        # inequality |q − p| ≥ D − |q − centre|, so the scan stops at the first D too far
        ex = qx - (lo[0] + (cx + 0.5) * h)
        ey = qy - (lo[1] + (cy + 0.5) * h)
        ez = qz - (lo[2] + (cz + 0.5) * h)
        t = math.sqrt(ex * ex + ey * ey + ez * ez) + eps
        stop = np.inf  # D beyond which no entry can beat the k-th: t + √worst, with slack
        for e in range(first, last):
            if list_dist[e] > stop:
                break
            new = _consider(pts, index, list_pos[e], qx, qy, qz, out_d, out_i, qi, k, worst)
            if new != worst:
                worst = new
                stop = t + math.sqrt(worst) * grow
        # any point outside the block is at least 1.5·h − max|e| away (the nearest face)
        b = 1.5 * h - max(abs(ex), abs(ey), abs(ez)) - eps
        done = b > 0.0 and b * b * keep > worst
        if not done:
            b2 = _unvisited_bound2(qx, qy, qz, cx, cy, cz, 1, dims, lo, hi, h, eps)
            done = b2 == np.inf or b2 * keep > worst
        if not done and worst < np.inf:  # fewer than k points in the block: far from all
            done = _shells(
                qx,
                qy,
                qz,
                cx,
                cy,
                cz,
                pts,
                index,
                starts,
                dims,
                lo,
                hi,
                h,
                eps,
                reach,
                worst,
                out_d,
                out_i,
                np.int64(qi),  # prange's index is unsigned in the parallel loop: one type
            )
        if done:
            hard[qi] = 0
            for j in range(k):
                out_d[qi, j] = math.sqrt(out_d[qi, j])
        else:
            hard[qi] = 1


@kernel(parallel=True, nogil=True)
def _rank_kernel(queries, rows, points, cand, beyond, out_d, out_i, ok):
    """Top-k of each row's candidates (original indices) by distance², then index.

    ok[f] says the ranking is proven: every non-candidate lies at least beyond[f] away.
    """
    k = out_d.shape[1]
    big = points.shape[0]
    keep = 1.0 - _REL_SLACK
    for f in prange(rows.shape[0]):
        qi = rows[f]
        qx = queries[qi, 0]
        qy = queries[qi, 1]
        qz = queries[qi, 2]
        for j in range(k):
            out_d[qi, j] = np.inf
            out_i[qi, j] = big
        worst = np.inf
        for j in range(cand.shape[1]):
            p = cand[f, j]
            dx = qx - points[p, 0]
            dy = qy - points[p, 1]
            dz = qz - points[p, 2]
            d2 = dx * dx + dy * dy + dz * dz
            if d2 > worst or (d2 == worst and p > out_i[qi, k - 1]):
                continue
            worst = _offer(d2, p, out_d, out_i, qi, k)
        ok[f] = beyond[f] * beyond[f] * keep > worst
        for j in range(k):
            out_d[qi, j] = math.sqrt(out_d[qi, j])
