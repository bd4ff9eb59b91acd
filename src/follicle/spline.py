"""Uniform Catmull-Rom hair curves: evaluation, resampling, cutting, Bezier form, bounds.

Šik 2012 §2.2.8. A curve with vertices P_0..P_{N-1} passes through every vertex with the
uniform parametrisation C(i / (N-1)) = P_i. Segment s (from P_s to P_{s+1}) uses
P_{s-1}, P_s, P_{s+1}, P_{s+2}; the end points are duplicated (P_{-1} = P_0,
P_N = P_{N-1}, seed Fig. 2.8) here only, never in the stored arrays.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import InputError
from .kernels import kernel
from .validate import whole

__all__ = [
    "CATMULL_ROM",
    "evaluate",
    "derivative",
    "vertex_tangents",
    "resample",
    "cut",
    "cut_curves",
    "cut_vertex_count",
    "to_bezier",
    "curve_bounds",
    "bounds",
]

# Šik 2012 §2.2.8: C(t) = [t^3, t^2, t, 1] . M . [P_{i-1}, P_i, P_{i+1}, P_{i+2}] (tension 0.5)
CATMULL_ROM = 0.5 * np.array(
    [[-1.0, 3.0, -3.0, 1.0], [2.0, -5.0, 4.0, -1.0], [-1.0, 0.0, 1.0, 0.0], [0.0, 2.0, 0.0, 0.0]]
)
CATMULL_ROM.setflags(write=False)


# ------------------------------------------------------------------ validation
def _check_curves(points: object, offsets: object) -> tuple[np.ndarray, np.ndarray]:
    """Validated float64 points (P, 3) and int64 offsets (C + 1,) with >= 2 vertices a curve."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points: expected an array of shape (P, 3), got shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise InputError("points: coordinates must be finite (no NaN or inf)")
    offs = np.asarray(offsets)
    if offs.ndim != 1 or offs.size < 1 or (offs.size and not np.issubdtype(offs.dtype, np.integer)):
        raise InputError(
            f"offsets: expected a 1-D integer array of C + 1 entries, got {offs.dtype} {offs.shape}"
        )
    offs = offs.astype(np.int64)
    if offs[0] != 0 or offs[-1] != len(pts):
        raise InputError(
            f"offsets: must start at 0 and end at len(points) = {len(pts)}, "
            f"got {offs[0]} .. {offs[-1]}"
        )
    if np.any(np.diff(offs) < 2):
        raise InputError("offsets: every curve needs at least 2 vertices")
    return np.ascontiguousarray(pts), np.ascontiguousarray(offs)


def _check_vertices(vertices: object) -> np.ndarray:
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 2:
        raise InputError(f"vertices: expected an array of shape (N >= 2, 3), got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise InputError("vertices: coordinates must be finite (no NaN or inf)")
    return np.ascontiguousarray(v)


def _check_params(t: object, name: str, low_open: bool = False, scalar: bool = False) -> np.ndarray:
    arr = np.asarray(t, dtype=np.float64)
    if scalar and arr.ndim != 0:
        raise InputError(f"{name}: expected one number, got an array of shape {arr.shape}")
    lo_ok = arr > 0.0 if low_open else arr >= 0.0
    if not np.all(np.isfinite(arr) & lo_ok & (arr <= 1.0)):
        span = "(0, 1]" if low_open else "[0, 1]"
        raise InputError(f"{name}: curve parameters must lie in {span}")
    return arr


# ------------------------------------------------------------------ scalar kernels
@kernel(inline="always")
def _locate(t: float, nseg: int) -> tuple[int, float]:
    """Segment index s and local parameter in [0, 1] of global t; snaps t at a vertex."""
    u = t * nseg
    r = np.floor(u + 0.5)
    if abs(u - r) <= 1e-12 * max(1.0, u):  # t = i / (N-1) lands on P_i exactly
        u = r
    s = min(int(np.floor(u)), nseg - 1)
    return s, u - s


@kernel(inline="always")
def basis(u: float) -> tuple[float, float, float, float]:
    """Catmull-Rom weights of P_{s-1}, P_s, P_{s+1}, P_{s+2} at u in [0, 1] (Šik 2012 §2.2.8).

    The rows of [u³, u², u, 1] · CATMULL_ROM written out; exact at u = 0 and u = 1.
    """
    u2 = u * u
    u3 = u2 * u
    return (
        0.5 * (-u3 + 2.0 * u2 - u),
        0.5 * (3.0 * u3 - 5.0 * u2 + 2.0),
        0.5 * (-3.0 * u3 + 4.0 * u2 + u),
        0.5 * (u3 - u2),
    )


@kernel(inline="always")
def _dweights(u: float) -> tuple[float, float, float, float]:
    u2 = u * u
    return (
        0.5 * (-3.0 * u2 + 4.0 * u - 1.0),
        0.5 * (9.0 * u2 - 10.0 * u),
        0.5 * (-9.0 * u2 + 8.0 * u + 1.0),
        0.5 * (3.0 * u2 - 2.0 * u),
    )


@kernel(inline="always")
def control_points(start: int, n: int, s: int) -> tuple[int, int, int, int]:
    """Indices of the 4 control points of segment s, end points duplicated (seed Fig. 2.8)."""
    return start + max(s - 1, 0), start + s, start + s + 1, start + min(s + 2, n - 1)


@kernel
def _eval_kernel(v: np.ndarray, ts: np.ndarray, deriv: bool) -> np.ndarray:
    n = v.shape[0]
    nseg = n - 1
    out = np.empty((ts.shape[0], 3), dtype=np.float64)
    for m in range(ts.shape[0]):
        s, u = _locate(ts[m], nseg)
        i0, i1, i2, i3 = control_points(0, n, s)
        if deriv:
            w0, w1, w2, w3 = _dweights(u)
            scale = float(nseg)  # dC/dt = (N-1) dC/du
        else:
            w0, w1, w2, w3 = basis(u)
            scale = 1.0
        for a in range(3):
            out[m, a] = scale * (w0 * v[i0, a] + w1 * v[i1, a] + w2 * v[i2, a] + w3 * v[i3, a])
    return out


def evaluate(vertices: object, t: object) -> np.ndarray:
    """Point C(t) of one curve (N, 3) at t in [0, 1] (scalar or array): (..., 3) float64.

    Šik 2012 §2.2.8 uniform parametrisation: C(i / (N-1)) = P_i exactly.
    """
    v = _check_vertices(vertices)
    tt = _check_params(t, "t")
    return _eval_kernel(v, tt.reshape(-1), False).reshape(tt.shape + (3,))


def derivative(vertices: object, t: object) -> np.ndarray:
    """dC/dt of one curve at t in [0, 1] (global parameter): (..., 3) float64."""
    v = _check_vertices(vertices)
    tt = _check_params(t, "t")
    return _eval_kernel(v, tt.reshape(-1), True).reshape(tt.shape + (3,))


# ------------------------------------------------------------------ all-curve kernels
@kernel
def _tangents_kernel(pts: np.ndarray, offs: np.ndarray) -> np.ndarray:
    out = np.empty_like(pts)
    for c in range(offs.shape[0] - 1):
        a, b = offs[c], offs[c + 1]
        for i in range(a, b):
            # Šik 2012 §2.2.8: T_i = (P_{i+1} - P_{i-1}) / 2 with duplicated end points
            lo = max(i - 1, a)
            hi = min(i + 1, b - 1)
            for k in range(3):
                out[i, k] = 0.5 * (pts[hi, k] - pts[lo, k])
    return out


def vertex_tangents(points: object, offsets: object) -> np.ndarray:
    """(P, 3) float64 Catmull-Rom tangents (P_{i+1} - P_{i-1}) / 2, not normalised.

    They equal dC/du of the segments meeting at the vertex (u the per-segment parameter).
    """
    pts, offs = _check_curves(points, offsets)
    return _tangents_kernel(pts, offs)


@kernel
def _resample_kernel(pts: np.ndarray, offs: np.ndarray, offs2: np.ndarray, k: int) -> np.ndarray:
    out = np.empty((offs2[-1], 3), dtype=np.float32)
    for c in range(offs.shape[0] - 1):
        a = offs[c]
        n = offs[c + 1] - a
        o = offs2[c]
        for s in range(n - 1):
            i0, i1, i2, i3 = control_points(a, n, s)
            for j in range(k):
                w0, w1, w2, w3 = basis(j / k)
                for d in range(3):
                    out[o, d] = (
                        w0 * pts[i0, d] + w1 * pts[i1, d] + w2 * pts[i2, d] + w3 * pts[i3, d]
                    )
                o += 1
        for d in range(3):
            out[o, d] = pts[a + n - 1, d]
    return out


def resample(points: object, offsets: object, k: int) -> tuple[np.ndarray, np.ndarray]:
    """k points per segment of every curve: (points float32, offsets int64).

    A curve of n vertices becomes (n-1)*k + 1 points: each segment at u = j/k,
    j = 0..k-1, then the last vertex. k = 1 returns the vertices themselves.
    """
    k = whole(k, "k", 1, what="a whole number of points per segment")
    pts, offs = _check_curves(points, offsets)
    counts = (np.diff(offs) - 1) * k + 1
    offs2 = np.zeros_like(offs)
    np.cumsum(counts, out=offs2[1:])
    return _resample_kernel(pts, offs, offs2, int(k)), offs2


# ------------------------------------------------------------------ cutting
@kernel
def cut_locate(t: float, nseg: int) -> tuple[int, float]:
    """(s, u) of a cut: u == 0 when t_cut falls on vertex s (then no new vertex is made)."""
    x = t * nseg
    r = np.floor(x + 0.5)
    if abs(x - r) <= 1e-12 * max(1.0, x):
        x = r
    s = int(np.floor(x))
    return s, x - s


@kernel
def _cut_kernel(
    pts: np.ndarray, offs: np.ndarray, nverts: np.ndarray, tcut: np.ndarray, offs2: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    out = np.empty((offs2[-1], 3), dtype=np.float64)
    tpar = np.empty(offs2[-1], dtype=np.float64)
    for c in range(offs.shape[0] - 1):
        a = offs[c]
        n = nverts[c]  # vertex count of the full curve (the parametrisation)
        s, u = cut_locate(tcut[c], n - 1)
        o = offs2[c]
        for i in range(s + 1):  # Šik 2012 §2.2.8 cutting: keep P_0 .. P_s = C(a)
            for d in range(3):
                out[o + i, d] = pts[a + i, d]
            tpar[o + i] = i / (n - 1)  # original parametrisation, not the cut one
        if u > 0.0:  # append C(t_cut); its segment needs P_{s-1} .. P_{s+2}
            i0, i1, i2, i3 = control_points(a, n, s)
            w0, w1, w2, w3 = basis(u)
            for d in range(3):
                out[o + s + 1, d] = (
                    w0 * pts[i0, d] + w1 * pts[i1, d] + w2 * pts[i2, d] + w3 * pts[i3, d]
                )
        tpar[offs2[c + 1] - 1] = tcut[c]
    return out, tpar


@kernel
def _cut_counts(nverts: np.ndarray, tcut: np.ndarray) -> np.ndarray:
    out = np.empty(nverts.shape[0], dtype=np.int64)
    for c in range(nverts.shape[0]):
        s, u = cut_locate(tcut[c], nverts[c] - 1)
        out[c] = s + 1 if u == 0.0 else s + 2
    return out


def cut_vertex_count(n: int, t_cut: float) -> int:
    """How many leading vertices of an n-vertex curve are needed to cut it at t_cut.

    Šik 2012 prints N' = max(ceil(t_cut N) + 2, N), which is always N: a typo for min.
    Derived here: t_cut in segment s (P_s .. P_{s+1}) needs P_{s-1} .. P_{s+2}, i.e.
    min(s + 3, n) vertices; when t_cut falls exactly on vertex s only P_0 .. P_s are
    kept, so s + 1 suffice.
    """
    n = whole(n, "n", 2, what="a vertex count")
    t = float(_check_params(t_cut, "t_cut", low_open=True, scalar=True))
    s, u = cut_locate(t, n - 1)
    return s + 1 if u == 0.0 else min(s + 3, n)


def cut(
    vertices: object, t_cut: float, n_total: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Šik 2012 §2.2.8 cutting: the curve up to C(t_cut) as (vertices2 float64, t_params float64).

    Keeps P_0 .. P_s (P_s the start of the segment holding t_cut) and appends
    C(t_cut); t_cut exactly on a vertex keeps that vertex as the end. ``t_params``
    are each kept vertex's parameter on the ORIGINAL curve (i / (N-1), last =
    t_cut), for root-to-tip attributes. ``n_total`` lets ``vertices`` be only the
    first :func:`cut_vertex_count` vertices of an n_total-vertex curve.
    """
    v = _check_vertices(vertices)
    t = float(_check_params(t_cut, "t_cut", low_open=True, scalar=True))
    n = len(v) if n_total is None else whole(n_total, "n_total", len(v), what="a vertex count")
    need = cut_vertex_count(n, t)
    if len(v) < need:
        raise InputError(
            f"vertices: cutting a {n}-vertex curve at {t} needs its first {need} vertices, "
            f"got {len(v)}"
        )
    v = v[:need]
    nverts = np.array([n], dtype=np.int64)
    tc = np.array([t])
    counts = _cut_counts(nverts, tc)
    offs = np.array([0, need], dtype=np.int64)
    offs2 = np.array([0, counts[0]], dtype=np.int64)
    return _cut_kernel(v, offs, nverts, tc, offs2)


def cut_curves(
    points: object, offsets: object, t_cut: object
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`cut` for every curve at its own t_cut (C,): (points float32, offsets, t_params)."""
    pts, offs = _check_curves(points, offsets)
    ncurves = len(offs) - 1
    tc = np.broadcast_to(_check_params(t_cut, "t_cut", low_open=True), (ncurves,))
    tc = np.ascontiguousarray(tc, dtype=np.float64)
    nverts = np.diff(offs)
    offs2 = np.zeros_like(offs)
    np.cumsum(_cut_counts(nverts, tc), out=offs2[1:])
    out, tpar = _cut_kernel(pts, offs, nverts, tc, offs2)
    return out.astype(np.float32), offs2, tpar


# ------------------------------------------------------------------ Bezier form and bounds
@kernel
def _bezier_kernel(pts: np.ndarray, offs: np.ndarray) -> np.ndarray:
    nseg = pts.shape[0] - (offs.shape[0] - 1)
    out = np.empty((nseg, 4, 3), dtype=np.float64)
    m = 0
    for c in range(offs.shape[0] - 1):
        a = offs[c]
        n = offs[c + 1] - a
        for s in range(n - 1):
            i0, i1, i2, i3 = control_points(a, n, s)
            for d in range(3):
                # Šik 2012 §2.2.8, Bezier conversion: B = [[0,1,0,0],[-1/6,1,1/6,0],...] . P
                out[m, 0, d] = pts[i1, d]
                out[m, 1, d] = pts[i1, d] + (pts[i2, d] - pts[i0, d]) / 6.0
                out[m, 2, d] = pts[i2, d] + (pts[i1, d] - pts[i3, d]) / 6.0
                out[m, 3, d] = pts[i2, d]
            m += 1
    return out


def to_bezier(points: object, offsets: object) -> np.ndarray:
    """(P - C, 4, 3) float64 cubic Bezier control points of every segment, curve by curve."""
    pts, offs = _check_curves(points, offsets)
    return _bezier_kernel(pts, offs)


@kernel(inline="always")
def _cubic_at(c3: float, c2: float, c1: float, c0: float, u: float) -> float:
    return ((c3 * u + c2) * u + c1) * u + c0


@kernel
def _bounds_kernel(pts: np.ndarray, offs: np.ndarray) -> np.ndarray:
    out = np.empty((offs.shape[0] - 1, 2, 3), dtype=np.float64)
    for c in range(offs.shape[0] - 1):
        a = offs[c]
        n = offs[c + 1] - a
        for d in range(3):
            lo = min(pts[a, d], pts[a + n - 1, d])
            hi = max(pts[a, d], pts[a + n - 1, d])
            for s in range(n - 1):
                i0, i1, i2, i3 = control_points(a, n, s)
                p0, p1, p2, p3 = pts[i0, d], pts[i1, d], pts[i2, d], pts[i3, d]
                lo = min(lo, p1)
                hi = max(hi, p1)
                # power-basis coefficients [c3, c2, c1, c0] = CATMULL_ROM . [p0..p3]
                c3 = 0.5 * (-p0 + 3.0 * p1 - 3.0 * p2 + p3)
                c2 = 0.5 * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3)
                c1 = 0.5 * (p2 - p0)
                c0 = p1
                # extrema where C'(u) = A u^2 + B u + K = 0
                qa = 3.0 * c3
                qb = 2.0 * c2
                qk = c1
                r0 = -1.0
                r1 = -1.0
                scale = abs(qa) + abs(qb) + abs(qk)
                if scale == 0.0:
                    continue  # constant along this axis
                if abs(qa) <= 1e-14 * scale:  # linear (or constant) derivative
                    if qb != 0.0:
                        r0 = -qk / qb
                else:
                    disc = qb * qb - 4.0 * qa * qk
                    if disc >= 0.0:
                        # numerically stable quadratic roots
                        q = -0.5 * (qb + math.copysign(math.sqrt(disc), qb))
                        r0 = q / qa
                        if q != 0.0:
                            r1 = qk / q
                for r in (r0, r1):
                    if r > 0.0 and r < 1.0:
                        x = _cubic_at(c3, c2, c1, c0, r)
                        lo = min(lo, x)
                        hi = max(hi, x)
            out[c, 0, d] = lo
            out[c, 1, d] = hi
    return out


def curve_bounds(points: object, offsets: object) -> np.ndarray:
    """(C, 2, 3) exact axis-aligned [lo, hi] boxes of the smooth curves.

    Šik 2012 §2.2.8 bounds each Bezier hull (conservative); here each segment's cubic is
    maximised per axis by solving its derivative quadratic, so the box is tight.
    """
    pts, offs = _check_curves(points, offsets)
    return _bounds_kernel(pts, offs)


def bounds(points: object, offsets: object) -> tuple[np.ndarray, np.ndarray]:
    """Exact axis-aligned bounds (lo (3,), hi (3,)) of all curves together."""
    b = curve_bounds(points, offsets)
    if len(b) == 0:
        raise InputError("points: no curves to bound")
    return b[:, 0].min(axis=0), b[:, 1].max(axis=0)
