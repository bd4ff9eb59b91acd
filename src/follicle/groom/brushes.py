"""Grooming brushes: what one dab of a brush does to guide vertices (Šik 2012 §2.2.1: the
artist "directly models" the guides with "a tool for brushing or a tool for hair
cutting"). :class:`follicle.GuideEditor` moves a brush along a stroke and calls these.

Every brush works on the guides' world positions at rest, (S, V, 3) float64 with the
roots at index 0, and a per-vertex weight in [0, 1] (the brush's falloff times its
strength). The roots never move. Brushes that keep segment lengths rebuild each guide
from its root by follow-the-leader (Müller et al. 2012, as the dynamics' DFTL does):
every vertex is put back at its segment's length from the one before, along the
direction the brush gave it, and out of the skin — pushed along the skin SDF's
normal, then put back at the segment's length, so lengths stay exact and no vertex
ends inside.
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import kernel
from ..mesh.sdf import SDF, sdf_sample

__all__ = [
    "BRUSHES",
    "MIN_LENGTH",
    "dab",
    "follow",
    "segment_lengths",
    "comb",
    "smooth",
    "puff",
    "resized",
    "cut_lengths",
    "uv_points",
    "line_side",
]

BRUSHES = ("comb", "cut", "length", "puff", "smooth", "add", "delete", "part")
MIN_LENGTH = 1e-4  # metres: no brush shortens a guide below this
_PUSH_TRIES = 4  # push-outs of a vertex found inside the skin before giving up


@kernel
def dab(points, vp, width, height, cx, cy, radius, seen, reach, depth):
    """One dab of a brush centred on pixel (cx, cy), into ``reach`` (S, V): each
    vertex's falloff (1 − (d/r)²)² within the radius r — 1 at the centre, 0 with no
    slope at the rim, so a stroke leaves no edge — at the distance d of its projection
    through ``vp`` (world → clip, the camera's) in a width × height picture; 0 where
    not ``seen`` or behind the eye. The view depth into ``depth``. Returns, per guide,
    whether any vertex but its root is reached."""
    s_count, v_count = points.shape[:2]
    hit = np.zeros(s_count, np.bool_)
    inv = 1.0 / (radius * radius)
    for s in range(s_count):
        for i in range(v_count):
            x, y, z = points[s, i, 0], points[s, i, 1], points[s, i, 2]
            cw = vp[3, 0] * x + vp[3, 1] * y + vp[3, 2] * z + vp[3, 3]
            depth[s, i] = cw
            reach[s, i] = 0.0
            if not (cw > 0.0 and seen[s, i]):
                continue
            px = ((vp[0, 0] * x + vp[0, 1] * y + vp[0, 2] * z + vp[0, 3]) / cw + 1.0) * 0.5
            py = (1.0 - (vp[1, 0] * x + vp[1, 1] * y + vp[1, 2] * z + vp[1, 3]) / cw) * 0.5
            dx = px * width - cx
            dy = py * height - cy
            f = 1.0 - (dx * dx + dy * dy) * inv
            if f > 0.0:
                reach[s, i] = f * f
                hit[s] |= i > 0
    return hit


def segment_lengths(points: np.ndarray) -> np.ndarray:
    """Per guide, its segments' lengths (S, V − 1)."""
    return np.linalg.norm(np.diff(points, axis=1), axis=2)


@kernel
def _follow(
    points, lengths, which, use_skin, values, origin, inv_voxel, local_from_world, margin, tries
):
    for g in range(len(which)):  # serial: a parallel launch costs more than 1,000 guides
        s = which[g]
        for i in range(1, points.shape[1]):
            px, py, pz = points[s, i - 1, 0], points[s, i - 1, 1], points[s, i - 1, 2]
            dx = points[s, i, 0] - px
            dy = points[s, i, 1] - py
            dz = points[s, i, 2] - pz
            for _ in range(tries + 1):
                norm = math.sqrt(dx * dx + dy * dy + dz * dz)
                if norm == 0.0:  # no direction left: along the previous segment
                    if i >= 2:
                        dx = px - points[s, i - 2, 0]
                        dy = py - points[s, i - 2, 1]
                        dz = pz - points[s, i - 2, 2]
                        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
                    if norm == 0.0:
                        dx, dy, dz, norm = 0.0, 0.0, 1.0, 1.0
                k = lengths[s, i - 1] / norm
                qx, qy, qz = px + dx * k, py + dy * k, pz + dz * k
                if not use_skin:
                    break
                d, nx, ny, nz = sdf_sample(values, origin, inv_voxel, local_from_world, qx, qy, qz)
                if d >= margin:
                    break
                push = margin - d
                dx = qx + nx * push - px
                dy = qy + ny * push - py
                dz = qz + nz * push - pz
            points[s, i, 0], points[s, i, 1], points[s, i, 2] = qx, qy, qz


def follow(
    points: np.ndarray,
    lengths: np.ndarray,
    skin: SDF | None,
    margin: float,
    which: np.ndarray | None = None,
    tries: int = _PUSH_TRIES,
) -> None:
    """Rebuild the guides ``which`` (indices; None: all) in place from their roots: each
    vertex at its segment's length (``lengths``, (S, V − 1)) from the one before, along
    the direction it has now, and at least ``margin`` outside ``skin`` (None: none), as
    far as ``tries`` push-outs of a vertex get it."""
    if skin is None:
        grid = (np.ones((2, 2, 2), np.float32), np.zeros(3), 1.0, np.eye(4))
    else:
        grid = skin.sample_args
    lengths = np.ascontiguousarray(lengths, np.float64)
    which = np.arange(len(points)) if which is None else np.asarray(which, np.int64)
    _follow(points, lengths, which, skin is not None, *grid, float(margin), int(tries))


@kernel
def comb(points, weight, depth, step, which):
    """Drag the vertices of the guides ``which`` by their weight times ``step`` (3,:
    the stroke's step in world units per metre of view depth) times their ``depth``,
    in place; the caller then restores the lengths. A vertex takes its own move where
    the brush holds it fully and its predecessor's where the brush does not reach it
    (blended by its weight), so the part of a guide past the brush is carried along
    as a comb carries the lengths behind it — moving only the vertices under the brush
    would fold a guide where the brush lets go."""
    for g in range(len(which)):
        s = which[g]
        cx, cy, cz = 0.0, 0.0, 0.0  # the move of the vertex before
        for i in range(1, points.shape[1]):
            w = min(weight[s, i], 1.0)
            k = w * max(depth[s, i], 0.0)
            cx = k * step[0] + (1.0 - w) * cx
            cy = k * step[1] + (1.0 - w) * cy
            cz = k * step[2] + (1.0 - w) * cz
            points[s, i, 0] += cx
            points[s, i, 1] += cy
            points[s, i, 2] += cz


@kernel
def _unit(points, s, i):
    """Segment i of guide s: its unit direction and length."""
    dx = points[s, i + 1, 0] - points[s, i, 0]
    dy = points[s, i + 1, 1] - points[s, i, 1]
    dz = points[s, i + 1, 2] - points[s, i, 2]
    n = math.sqrt(dx * dx + dy * dy + dz * dz)
    k = 1.0 / n if n > 0.0 else 0.0
    return dx * k, dy * k, dz * k, n


@kernel
def _turned(points, weight, which, normals, puffing):
    """Each guide of ``which`` rebuilt from its root with its segments' lengths, each
    segment's direction moved by its far vertex's weight (× 1 − its place, puffing)
    towards the root's ``normals`` (puffing) or the mean of the neighbouring segments'
    directions (smoothing)."""
    v = points.shape[1]
    unit = np.empty((v - 1, 3))
    length = np.empty(v - 1)
    for g in range(len(which)):
        s = which[g]
        for i in range(v - 1):
            unit[i, 0], unit[i, 1], unit[i, 2], length[i] = _unit(points, s, i)
        for i in range(v - 1):
            if puffing:
                w = weight[s, i + 1] * (1.0 - i / (v - 1))
                tx, ty, tz = normals[s, 0], normals[s, 1], normals[s, 2]
            else:
                w = weight[s, i + 1]
                if i == 0 or v < 3:  # the root's direction is the skin's (puff's) business
                    w = 0.0
                a = i - 1
                b = i + 1 if i + 1 < v - 1 else i - 1  # the tip's: the one before
                tx = 0.5 * (unit[a, 0] + unit[b, 0])
                ty = 0.5 * (unit[a, 1] + unit[b, 1])
                tz = 0.5 * (unit[a, 2] + unit[b, 2])
            dx = unit[i, 0] + w * (tx - unit[i, 0])
            dy = unit[i, 1] + w * (ty - unit[i, 1])
            dz = unit[i, 2] + w * (tz - unit[i, 2])
            n = math.sqrt(dx * dx + dy * dy + dz * dz)
            if n == 0.0:
                dx, dy, dz, n = unit[i, 0], unit[i, 1], unit[i, 2], 1.0
            k = length[i] / n
            for c, d in ((0, dx), (1, dy), (2, dz)):
                points[s, i + 1, c] = points[s, i, c] + d * k


def smooth(points: np.ndarray, weight: np.ndarray, which: np.ndarray) -> None:
    """Relax the curvature of the guides ``which`` in place: each segment's direction
    turned towards the mean of its neighbours' by its far vertex's weight, the guide
    rebuilt from the root at its segments' lengths (the root segment and lengths kept).
    Directions, not positions, are averaged: averaging the positions of a curl shrinks
    its radius, and with the lengths kept it then curls more."""
    _turned(points, weight, which, np.zeros((1, 3)), False)


def puff(points: np.ndarray, weight: np.ndarray, normals: np.ndarray, which: np.ndarray) -> None:
    """Lift the guides ``which`` towards their roots' skin normals, most at the root and
    not at all at the tip: each segment's direction turned towards the normal by its
    weight × (1 − its place along the guide), the guide rebuilt at its lengths (the
    caller's follow-the-leader then keeps it off the skin)."""
    _turned(points, weight, which, normals, True)


@kernel
def _resized(points, lengths, out, row, share):
    s, v = points.shape[:2]
    arc = np.empty(v)
    for g in range(s):
        arc[0] = 0.0
        for i in range(v - 1):
            arc[i + 1] = arc[i] + _unit(points, g, i)[3]
        want = max(lengths[g], MIN_LENGTH)
        tx, ty, tz, _ = _unit(points, g, v - 2)
        j = 0
        for k in range(v):
            at = want * k / (v - 1)
            if at >= arc[v - 1]:  # past the tip: along the tip's direction
                extra = at - arc[v - 1]
                out[g, k, 0] = points[g, v - 1, 0] + extra * tx
                out[g, k, 1] = points[g, v - 1, 1] + extra * ty
                out[g, k, 2] = points[g, v - 1, 2] + extra * tz
                row[g, k], share[g, k] = v - 2, 1.0  # the tip's own
                continue
            while j + 1 < v - 1 and arc[j + 1] <= at:
                j += 1
            span = arc[j + 1] - arc[j]
            f = (at - arc[j]) / span if span > 0.0 else 0.0
            row[g, k], share[g, k] = j, f
            for c in range(3):
                out[g, k, c] = points[g, j, c] + f * (points[g, j + 1, c] - points[g, j, c])


def resized(points: np.ndarray, lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each guide (V vertices) cut or extended to ``lengths`` (S,) metres (at least
    :data:`MIN_LENGTH`) and resampled to V vertices evenly spaced by arc length: cut
    where its arc length reaches the new length, extended along its tip direction.
    Returns the points and where each new vertex lies on the old guide: between
    vertices ``row`` and ``row + 1`` (S, V) at ``share`` (0..1) of the way, the tip
    for a vertex past it — what carries the guide's point attributes along."""
    out = np.empty_like(points)
    row = np.empty(points.shape[:2], np.int64)
    share = np.empty(points.shape[:2], np.float64)
    _resized(np.ascontiguousarray(points), np.asarray(lengths, np.float64), out, row, share)
    return out, row, share


def _crossing(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Where segments a→b (n, 2) first meet c→d (2,): the parameter along a→b in
    [0, 1], NaN where they do not cross."""
    r = b - a
    q = d - c
    den = r[:, 0] * q[1] - r[:, 1] * q[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        w = c - a
        t = (w[:, 0] * q[1] - w[:, 1] * q[0]) / den
        u = (w[:, 0] * r[:, 1] - w[:, 1] * r[:, 0]) / den
    hit = (den != 0.0) & (t >= 0.0) & (t <= 1.0) & (u >= 0.0) & (u <= 1.0)
    return np.where(hit, t, np.nan)


def cut_lengths(
    points: np.ndarray,
    screen: np.ndarray,
    depth: np.ndarray,
    path: np.ndarray,
    active: np.ndarray,
) -> np.ndarray:
    """Per guide, the arc length from the root to where its projection (``screen``,
    (S, V, 2) pixels; ``depth`` (S, V) the view depths) first crosses the stroke
    ``path`` (K, 2) on one of its ``active`` segments (S, V − 1); NaN for the guides it
    does not cross there. The crossing's place on screen is taken back to the segment
    in space perspective-correctly (a point a share t along the picture of a segment
    is t/d₁ / ((1 − t)/d₀ + t/d₁) along it)."""
    s, v = points.shape[:2]
    seg = np.linalg.norm(np.diff(points, axis=1), axis=2)
    arc = np.concatenate([np.zeros((s, 1)), np.cumsum(seg, axis=1)], axis=1)
    a = screen[:, :-1].reshape(-1, 2)
    b = screen[:, 1:].reshape(-1, 2)
    first = np.full(s * (v - 1), np.inf)
    for k in range(len(path) - 1):
        t = _crossing(a, b, path[k], path[k + 1])
        first = np.fmin(first, t)
    first = np.where(active, first.reshape(s, v - 1), np.inf)
    out = np.full(s, np.nan)
    for g in np.flatnonzero(np.isfinite(first).any(axis=1)):
        i = int(np.flatnonzero(np.isfinite(first[g]))[0])
        t = first[g, i]
        along = (t / depth[g, i + 1]) / ((1.0 - t) / depth[g, i] + t / depth[g, i + 1])
        out[g] = arc[g, i] + along * seg[g, i]
    return out


@kernel
def uv_points(uvs, faces, vertices, width, height):
    """The surface point under each texel centre of a width × height texture over the
    mesh's UV square (rows from the top, as interpolation groups read it), (H, W, 3),
    and whether a triangle covers that texel (H, W): the mesh rasterized in UV space."""
    pos = np.zeros((height, width, 3))
    covered = np.zeros((height, width), np.bool_)
    for f in range(faces.shape[0]):
        a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
        ax, ay = uvs[a, 0] * width, (1.0 - uvs[a, 1]) * height
        bx, by = uvs[b, 0] * width, (1.0 - uvs[b, 1]) * height
        cx, cy = uvs[c, 0] * width, (1.0 - uvs[c, 1]) * height
        den = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy)
        if den == 0.0:
            continue
        c0 = max(int(math.floor(min(ax, bx, cx))), 0)
        c1 = min(int(math.ceil(max(ax, bx, cx))), width - 1)
        r0 = max(int(math.floor(min(ay, by, cy))), 0)
        r1 = min(int(math.ceil(max(ay, by, cy))), height - 1)
        for row in range(r0, r1 + 1):
            py = row + 0.5
            for col in range(c0, c1 + 1):
                px = col + 0.5
                wa = ((by - cy) * (px - cx) + (cx - bx) * (py - cy)) / den
                wb = ((cy - ay) * (px - cx) + (ax - cx) * (py - cy)) / den
                wc = 1.0 - wa - wb
                if wa < -1e-9 or wb < -1e-9 or wc < -1e-9:
                    continue
                for k in range(3):
                    pos[row, col, k] = (
                        wa * vertices[a, k] + wb * vertices[b, k] + wc * vertices[c, k]
                    )
                covered[row, col] = True
    return pos, covered


def line_side(points: np.ndarray, line: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For screen points (N, 2) and a polyline (K ≥ 2, 2): the distance to the nearest
    point of the line, the side of the line the point lies on (+1 left, −1 right, seen
    along the line on screen, y down) and the unit screen direction away from the line
    at the nearest segment, on that side (N, 2; zero at a segment of no length)."""
    best = np.full(len(points), np.inf)
    side = np.ones(len(points))
    away = np.zeros((len(points), 2))
    for k in range(len(line) - 1):
        a, b = line[k], line[k + 1]
        d = b - a
        length2 = float(d @ d)
        t = np.clip((points - a) @ d / length2, 0.0, 1.0) if length2 > 0.0 else 0.0
        rel = points - (a + np.multiply.outer(t, d))
        dist = np.linalg.norm(rel, axis=1)
        closer = dist < best
        # left of the line (y down); a segment of no length has no sides
        normal = np.array([d[1], -d[0]]) / math.sqrt(length2) if length2 > 0.0 else d
        sign = np.where(rel @ normal >= 0.0, 1.0, -1.0)
        best = np.where(closer, dist, best)
        side = np.where(closer, sign, side)
        away = np.where(closer[:, None], sign[:, None] * normal[None], away)
    return best, side, away
