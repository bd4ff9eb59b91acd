"""Strands rasterized per tile. A piece between two steps thinner than a pixel is walked
along its major axis one pixel column (or row) at a time, and the pixels across it get
the share of their area the hair covers — the overlap of the pixel with the hair's
cross-section (its width over the cosine of its slope), so a hair a tenth of a pixel
wide adds a tenth of its opacity along its length (analytic coverage, no
multisampling). A piece a pixel wide or more is a flat-ended ribbon: each pixel of its
box whose centre lies beside it gets the overlap, across the piece, of its width with
the ribbon's. Ends are half open, so consecutive pieces share no pixel.

What a fragment does depends on the pass (:data:`PASSES`): weighted blended
order-independent transparency (McGuire & Bavoil 2013) or "over" blending for the
colour, and the deep opacity maps' two passes (Yuksel & Keyser 2008) — the nearest
hair depth, then opacity added to the layer its depth falls in — from the light. Each
tile is one thread's and its segments come in order, so the bytes do not depend on
the thread count.
"""

from __future__ import annotations

import math

import numpy as np

from ...kernels import kernel, prange
from .bins import dealt_tiles, tile_bounds

__all__ = ["PASSES", "segment_boxes", "draw_strands"]

PASSES = {"oit": 0, "over": 1, "nearest": 2, "layers": 3}
# fast maths without the no-NaN and no-inf promises: NaN depths mark what is not drawn
FAST = {"contract", "arcp", "afn", "reassoc"}


@kernel(parallel=True)
def segment_boxes(steps, step_start):
    """Pixel box (x0, x1, y0, y1) of each segment's steps, grown by their half widths
    across a diagonal and a pixel; NaN when no step of it is drawable."""
    m = len(step_start) - 1
    boxes = np.empty((m, 4), np.float32)
    for s in prange(m):
        x0 = y0 = np.inf
        x1 = y1 = -np.inf
        for k in range(step_start[s], step_start[s + 1]):
            if math.isnan(steps[k, 2]):
                continue
            pad = 2.0 * steps[k, 3] + 1.0
            x0 = min(x0, steps[k, 0] - pad)
            x1 = max(x1, steps[k, 0] + pad)
            y0 = min(y0, steps[k, 1] - pad)
            y1 = max(y1, steps[k, 1] + pad)
        if x0 > x1:
            x0 = x1 = y0 = y1 = np.nan
        boxes[s, 0] = x0
        boxes[s, 1] = x1
        boxes[s, 2] = y0
        boxes[s, 3] = y1
    return boxes


@kernel
def _oit_weight(depth, consts):
    """Weighted blended OIT's weight exp(−k·Δdepth/depth): nearer hair outweighs farther."""
    oit_depth, sharpness = consts[0], consts[1]
    return max(math.exp(-sharpness * max(depth - oit_depth, 0.0) / oit_depth), 1e-20)


@kernel(fastmath=FAST, inline="always")
def _fragment(mode, buf, first, ref, row, col, u, cover, a, b, wa, wb, consts):
    """A fragment at (row, col), ``u`` along the piece a → b, covering ``cover`` of the
    pixel: depth-tested against each of the pixel's samples of the opaque layer ``ref``
    (H, W, samples) and weighed by the share it is in front of (as a GPU's MSAA: where
    hair passes behind the skin's silhouette it shows only beside the skin, not over
    the edge pixel); then, by pass, into the OIT sums (Σcαw, Σαw, Π(1 − α)), "over",
    the nearest depth, or its deep-opacity layer."""
    depth = a[2] + (b[2] - a[2]) * u
    samples = ref.shape[2]
    front = 0
    for s in range(samples):
        if depth < ref[row, col, s]:
            front += 1
    if front == 0:  # behind the skin
        return
    alpha = min((a[4] + (b[4] - a[4]) * u) * cover, 1.0) * front / samples
    if mode == 0:
        aw = alpha * (wa + (wb - wa) * u)
        buf[row, col, 0] += (a[5] + (b[5] - a[5]) * u) * aw
        buf[row, col, 1] += (a[6] + (b[6] - a[6]) * u) * aw
        buf[row, col, 2] += (a[7] + (b[7] - a[7]) * u) * aw
        buf[row, col, 3] += aw
        buf[row, col, 4] *= 1.0 - alpha
    elif mode == 1:
        for ch in range(3):
            v = a[5 + ch] + (b[5 + ch] - a[5 + ch]) * u
            buf[row, col, ch] += (v - buf[row, col, ch]) * alpha
    elif mode == 2:
        buf[row, col, 0] = min(buf[row, col, 0], depth)
    else:
        k = int(math.floor((depth - first[row, col]) / consts[2]))
        buf[row, col, min(max(k, 0), 3)] += alpha


@kernel(fastmath=FAST, inline="always")
def _thin_piece(mode, buf, first, ref, a, b, x_lo, x_hi, y_lo, y_hi, wa, wb, consts):
    """A piece under a pixel wide: a pixel column (row) at a time along its major axis,
    the pixels across it covered by the hair's cross-section (width / cos of the slope)."""
    ax, ay, bx, by = a[0], a[1], b[0], b[1]
    dx, dy = bx - ax, by - ay
    major_x = abs(dx) >= abs(dy)
    if major_x:
        a0, b0, a1, d0, d1, lo0, hi0, lo1, hi1 = ax, bx, ay, dx, dy, x_lo, x_hi, y_lo, y_hi
    else:
        a0, b0, a1, d0, d1, lo0, hi0, lo1, hi1 = ay, by, ax, dy, dx, y_lo, y_hi, x_lo, x_hi
    if d0 == 0.0:
        return
    # pixel centres c + 0.5 with u = (c + 0.5 - a0) / d0 in [0, 1)
    if d0 > 0.0:
        c0 = int(math.ceil(a0 - 0.5))
        c1 = int(math.ceil(b0 - 0.5)) - 1
    else:
        c0 = int(math.floor(b0 - 0.5)) + 1
        c1 = int(math.floor(a0 - 0.5))
    c0 = max(c0, lo0)
    c1 = min(c1, hi0 - 1)
    if c0 > c1:
        return
    slope = d1 / d0
    sec = math.sqrt(1.0 + slope * slope)
    inv = 1.0 / d0
    for c in range(c0, c1 + 1):
        u = (c + 0.5 - a0) * inv
        centre = a1 + u * d1
        half = (a[3] + (b[3] - a[3]) * u) * sec
        lo = centre - half
        hi = centre + half
        r0 = max(int(math.floor(lo)), lo1)
        r1 = min(int(math.floor(hi)), hi1 - 1)
        for q in range(r0, r1 + 1):
            cover = min(hi, q + 1.0) - max(lo, float(q))
            if cover <= 0.0:
                continue
            if major_x:
                _fragment(mode, buf, first, ref, q, c, u, cover, a, b, wa, wb, consts)
            else:
                _fragment(mode, buf, first, ref, c, q, u, cover, a, b, wa, wb, consts)


@kernel(inline="always")
def _joint(step, dx, dy):
    """The unit screen tangent at ``step`` (its joint with the next piece lies across
    it), pointing along the piece (dx, dy); the piece's own direction where the step
    has none."""
    tx, ty = step[8], step[9]
    if tx == 0.0 and ty == 0.0:
        tx, ty = dx, dy
    return (tx, ty) if tx * dx + ty * dy >= 0.0 else (-tx, -ty)


@kernel(fastmath=FAST, inline="always")
def _wide_piece(mode, buf, first, ref, a, b, x_lo, x_hi, y_lo, y_hi, wa, wb, consts):
    """A piece a pixel wide or more: a ribbon. A pixel of its box is its when its centre
    lies past the line across the hair at a and before the one at b (each across the
    screen tangent there, so consecutive pieces tile a bending ribbon without gaps or
    overlaps, as the OpenGL engine's strips do), covered by the overlap of the pixel's
    width across the piece with the ribbon's."""
    ax, ay = a[0], a[1]
    dx, dy = b[0] - ax, b[1] - ay
    length2 = dx * dx + dy * dy
    if length2 == 0.0:
        return
    inv_len = 1.0 / math.sqrt(length2)
    nx, ny = -dy * inv_len, dx * inv_len  # unit, across the piece
    tax, tay = _joint(a, dx, dy)
    tbx, tby = _joint(b, dx, dy)
    pad = 2.0 * max(a[3], b[3]) + 1.0
    j0 = max(int(math.floor(min(ax, b[0]) - pad)), x_lo)
    j1 = min(int(math.ceil(max(ax, b[0]) + pad)), x_hi - 1)
    i0 = max(int(math.floor(min(ay, b[1]) - pad)), y_lo)
    i1 = min(int(math.ceil(max(ay, b[1]) + pad)), y_hi - 1)
    for i in range(i0, i1 + 1):
        py = i + 0.5 - ay
        for j in range(j0, j1 + 1):
            px = j + 0.5 - ax
            if px * tax + py * tay < 0.0:  # before the joint at a
                continue
            if (px - dx) * tbx + (py - dy) * tby >= 0.0:  # at or past the joint at b
                continue
            d = px * nx + py * ny
            u = min(max((px * dx + py * dy) / length2, 0.0), 1.0)
            half = a[3] + (b[3] - a[3]) * u
            cover = min(d + 0.5, half) - max(d - 0.5, -half)
            if cover > 0.0:
                _fragment(mode, buf, first, ref, i, j, u, cover, a, b, wa, wb, consts)


@kernel(fastmath=FAST, inline="always")
def _piece(mode, buf, first, ref, a, b, x_lo, x_hi, y_lo, y_hi, consts):
    """Rasterize the piece from step a to step b (rows of STEP_FIELDS) inside the tile
    [x_lo, x_hi) × [y_lo, y_hi): thin along its major axis, wide as a ribbon."""
    # the OIT weight changes little along a piece: linear between its ends
    wa = _oit_weight(a[2], consts) if mode == 0 else 0.0
    wb = _oit_weight(b[2], consts) if mode == 0 else 0.0
    if max(a[3], b[3]) >= 0.5:
        _wide_piece(mode, buf, first, ref, a, b, x_lo, x_hi, y_lo, y_hi, wa, wb, consts)
    else:
        _thin_piece(mode, buf, first, ref, a, b, x_lo, x_hi, y_lo, y_hi, wa, wb, consts)


@kernel(parallel=True)
def draw_strands(
    mode, steps, step_start, tile_start, items, tile, nx, buf, first, ref, consts, threads
):
    """Draw every tile's segments into ``buf`` (H, W, channels of the pass).

    ``ref`` (H, W, samples): depth of the opaque layer (skin) the hair is tested against
    at each of a pixel's samples;
    ``first`` (H, W): the nearest hair depths (the layers pass); ``consts``: OIT depth,
    OIT sharpness, layer thickness; ``threads``: numba's thread count."""
    h, w = ref.shape[:2]
    order = dealt_tiles(tile_start)
    for t in prange(threads):
        for k in order[t::threads]:
            x_lo, x_hi, y_lo, y_hi = tile_bounds(k, nx, tile, w, h)
            for e in range(tile_start[k], tile_start[k + 1]):
                s = items[e]
                for j in range(step_start[s], step_start[s + 1] - 1):
                    a = steps[j]
                    b = steps[j + 1]
                    if math.isnan(a[2]) or math.isnan(b[2]):
                        continue
                    if (
                        max(a[0], b[0]) + 2.0 * max(a[3], b[3]) + 1.0 < x_lo
                        or min(a[0], b[0]) - 2.0 * max(a[3], b[3]) - 1.0 > x_hi
                        or max(a[1], b[1]) + 2.0 * max(a[3], b[3]) + 1.0 < y_lo
                        or min(a[1], b[1]) - 2.0 * max(a[3], b[3]) - 1.0 > y_hi
                    ):
                        continue
                    _piece(mode, buf, first, ref, a, b, x_lo, x_hi, y_lo, y_hi, consts)
