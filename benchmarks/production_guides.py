"""Guides shaped like the ones production tools write, for the dynamics tests and benchmark.

Built-in grooms are kind: every strand has one vertex count and equal segments. Guides
exported from a DCC or a game asset are not (issue: production dynamics): their vertex
counts differ strand to strand, segment lengths vary ×0.1–10 along a strand, about 1 %
of segments have zero length (coincident vertices: a tool's duplicated point, a welded
tip), and short stubble sits beside long hair. :func:`production_guides` makes such guides
on the built-in head from the built-in long groom's roots and shapes: each strand keeps
the built-in shape up to its new length (and carries on along its last direction past
it), lengths log-uniform from 2 mm to 60 cm (both ends included), vertex counts 4–48,
segment lengths ×0.1–10 (log-uniform), 1 % of segments of zero length (a vertex put
on its predecessor). ``vertices`` gives every strand that many instead, as TressFX files
have them.
"""

from __future__ import annotations

import numpy as np

import follicle
from follicle import HairCurves

SHORTEST, LONGEST = 0.002, 0.6  # strand lengths, m
FEWEST, MOST = 4, 48  # vertices per strand
SPREAD = 10.0  # segment lengths within a strand vary ×1/SPREAD … ×SPREAD
COINCIDENT = 0.01  # share of segments of zero length


def _along(points: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Points of the polyline ``points`` (n, 3) at arc lengths ``at`` (m); past its end
    along its last segment's direction."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    out = np.stack([np.interp(at, s, points[:, a]) for a in range(3)], axis=1)
    last = (points[-1] - points[-2]) / seg[-1]
    beyond = at > s[-1]
    out[beyond] = points[-1] + (at[beyond] - s[-1])[:, None] * last
    return out


def production_guides(
    seed: int = 0, mesh: object = None, vertices: int | None = None
) -> HairCurves:
    """The built-in long groom's 300 roots with production-shaped strands (see the
    module) grown on ``mesh`` (default: the built-in head)."""
    rng = np.random.default_rng(seed)
    mesh = mesh if mesh is not None else follicle.load_mesh("builtin:head")
    base = follicle.load_guides("builtin:long", mesh).curves
    count = base.curve_count
    lengths = np.exp(rng.uniform(np.log(SHORTEST), np.log(LONGEST), count))
    lengths[:2] = SHORTEST, LONGEST
    strands = []
    for c in range(count):
        shape = base.points[base.offsets[c] : base.offsets[c + 1]].astype(np.float64)
        n = vertices or int(rng.integers(FEWEST, MOST + 1))
        steps = np.exp(rng.uniform(-np.log(SPREAD), np.log(SPREAD), n - 1))
        at = np.concatenate([[0.0], np.cumsum(steps)]) * lengths[c] / steps.sum()
        points = _along(shape, at)
        for i in np.flatnonzero(rng.random(n - 1) < COINCIDENT) + 1:
            points[i] = points[i - 1]
        strands.append(points)
    return HairCurves.from_polylines(strands)
