"""Finishing hairs (Šik 2012 §2.2.8, §2.2.9): cut, curve normals, vertex removal, placement.

The generator shapes a bucket of m curves as one rectangular float64 array (m, n, 3)
in root-local frames; every curve then has its own length. The kernels here cut each
curve at its t_cut in place, mark the vertices that stay (not past the cut, not
degenerate, not redundant by the skip threshold) and pack the kept vertices, placed
on the skin and with their rotation-minimising frame normals, into flat arrays.
"""

from __future__ import annotations

import numpy as np

from ..arrays import readonly
from ..frames import polyline_frames
from ..kernels import kernel, prange
from ..spline import basis, control_points, cut_locate
from .appearance import vertex_look

__all__ = ["cut_plan", "cut_in_place", "finish", "pack"]

_ROOT_TANGENT = np.array([1.0, 0.0, 0.0])  # local +x: the first curve normal N_0 (§2.2.8)


@kernel(nogil=True)
def _plan_kernel(tcut, n_total, need):
    for h in range(tcut.shape[0]):
        s, u = cut_locate(tcut[h], n_total - 1)
        need[h] = s + 1 if u == 0.0 else min(s + 3, n_total)


def cut_plan(tcut: np.ndarray, n_total: int) -> np.ndarray:
    """Vertices each hair needs before cutting at ``tcut`` (early culling, Šik 2012 §2.2.8).

    A cut in segment s needs P_0 .. P_{s+2} (the segment's Catmull-Rom neighbours); a
    cut exactly on vertex s needs P_0 .. P_s. 0 for t_cut = 0 (the hair is dropped).
    """
    tcut = np.ascontiguousarray(tcut, dtype=np.float64)
    need = np.empty(len(tcut), dtype=np.int64)
    _plan_kernel(tcut, int(n_total), need)
    need[tcut <= 0.0] = 0
    return need


@kernel(parallel=True, nogil=True)
def _cut_kernel(p, tcut, n_total, length, t_end):
    n = p.shape[1]
    for h in prange(p.shape[0]):
        s, u = cut_locate(tcut[h], n_total - 1)
        if s >= n_total - 1 or u == 0.0:  # uncut, or cut on vertex s: keep P_0 .. P_s
            length[h] = min(s + 1, n)
            t_end[h] = (length[h] - 1) / (n_total - 1)
            continue
        i0, i1, i2, i3 = control_points(0, n_total, s)
        w0, w1, w2, w3 = basis(u)
        for a in range(3):
            p[h, s + 1, a] = (
                w0 * p[h, i0, a] + w1 * p[h, i1, a] + w2 * p[h, i2, a] + w3 * p[h, i3, a]
            )
        t_end[h] = tcut[h]
        length[h] = s + 2


def cut_in_place(p: np.ndarray, tcut: np.ndarray, n_total: int) -> tuple[np.ndarray, np.ndarray]:
    """Cut curves ``p`` (m, n, 3) of ``n_total``-vertex hairs at ``tcut`` (m,), in place.

    Vertex s + 1 becomes C(t_cut) (Šik 2012 §2.2.8). Returns (length (m,): vertices kept;
    t_end (m,): the parameter of the last kept vertex). Every vertex keeps the parameter
    i / (n_total − 1) of the uncut curve but the cut vertex, which gets t_cut.
    ``p`` must hold at least :func:`cut_plan` vertices of every curve.
    """
    length = np.empty(p.shape[0], dtype=np.int64)
    t_end = np.empty(p.shape[0], dtype=np.float64)
    _cut_kernel(p, readonly(tcut, np.float64), int(n_total), length, t_end)
    return length, t_end


@kernel(inline="always")
def _tangent(q, i, m):
    """Unit Catmull-Rom tangent (P_{i+1} − P_{i−1}) / 2 at vertex i of q[:m] (zero stays zero)."""
    lo = max(i - 1, 0)
    hi = min(i + 1, m - 1)
    x = q[hi, 0] - q[lo, 0]
    y = q[hi, 1] - q[lo, 1]
    z = q[hi, 2] - q[lo, 2]
    d = np.sqrt(x * x + y * y + z * z)
    if d > 0.0:
        return x / d, y / d, z / d
    return 0.0, 0.0, 0.0


@kernel(inline="always")
def _similar(q, i, j, m, threshold):
    ax, ay, az = _tangent(q, i, m)
    bx, by, bz = _tangent(q, j, m)
    return ax * bx + ay * by + az * bz > threshold


@kernel(parallel=True, nogil=True)
def _keep_kernel(p, length, threshold, keep):
    n = p.shape[1]
    for h in prange(p.shape[0]):
        m = length[h]
        for i in range(n):
            keep[h, i] = False
        if m < 2:
            continue
        q = p[h]
        total = 0.0
        for i in range(1, m):
            total += np.sqrt(
                (q[i, 0] - q[i - 1, 0]) ** 2
                + (q[i, 1] - q[i - 1, 1]) ** 2
                + (q[i, 2] - q[i - 1, 2]) ** 2
            )
        eps = 1e-6 * total / (m - 1)  # "equal" vertices: per hair, chunk independent
        keep[h, 0] = True
        last = 0
        kept = 1
        for i in range(1, m):
            d = np.sqrt(
                (q[i, 0] - q[last, 0]) ** 2
                + (q[i, 1] - q[last, 1]) ** 2
                + (q[i, 2] - q[last, 2]) ** 2
            )
            if d <= eps:
                continue  # §2.2.2 remove degenerate vertices
            if (
                i < m - 1
                and threshold <= 1.0
                and _similar(q, i, last, m, threshold)
                and _similar(q, i, i + 1, m, threshold)
            ):
                continue  # §2.2.9 skip: the tangent is like both neighbours'
            keep[h, i] = True
            last = i
            kept += 1
        if kept < 2:  # the hair has completely degenerated
            keep[h, 0] = False


def finish(p: np.ndarray, length: np.ndarray, skip_threshold: float | None) -> np.ndarray:
    """The keep mask (m, n) of cut curves ``p`` (m, n, 3) with ``length`` vertices each.

    A vertex is kept unless it lies past the cut, within 1e-6 of the mean segment
    length of the previous kept vertex (degenerate, Šik 2012 §2.2.2), or, with a
    ``skip_threshold``, the cosine of its tangent with both the previous kept vertex's
    and the next vertex's tangent exceeds it (§2.2.9; comparing with the previous KEPT
    vertex stops a gentle arc from being thinned away vertex by vertex). First and last
    vertices always stay; a hair left with one vertex is dropped (all False).
    """
    keep = np.empty(p.shape[:2], dtype=np.bool_)
    threshold = 2.0 if skip_threshold is None else float(skip_threshold)
    _keep_kernel(p, length, threshold, keep)
    return keep


_BLOCK = 128  # curves per scratch buffer in the pack kernel


@kernel(parallel=True, nogil=True)
def _pack_kernel(
    p,
    length,
    keep,
    rows,
    origin,
    tangent,
    binormal,
    normal,
    start,
    first,
    ends,
    t_end,
    n_total,
    out_p,
    out_n,
    out_c,
    out_w,
    out_o,
):
    m, n = p.shape[0], p.shape[1]
    step = 1.0 / (n_total - 1)
    for blk in prange((m + _BLOCK - 1) // _BLOCK):
        tan = np.empty((n, 3))
        nor = np.empty((n, 3))
        bi = np.empty((0, 3))  # normals only
        for h in range(blk * _BLOCK, min(m, (blk + 1) * _BLOCK)):
            if not keep[h, 0]:
                continue
            L = length[h]
            polyline_frames(p[h, :L], first, tan[:L], nor[:L], bi)
            r = rows[h]
            k = start[h]
            for i in range(L):
                if not keep[h, i]:
                    continue
                x, y, z = p[h, i, 0], p[h, i, 1], p[h, i, 2]
                nx, ny, nz = nor[i, 0], nor[i, 1], nor[i, 2]
                for a in range(3):
                    out_p[k, a] = (
                        origin[r, a] + x * tangent[r, a] + y * binormal[r, a] + z * normal[r, a]
                    )
                    out_n[k, a] = nx * tangent[r, a] + ny * binormal[r, a] + nz * normal[r, a]
                t = i * step if i < L - 1 else t_end[h]
                out_c[k, 0], out_c[k, 1], out_c[k, 2], out_w[k], out_o[k] = vertex_look(ends[h], t)
                k += 1


def pack(
    p: np.ndarray,
    length: np.ndarray,
    keep: np.ndarray,
    rows: np.ndarray,
    frame: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    start: np.ndarray,
    ends: np.ndarray,
    t_end: np.ndarray,
    n_total: int,
    out: dict[str, np.ndarray],
) -> None:
    """Write the kept vertices of curves ``p`` into ``out`` from vertex ``start[h]`` on.

    Curve normals are the rotation-minimising frame normals of each cut curve with
    N_0 the root tangent (Šik 2012 §2.2.8). Points and normals go from the root-local frame
    of hair ``rows[h]`` to the skin: ``frame`` = (origin, tangent, binormal, normal),
    each (hairs, 3) float64. Colour, width and opacity come from each curve's
    :func:`.appearance.hair_ends` row at the vertex's parameter on the uncut
    ``n_total``-vertex curve (``t_end`` for the last one, from :func:`cut_in_place`).
    """
    _pack_kernel(
        p,
        length,
        keep,
        rows,
        *frame,
        start,
        _ROOT_TANGENT,
        ends,
        t_end,
        int(n_total),
        out["points"],
        out["normal"],
        out["color"],
        out["width"],
        out["opacity"],
    )
