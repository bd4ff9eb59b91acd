"""Curves of any basis reduced to the points they pass through: pure numpy, no pxr.

follicle's curves are Catmull-Rom curves through their vertices (see
:mod:`follicle.curves`), so a file's curves of another kind (linear, Bézier, B-spline,
Catmull-Rom with or without pinned ends, as USD's ``BasisCurves`` and Alembic's
``ICurves`` describe them) are turned into points on the curve: :func:`rule` names the
mapping for a prim's type, basis and wrap, :func:`out_counts` gives the points per
curve it makes and :func:`through_points` maps any per-vertex values with it. NURBS
curves (USD's ``UsdGeomNurbsCurves``, Alembic's NURBS ``ICurves``; order, knots,
optional weights) are evaluated, rational or not, at their knots and evenly between
them by :func:`nurbs_stencil`, whose :class:`NurbsStencil` maps vertex and varying
values the same way; :func:`nurbs_points` gives just the points. This module imports
only numpy: the guarded reading server (:mod:`follicle.io.guard_server`) imports it in
its children beside usd-core and Alembic.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "scope_sizes",
    "CurveBasisError",
    "rule",
    "out_counts",
    "through_points",
    "NurbsStencil",
    "nurbs_stencil",
    "nurbs_points",
    "MAX_ORDER",
]

_VSTEP = {"bezier": 3, "bspline": 1, "catmullRom": 1}  # USD's vstep of each cubic basis


class CurveBasisError(ValueError):
    """Curves this module cannot reduce to points; the message names them and why."""


def topology(
    counts: np.ndarray, points: np.ndarray, where: str, counts_name: str, points_name: str
) -> np.ndarray:
    """A curves object's vertex counts as int64, checked against its points (whole
    numbers, none negative, summing to the point count; points x, y, z rows):
    CurveBasisError naming ``where`` and the file's own attribute names otherwise."""
    if counts.ndim != 1 or counts.dtype.kind not in "iu":
        raise CurveBasisError(
            f"{where}: {counts_name} must be int[], got {counts.dtype} of shape {counts.shape}"
        )
    if points.ndim != 2 or points.shape[1] != 3:
        raise CurveBasisError(
            f"{where}: {points_name} must be point3f[] (x, y, z each), got shape {points.shape}"
        )
    counts = counts.astype(np.int64)
    if np.any(counts < 0):
        i = int(np.argmax(counts < 0))
        raise CurveBasisError(f"{where}: curve {i} has a negative vertex count ({int(counts[i])})")
    if int(counts.sum()) != len(points):
        raise CurveBasisError(
            f"{where}: {counts_name} sum to {int(counts.sum())} but there are {len(points)} points"
        )
    return counts


def rule(kind: str, basis: str, wrap: str, counts: np.ndarray, where: str) -> str:
    """How curves of ``kind`` (linear or cubic), ``basis`` and ``wrap`` map their control
    vertices to the points they pass through: ``"all"`` (every vertex), ``"inner"`` (all
    but the two ends: nonperiodic Catmull-Rom), ``"bezier"`` (every third),
    ``"knots"`` (a uniform B-spline at its knots) or ``"pinned-knots"`` (the same with
    USD's phantom end points added first). CurveBasisError naming ``where`` for
    periodic curves, an unknown basis or a curve with too few (or, Bézier, a wrong
    number of) vertices."""
    if wrap == "periodic":
        raise CurveBasisError(f"{where}: periodic (closed) curves are not hair; not read")
    if kind == "linear":  # a one-vertex curve is read, and left out by the caller
        low, mapping = 1, "all"
    elif basis not in _VSTEP:
        raise CurveBasisError(f"{where}: unknown basis '{basis}' (bezier, bspline or catmullRom)")
    elif wrap == "pinned" and basis != "bezier":
        low, mapping = (1, "all") if basis == "catmullRom" else (2, "pinned-knots")
    else:
        low = 4
        mapping = {"bezier": "bezier", "bspline": "knots", "catmullRom": "inner"}[basis]
    bad = (counts < low) | (((counts - 4) % 3 != 0) if mapping == "bezier" else False)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise CurveBasisError(
            f"{where}: curve {i} has {int(counts[i])} vertices, invalid for"
            f" {kind} {basis} {wrap} curves"
        )
    return mapping


def out_counts(mapping: str, counts: np.ndarray) -> np.ndarray:
    """Points per curve that :func:`through_points` makes of curves of ``counts``
    vertices under ``mapping`` (a :func:`rule`)."""
    if mapping in ("inner", "knots"):
        return counts - 2
    if mapping == "bezier":
        return (counts - 1) // 3 + 1
    return counts


def scope_sizes(counts: np.ndarray, vertices: int, varying: np.ndarray) -> dict[str, int]:
    """How many values a primvar / geometry parameter of each scope holds on curves of
    ``counts`` control vertices (``vertices`` in all) whose segments give ``varying``
    values each: USD's interpolations and Alembic's scopes by the same names."""
    return {
        "constant": 1,
        "uniform": len(counts),
        "vertex": vertices,
        "varying": int(varying.sum()),
        "faceVarying": int(varying.sum()),
    }


def through_points(values: np.ndarray, counts: np.ndarray, mapping: str) -> np.ndarray:
    """Per-control-vertex ``values`` (rows, curves of ``counts`` vertices one after
    another) at the points the curves pass through under ``mapping`` (a :func:`rule`).
    Floating values are evaluated on the curve; others (ids, flags) are taken from the
    nearest vertex."""
    offsets = np.concatenate([[0], np.cumsum(counts)])
    if mapping == "all":
        return values
    if mapping == "pinned-knots":  # add USD's phantom ends, then as nonperiodic
        starts, ends = offsets[:-1], offsets[1:] - 1
        first, last = values[starts], values[ends]
        if np.issubdtype(values.dtype, np.floating):
            first, last = 2 * first - values[starts + 1], 2 * last - values[ends - 1]
        at = np.arange(len(values)) + np.repeat(2 * np.arange(len(counts)) + 1, counts)
        padded = np.empty((len(values) + 2 * len(counts),) + values.shape[1:], values.dtype)
        padded[at], padded[starts + 2 * np.arange(len(counts))] = values, first
        padded[ends + 2 * np.arange(len(counts)) + 2] = last
        return through_points(padded, counts + 2, "knots")
    local = np.arange(len(values)) - np.repeat(offsets[:-1], counts)
    if mapping == "bezier":
        return values[local % 3 == 0]
    inner = np.flatnonzero((local > 0) & (local < np.repeat(counts, counts) - 1))
    if mapping == "inner" or not np.issubdtype(values.dtype, np.floating):
        return values[inner]
    # uniform cubic B-spline at its knots: (P[j-1] + 4 P[j] + P[j+1]) / 6
    return ((values[inner - 1] + 4 * values[inner] + values[inner + 1]) / 6).astype(values.dtype)


# ------------------------------------------------------------------ NURBS
MAX_ORDER = 16  # highest NURBS order read (degree 15; Maya, Houdini and Blender stay ≤ 11)


@dataclass(frozen=True)
class NurbsStencil:
    """NURBS curves evaluated at chosen parameters, as weights of their control vertices:
    output point ``m`` is ``Σ_j weight[m, j] · values[index[m, j]]`` for vertex values,
    and ``values[lower[m]]`` to ``values[lower[m] + 1]`` at fraction ``frac[m]`` for
    varying values (one per segment end). Made by :func:`nurbs_stencil`."""

    counts: np.ndarray  # (C,) output points per curve
    index: np.ndarray  # (M, k) int64 control vertices of each output point
    weight: np.ndarray  # (M, k) float64, rows summing to 1
    lower: np.ndarray  # (M,) int64 varying value before each output point
    frac: np.ndarray  # (M,) float64 fraction of the way to the next one
    varying_counts: np.ndarray  # (C,) segments + 1 of each curve

    def vertex(self, values: np.ndarray) -> np.ndarray:
        """Per-control-vertex ``values`` at the output points: evaluated with the curve's
        (rational) basis when floating, else the value of the vertex weighing most."""
        if np.issubdtype(values.dtype, np.floating):
            gathered = values[self.index].astype(np.float64)
            mixed = np.einsum("mk,mk...->m...", self.weight, gathered)
            return mixed.astype(values.dtype)
        heaviest = np.argmax(self.weight, axis=1)
        return values[self.index[np.arange(len(self.index)), heaviest]]

    def varying(self, values: np.ndarray) -> np.ndarray:
        """Per-segment-end ``values`` at the output points: linear in the parameter when
        floating, else the nearer segment end's."""
        if np.issubdtype(values.dtype, np.floating):
            f = self.frac.reshape((-1,) + (1,) * (values.ndim - 1))
            mixed = (1 - f) * values[self.lower] + f * values[self.lower + 1]
            return mixed.astype(values.dtype)
        return values[self.lower + (self.frac > 0.5)]


def _first_bad(bad: np.ndarray) -> int:
    return int(np.argmax(bad))


def _check_nurbs(
    counts: np.ndarray,
    orders: np.ndarray,
    knots: np.ndarray,
    weights: np.ndarray | None,
    where: str,
) -> None:
    """CurveBasisError naming ``where`` unless orders, knots and weights describe
    NURBS curves of ``counts`` control vertices that can be evaluated."""
    c = len(counts)
    if orders.shape != (c,):
        raise CurveBasisError(f"{where}: order has {orders.size} values; {c} curves need one each")
    for bad, why in (
        (orders < 2, "below 2 (a NURBS curve needs degree 1 or more)"),
        (orders > MAX_ORDER, f"above {MAX_ORDER}, the highest order read"),
        (
            counts < orders,
            "more than its control vertices; a NURBS curve needs"
            " at least as many vertices as its order",
        ),
    ):
        if np.any(bad):
            i = _first_bad(bad)
            raise CurveBasisError(
                f"{where}: curve {i} has order {int(orders[i])} and"
                f" {int(counts[i])} vertices: the order is {why}"
            )
    need = int((counts + orders).sum())
    if knots.shape != (need,):
        raise CurveBasisError(
            f"{where}: knots has {knots.size} values; curves of these vertex"
            f" counts and orders need {need} (vertices + order per curve)"
        )
    if not np.isfinite(knots).all():
        raise CurveBasisError(f"{where}: knot {_first_bad(~np.isfinite(knots))} is not finite")
    starts = np.concatenate([[0], np.cumsum(counts + orders)[:-1]])
    falls = np.diff(knots) < 0
    falls[starts[1:] - 1] = False  # where one curve's knots end and the next one's start
    if np.any(falls):
        j = _first_bad(falls)
        i = int(np.searchsorted(starts, j, side="right") - 1)
        raise CurveBasisError(
            f"{where}: the knots of curve {i} decrease ({knots[j]:g} then"
            f" {knots[j + 1]:g}); a knot vector must not decrease"
        )
    if weights is not None:
        if weights.shape != (int(counts.sum()),):
            raise CurveBasisError(
                f"{where}: pointWeights has {weights.size} values for"
                f" {int(counts.sum())} vertices; give one per vertex"
            )
        bad = ~(np.isfinite(weights) & (weights > 0))
        if np.any(bad):
            raise CurveBasisError(
                f"{where}: pointWeights[{_first_bad(bad)}] ="
                f" {weights[_first_bad(bad)]:g}; weights must be > 0"
            )


def _domains(
    counts: np.ndarray,
    orders: np.ndarray,
    knots: np.ndarray,
    starts: np.ndarray,
    ranges: np.ndarray | None,
    where: str,
) -> tuple[np.ndarray, np.ndarray]:
    """Each curve's parameter interval: its knots [order − 1] to [vertices] (where the
    basis functions sum to 1), or ``ranges`` inside it."""
    lo, hi = knots[starts + orders - 1], knots[starts + counts]
    if ranges is not None:
        if ranges.shape != (len(counts), 2):
            raise CurveBasisError(
                f"{where}: ranges has shape {ranges.shape}; give (min, max)"
                f" for each of the {len(counts)} curves"
            )
        outside = ~((ranges[:, 0] >= lo) & (ranges[:, 1] <= hi))
        if np.any(outside):
            i = _first_bad(outside)
            raise CurveBasisError(
                f"{where}: ranges of curve {i} ({ranges[i, 0]:g},"
                f" {ranges[i, 1]:g}) reach outside its knots' domain"
                f" [{lo[i]:g}, {hi[i]:g}]"
            )
        lo, hi = ranges[:, 0], ranges[:, 1]
    empty = ~(lo < hi)
    if np.any(empty):
        i = _first_bad(empty)
        raise CurveBasisError(
            f"{where}: curve {i} has an empty parameter range ({lo[i]:g} to"
            f" {hi[i]:g}); its knots must rise over the domain"
        )
    return lo, hi


def _parameters(
    counts: np.ndarray, knots: np.ndarray, starts: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(parameters, their curve) where each curve is evaluated: its distinct knots inside
    its interval and the interval's ends (so its segment joins are kept), and each span
    between them cut into ``m`` equal steps, ``m`` the fewest giving at least as many
    points as the curve has control vertices."""
    c = len(counts)
    curve_of_knot = np.repeat(np.arange(c), np.diff(np.append(starts, len(knots))))
    new = np.ones(len(knots), bool)
    new[1:] = knots[1:] != knots[:-1]
    inner = new & (knots > lo[curve_of_knot]) & (knots < hi[curve_of_knot])
    values = np.concatenate([lo, knots[inner], hi])
    curve = np.concatenate([np.arange(c), curve_of_knot[inner], np.arange(c)])
    rank = np.concatenate([np.zeros(c), np.ones(int(inner.sum())), np.full(c, 2.0)])
    order = np.lexsort((values, rank, curve))
    breaks, curve = values[order], curve[order]
    spans = np.bincount(curve, minlength=c) - 1
    steps = np.maximum(1, -(-(counts - 1) // spans))  # ceil((vertices - 1) / spans)
    last = np.cumsum(spans + 1) - 1  # each curve's final break
    span_at = np.setdiff1d(np.arange(len(breaks)), last)  # each span's first break
    span_curve = curve[span_at]
    per = steps[span_curve]
    span = np.repeat(np.arange(len(span_at)), per)
    step = np.arange(int(per.sum())) - np.repeat(np.cumsum(per) - per, per)
    a, b = breaks[span_at][span], breaks[span_at + 1][span]
    inside = a + (b - a) * (step / per[span])
    out = spans * steps + 1
    at = np.arange(len(span)) + np.repeat(np.arange(c), spans * steps)  # room for each end
    params = np.empty(int(out.sum()))
    params[at] = inside
    params[np.cumsum(out) - 1] = hi
    return params, np.repeat(np.arange(c), out)


def _spans(
    u: np.ndarray, first: np.ndarray, last: np.ndarray, hi: np.ndarray, knots: np.ndarray
) -> np.ndarray:
    """For each parameter ``u``: the largest knot index ``i`` in [first, last] with
    knots[i] ≤ u (at the top ``hi`` of the interval: knots[i] < u, the last non-empty
    span), by a bisection run on all parameters at once."""
    low, high = first.copy(), last.copy()
    top = u >= hi
    while np.any(low < high):
        mid = (low + high + 1) // 2
        ok = np.where(top, knots[mid] < u, knots[mid] <= u)
        low = np.where(ok, mid, low)
        high = np.where(ok, high, mid - 1)
    return low


def _basis(u: np.ndarray, span: np.ndarray, knots: np.ndarray, k: int) -> np.ndarray:
    """(M, k) the non-zero B-spline basis functions of order ``k`` at ``u``, those of
    control vertices span − k + 1 … span: the Cox-de Boor recurrence as Piegl & Tiller
    1997 (*The NURBS Book*) algorithm A2.2 computes it."""
    n = np.zeros((len(u), k))
    n[:, 0] = 1.0
    left = np.zeros((len(u), k))
    right = np.zeros((len(u), k))
    for j in range(1, k):
        left[:, j] = u - knots[span + 1 - j]
        right[:, j] = knots[span + j] - u
        saved = np.zeros(len(u))
        for r in range(j):
            temp = n[:, r] / (right[:, r + 1] + left[:, j - r])  # > 0: the span is not empty
            n[:, r] = saved + right[:, r + 1] * temp
            saved = left[:, j - r] * temp
        n[:, j] = saved
    return n


def nurbs_stencil(
    counts: np.ndarray,
    orders: np.ndarray,
    knots: np.ndarray,
    point_weights: np.ndarray | None = None,
    ranges: np.ndarray | None = None,
    where: str = "curves",
) -> NurbsStencil:
    """The points NURBS curves are reduced to, as a :class:`NurbsStencil`.

    Curve ``i`` has ``counts[i]`` control vertices (one after another), order
    ``orders[i]`` (degree + 1) and ``counts[i] + orders[i]`` knots (concatenated in
    ``knots``, as USD's ``UsdGeomNurbsCurves`` and Alembic batch them); ``point_weights``
    (one per vertex, > 0) make it rational, ``ranges`` (C, 2) narrow its parameter
    interval, by default knots[order − 1] to knots[count]. Each curve is evaluated at
    its distinct knots in that interval and the interval's ends, so every segment join
    is a point, with each span cut into equal parameter steps, as few as give at least
    as many points as the curve has vertices: a Bézier-like single span of n vertices
    gives n points, evenly spaced in its parameter. CurveBasisError naming ``where``
    for what cannot be evaluated (an order below 2, above MAX_ORDER or above the vertex
    count, a knot vector of the wrong length or decreasing, weights ≤ 0, ranges outside
    the knots)."""
    counts = np.asarray(counts, dtype=np.int64)
    orders = np.asarray(orders, dtype=np.int64).reshape(-1)
    knots = np.asarray(knots, dtype=np.float64).reshape(-1)
    weights = None if point_weights is None else np.asarray(point_weights, np.float64)
    _check_nurbs(counts, orders, knots, weights, where)
    starts = np.concatenate([[0], np.cumsum(counts + orders)[:-1]]).astype(np.int64)
    lo, hi = _domains(counts, orders, knots, starts, ranges, where)
    u, curve = _parameters(counts, knots, starts, lo, hi)
    span = _spans(u, (starts + orders - 1)[curve], (starts + counts - 1)[curve], hi[curve], knots)
    local = span - starts[curve]  # index of the span's knot within its curve
    vertex_start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    k_max = int(orders.max(initial=2))
    index = np.empty((len(u), k_max), np.int64)
    weight = np.zeros((len(u), k_max))
    for k in np.unique(orders):
        rows = np.flatnonzero(orders[curve] == k)
        first = vertex_start[curve[rows]] + local[rows] - k + 1
        index[rows] = first[:, None] + np.minimum(np.arange(k_max), k - 1)
        weight[rows, :k] = _basis(u[rows], span[rows], knots, int(k))
    if weights is not None:  # rational: R_j = N_j w_j / Σ N_l w_l
        weight *= weights[index]
        weight /= weight.sum(axis=1, keepdims=True)
    varying_counts = counts - orders + 2
    varying_start = np.concatenate([[0], np.cumsum(varying_counts)[:-1]])
    lower = varying_start[curve] + local - (orders[curve] - 1)
    frac = (u - knots[span]) / (knots[span + 1] - knots[span])
    return NurbsStencil(
        np.bincount(curve, minlength=len(counts)), index, weight, lower, frac, varying_counts
    )


def nurbs_points(
    points: np.ndarray,
    counts: np.ndarray,
    orders: np.ndarray,
    knots: np.ndarray,
    point_weights: np.ndarray | None = None,
    ranges: np.ndarray | None = None,
    where: str = "curves",
) -> tuple[np.ndarray, np.ndarray]:
    """(points on the curves, points per curve) of NURBS curves with control vertices
    ``points``; see :func:`nurbs_stencil` for the arguments and the points chosen."""
    stencil = nurbs_stencil(counts, orders, knots, point_weights, ranges, where)
    return stencil.vertex(np.asarray(points)), stencil.counts
