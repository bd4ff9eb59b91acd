"""From control points to screen: each hair segment smoothed by a uniform Catmull-Rom
spline (Le Muzic 2012 §5.2.1, the geometry shader's power form), cut into as many steps
as its on-screen length and bend need, each step projected and — seen from the camera —
shaded, as ``hair_gs.glsl`` and ``hair_step.glsl`` do on the GPU.

Two passes over the curves in parallel, taken in the space order of their roots
(:func:`space_order`): count the steps of every segment, then fill them at their
prefix-summed places, so the output is the same for any thread count. A
step is one row of :data:`STEP_FIELDS`; a step outside the clip volume has a NaN depth
and the pieces touching it are not drawn.
"""

from __future__ import annotations

import math

import numpy as np

from ...kernels import kernel, prange
from .shading import added, cross, dot, hair_radiance, scaled, unit

__all__ = ["STEP_FIELDS", "MAX_SUBDIVISIONS", "space_order", "segment_steps", "fill_steps"]

# x, y: pixels (camera: y down from the top; light: texel rows upwards); depth: view
# depth, metres (camera) or light depth 0..1; half: half the width in pixels; then the
# opacity, the shaded linear RGB, and the unit tangent on screen (where wide pieces
# meet; 0, 0 on a step under a pixel wide, or where it has no direction)
STEP_FIELDS = ("x", "y", "depth", "half", "opacity", "r", "g", "b", "tx", "ty")
MAX_SUBDIVISIONS = 16
CHORD_TOLERANCE_PX = 0.25  # largest gap between spline and steps, pixels


@kernel
def _power_form(p0, p1, p2, p3):
    """Uniform Catmull-Rom in power form: P(u) = p1 + (a u³ + b u² + c u) / 2."""
    a = (
        -p0[0] + 3.0 * p1[0] - 3.0 * p2[0] + p3[0],
        -p0[1] + 3.0 * p1[1] - 3.0 * p2[1] + p3[1],
        -p0[2] + 3.0 * p1[2] - 3.0 * p2[2] + p3[2],
    )
    b = (
        2.0 * p0[0] - 5.0 * p1[0] + 4.0 * p2[0] - p3[0],
        2.0 * p0[1] - 5.0 * p1[1] + 4.0 * p2[1] - p3[1],
        2.0 * p0[2] - 5.0 * p1[2] + 4.0 * p2[2] - p3[2],
    )
    c = (p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2])
    return a, b, c


@kernel
def _point(points, i):
    return (float(points[i, 0]), float(points[i, 1]), float(points[i, 2]))


@kernel
def _neighbours(points, first, last, i):
    """Control points P_{i-1} .. P_{i+2} of segment i, clamped to the curve."""
    return (
        _point(points, max(i - 1, first)),
        _point(points, i),
        _point(points, i + 1),
        _point(points, min(i + 2, last)),
    )


@kernel(inline="always")
def _pixel_size(p, view):
    """World size of a pixel at p: per metre of depth (perspective) or flat."""
    if view[3] > 0.5:
        d = (p[0] - view[0]) * view[4] + (p[1] - view[1]) * view[5] + (p[2] - view[2]) * view[6]
        return view[10] * max(d, 1e-9)
    return view[10]


@kernel
def _step_count(p0, p1, p2, p3, view, most):
    """hair_gs.glsl: the chord error of n steps falls as 1/n² from its value at n = 1;
    and no step is longer than ``view[11]`` pixels."""
    a, b, c = _power_form(p0, p1, p2, p3)
    mid = added(
        p1,
        scaled(
            (
                (a[0] * 0.5 + b[0]) * 0.5 + c[0],
                (a[1] * 0.5 + b[1]) * 0.5 + c[1],
                (a[2] * 0.5 + b[2]) * 0.5 + c[2],
            ),
            0.25,
        ),
    )
    px = _pixel_size(mid, view)
    dx = mid[0] - 0.5 * (p1[0] + p2[0])
    dy = mid[1] - 0.5 * (p1[1] + p2[1])
    dz = mid[2] - 0.5 * (p1[2] + p2[2])
    bend = math.sqrt(dx * dx + dy * dy + dz * dz) / px
    chord = math.sqrt((p2[0] - p1[0]) ** 2 + (p2[1] - p1[1]) ** 2 + (p2[2] - p1[2]) ** 2)
    steps = max(math.sqrt(bend / CHORD_TOLERANCE_PX), chord / (px * view[11]))
    if not steps < 1e6:  # NaN or a degenerate view
        return most
    return min(max(int(math.ceil(steps)), 1), most)


@kernel
def _spread(v):
    """The low 10 bits of v moved to every third bit (one axis of a Morton code)."""
    v &= 0x3FF
    v = (v | (v << 16)) & 0x30000FF
    v = (v | (v << 8)) & 0x300F00F
    v = (v | (v << 4)) & 0x30C30C3
    return (v | (v << 2)) & 0x9249249


@kernel
def space_order(points, offsets, bits):
    """The curves in space order: sorted, stably, by the Morton code of the cell of a
    2^bits-per-axis grid over the roots that holds their root.

    Their steps are stored in that order, so a screen tile meets its segments closer
    together in memory: in curve order a tile of long hair gathers segments from all
    over the steps array, and reading them costs more than drawing them (100,000
    hairs × 16 at 1280×720: the colour pass 0.97 s in curve order, 0.88 s in this one,
    1.16 s shuffled)."""
    n = len(offsets) - 1
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for c in range(n):
        for d in range(3):
            lo[d] = min(lo[d], points[offsets[c], d])
            hi[d] = max(hi[d], points[offsets[c], d])
    cells = 1 << bits
    scale = np.zeros(3)
    for d in range(3):
        if hi[d] > lo[d]:
            scale[d] = cells / (hi[d] - lo[d])
    keys = np.zeros(n, np.int64)
    start = np.zeros((1 << (3 * bits)) + 1, np.int64)
    for c in range(n):
        if offsets[c + 1] > offsets[c]:
            for d in range(3):
                q = int((points[offsets[c], d] - lo[d]) * scale[d])
                keys[c] |= _spread(min(max(q, 0), cells - 1)) << d
        start[keys[c] + 1] += 1
    for k in range(1, len(start)):
        start[k] += start[k - 1]
    order = np.empty(n, np.int64)
    for c in range(n):
        order[start[keys[c]]] = c
        start[keys[c]] += 1
    return order


@kernel(parallel=True)
def segment_steps(points, offsets, order, view, subdivisions):
    """Per segment, the curves taken in ``order``, its step count; and per curve (in
    that order) the index of its first segment (C + 1,)."""
    n_curves = len(offsets) - 1
    seg_base = np.zeros(n_curves + 1, np.int64)
    for q in range(n_curves):
        c = order[q]
        seg_base[q + 1] = seg_base[q] + max(offsets[c + 1] - offsets[c] - 1, 0)
    counts = np.empty(seg_base[-1], np.int64)
    most = min(subdivisions, MAX_SUBDIVISIONS)
    for q in prange(n_curves):
        c = order[q]
        first, last = offsets[c], offsets[c + 1] - 1
        for i in range(first, last):
            p0, p1, p2, p3 = _neighbours(points, first, last, i)
            counts[seg_base[q] + i - first] = _step_count(p0, p1, p2, p3, view, most)
    return counts, seg_base


@kernel(inline="always")
def _project(p, vp, view, size_x, size_y):
    """Pixel x, y and depth of p; depth NaN outside the clip volume."""
    cx = vp[0, 0] * p[0] + vp[0, 1] * p[1] + vp[0, 2] * p[2] + vp[0, 3]
    cy = vp[1, 0] * p[0] + vp[1, 1] * p[1] + vp[1, 2] * p[2] + vp[1, 3]
    cz = vp[2, 0] * p[0] + vp[2, 1] * p[1] + vp[2, 2] * p[2] + vp[2, 3]
    cw = vp[3, 0] * p[0] + vp[3, 1] * p[1] + vp[3, 2] * p[2] + vp[3, 3]
    if not (cw > 0.0 and -cw <= cz <= cw):
        return 0.0, 0.0, np.nan
    x = (cx / cw + 1.0) * 0.5 * size_x
    if view[3] > 0.5:  # the camera: rows from the top, depth the view depth (clip w)
        return x, (1.0 - cy / cw) * 0.5 * size_y, cw
    return x, (cy / cw + 1.0) * 0.5 * size_y, cz / cw * 0.5 + 0.5


@kernel(parallel=True)
def fill_steps(
    points,
    offsets,
    order,
    attrs,
    seg_base,
    step_start,
    vp,
    view,
    size_x,
    size_y,
    shade,
    model,
    prm,
    powers,
    common,
    nl,
    ldir,
    lrad,
    amb,
    shadow,
):
    """The steps of every segment at ``step_start[segment]`` onwards (STEP_FIELDS).

    ``attrs`` (P, 7): width, colour, opacity, t, seed per vertex. ``view``: eye or
    direction to the viewer (3), 1 perspective / 0 orthographic, forward (3), right
    (3), pixel scale, longest step in pixels. ``shade`` False: the light's passes, which
    need the shape only.
    """
    out = np.empty((step_start[-1], len(STEP_FIELDS)), np.float32)
    n_curves = len(offsets) - 1
    lvp, dom_first, dom_layers, dom_skin, sh = shadow  # separate: see hair_radiance
    eye = (view[0], view[1], view[2])
    perspective = view[3] > 0.5
    forward = (view[4], view[5], view[6])
    right = (view[7], view[8], view[9])
    for q in prange(n_curves):
        c = order[q]
        first, last = offsets[c], offsets[c + 1] - 1
        for i in range(first, last):
            seg = seg_base[q] + i - first
            s0 = step_start[seg]
            n = step_start[seg + 1] - s0 - 1
            p0, p1, p2, p3 = _neighbours(points, first, last, i)
            a, b, cc = _power_form(p0, p1, p2, p3)
            chord = (p2[0] - p1[0], p2[1] - p1[1], p2[2] - p1[2])
            for k in range(n + 1):
                u = k / n
                # the ends use the neighbouring segments' shared expressions, so
                # consecutive segments meet exactly
                if k == 0:
                    pos = p1
                    tan = scaled((p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]), 0.5)
                elif k == n:
                    pos = p2
                    tan = scaled((p3[0] - p1[0], p3[1] - p1[1], p3[2] - p1[2]), 0.5)
                else:
                    pos = added(
                        p1,
                        scaled(
                            (
                                ((a[0] * u + b[0]) * u + cc[0]) * u,
                                ((a[1] * u + b[1]) * u + cc[1]) * u,
                                ((a[2] * u + b[2]) * u + cc[2]) * u,
                            ),
                            0.5,
                        ),
                    )
                    tan = scaled(
                        (
                            (3.0 * a[0] * u + 2.0 * b[0]) * u + cc[0],
                            (3.0 * a[1] * u + 2.0 * b[1]) * u + cc[1],
                            (3.0 * a[2] * u + 2.0 * b[2]) * u + cc[2],
                        ),
                        0.5,
                    )
                if dot(tan, tan) < 1e-24:
                    tan = chord
                tan = unit(tan) if dot(tan, tan) > 0.0 else forward
                row = out[s0 + k]
                x, y, depth = _project(pos, vp, view, size_x, size_y)
                px = _pixel_size(pos, view)
                width = attrs[i, 0] + (attrs[i + 1, 0] - attrs[i, 0]) * u
                opacity = attrs[i, 4] + (attrs[i + 1, 4] - attrs[i, 4]) * u
                row[0] = x
                row[1] = y
                row[2] = depth
                row[3] = 0.5 * width / px
                row[4] = opacity
                # the screen tangent (where wide pieces meet): towards the point a pixel
                # further along the hair
                row[8] = row[9] = 0.0
                if row[3] >= 0.5:
                    x2, y2, _ = _project(added(pos, scaled(tan, px)), vp, view, size_x, size_y)
                    tx, ty = x2 - x, y2 - y
                    tlen = math.sqrt(tx * tx + ty * ty)
                    if tlen > 1e-6:
                        row[8], row[9] = tx / tlen, ty / tlen
                if not shade:
                    row[5] = row[6] = row[7] = 0.0
                    continue
                color = (
                    attrs[i, 1] + (attrs[i + 1, 1] - attrs[i, 1]) * u,
                    attrs[i, 2] + (attrs[i + 1, 2] - attrs[i, 2]) * u,
                    attrs[i, 3] + (attrs[i + 1, 3] - attrs[i, 3]) * u,
                )
                t = attrs[i, 5] + (attrs[i + 1, 5] - attrs[i, 5]) * u
                to_eye = (eye[0] - pos[0], eye[1] - pos[1], eye[2] - pos[2]) if perspective else eye
                side = cross(tan, to_eye)
                side_len = math.sqrt(dot(side, side))
                if side_len > 1e-12 * dot(to_eye, to_eye):
                    side = scaled(side, 1.0 / side_len)
                else:
                    side = right
                E = unit(to_eye)
                N = unit(cross(side, tan))
                if dot(N, E) < 0.0:
                    N = scaled(N, -1.0)
                rgb = hair_radiance(
                    model,
                    prm,
                    powers,
                    common,
                    pos,
                    tan,
                    N,
                    E,
                    color,
                    t,
                    attrs[i, 6],
                    width,
                    1.0 / 3.0,
                    nl,
                    ldir,
                    lrad,
                    amb,
                    lvp,
                    dom_first,
                    dom_layers,
                    dom_skin,
                    sh,
                )
                row[5] = rgb[0]
                row[6] = rgb[1]
                row[7] = rgb[2]
    return out
