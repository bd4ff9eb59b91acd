"""The skin mesh rasterized per tile: a depth buffer with, per pixel, the nearest
triangle and its perspective-correct barycentric coordinates (shaded afterwards, once
per pixel, by :func:`shade_skin`), and the key light's shadow map with a
slope-scaled depth bias (the OpenGL engine's polygon offset 2, 4) against acne.
"""

from __future__ import annotations

import math

import numpy as np

from ...kernels import kernel, prange
from .bins import dealt_tiles, tile_bounds
from .shading import skin_radiance, unit

__all__ = ["project_triangles", "draw_triangles", "shade_skin"]

_UNIT_DEPTH = 2.0**-24  # the smallest step of a 24-bit depth buffer


@kernel(parallel=True)
def project_triangles(vertices, faces, vp, size_x, size_y, camera):
    """Screen vertices (V, 3: x, y, depth) and triangle boxes (F, 4; NaN when a corner
    is outside the clip volume). ``camera``: rows from the top and view depth; else the
    light's texel rows upwards and depth 0..1."""
    nv = vertices.shape[0]
    screen = np.empty((nv, 3), np.float64)
    for v in prange(nv):
        p = vertices[v]
        cx = vp[0, 0] * p[0] + vp[0, 1] * p[1] + vp[0, 2] * p[2] + vp[0, 3]
        cy = vp[1, 0] * p[0] + vp[1, 1] * p[1] + vp[1, 2] * p[2] + vp[1, 3]
        cz = vp[2, 0] * p[0] + vp[2, 1] * p[1] + vp[2, 2] * p[2] + vp[2, 3]
        cw = vp[3, 0] * p[0] + vp[3, 1] * p[1] + vp[3, 2] * p[2] + vp[3, 3]
        if not (cw > 0.0 and -cw <= cz <= cw):
            screen[v, 0] = screen[v, 1] = screen[v, 2] = np.nan
            continue
        screen[v, 0] = (cx / cw + 1.0) * 0.5 * size_x
        if camera:
            screen[v, 1] = (1.0 - cy / cw) * 0.5 * size_y
            screen[v, 2] = cw
        else:
            screen[v, 1] = (cy / cw + 1.0) * 0.5 * size_y
            screen[v, 2] = cz / cw * 0.5 + 0.5
    nf = faces.shape[0]
    boxes = np.empty((nf, 4), np.float32)
    for f in prange(nf):
        x0 = y0 = np.inf
        x1 = y1 = -np.inf
        for c in range(3):
            s = screen[faces[f, c]]
            x0 = min(x0, s[0])
            x1 = max(x1, s[0])
            y0 = min(y0, s[1])
            y1 = max(y1, s[1])
            if math.isnan(s[2]):
                x0 = np.nan
        boxes[f, 0] = x0
        boxes[f, 1] = x1
        boxes[f, 2] = y0
        boxes[f, 3] = y1
    return screen, boxes


@kernel(parallel=True)
def draw_triangles(screen, faces, tile_start, items, tile, nx, depth, tri, bary, camera, threads):
    """Rasterize every tile's triangles, nearest wins (``depth`` (H, W) starts at +inf or
    the far value). ``camera``: perspective-correct barycentrics into ``bary`` (H, W, 2)
    and the triangle into ``tri`` (H, W); else the light's biased depth only. The tiles
    are dealt to the ``threads`` as :func:`~.bins.dealt_tiles` orders them."""
    h, w = depth.shape
    order = dealt_tiles(tile_start)
    for t in prange(threads):
        for k in order[t::threads]:
            x_lo, x_hi, y_lo, y_hi = tile_bounds(k, nx, tile, w, h)
            for e in range(tile_start[k], tile_start[k + 1]):
                f = items[e]
                a, b, c = screen[faces[f, 0]], screen[faces[f, 1]], screen[faces[f, 2]]
                area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
                if not abs(area) > 1e-12:
                    continue
                inv = 1.0 / area
                j0 = max(int(math.floor(min(a[0], b[0], c[0]) - 0.5)), x_lo)
                j1 = min(int(math.ceil(max(a[0], b[0], c[0]) - 0.5)), x_hi - 1)
                i0 = max(int(math.floor(min(a[1], b[1], c[1]) - 0.5)), y_lo)
                i1 = min(int(math.ceil(max(a[1], b[1], c[1]) - 0.5)), y_hi - 1)
                bias = 0.0
                if not camera:
                    # dz/dx and dz/dy of the triangle's plane, per texel
                    dzx = ((b[2] - a[2]) * (c[1] - a[1]) - (c[2] - a[2]) * (b[1] - a[1])) * inv
                    dzy = ((c[2] - a[2]) * (b[0] - a[0]) - (b[2] - a[2]) * (c[0] - a[0])) * inv
                    bias = 2.0 * max(abs(dzx), abs(dzy)) + 4.0 * _UNIT_DEPTH
                for i in range(i0, i1 + 1):
                    py = i + 0.5
                    for j in range(j0, j1 + 1):
                        px = j + 0.5
                        l1 = ((px - a[0]) * (c[1] - a[1]) - (py - a[1]) * (c[0] - a[0])) * inv
                        l2 = ((b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0])) * inv
                        l0 = 1.0 - l1 - l2
                        if l0 < 0.0 or l1 < 0.0 or l2 < 0.0:
                            continue
                        if camera:  # perspective-correct: 1/depth is linear on screen
                            q0, q1, q2 = l0 / a[2], l1 / b[2], l2 / c[2]
                            s = q0 + q1 + q2
                            z = 1.0 / s
                            if z < depth[i, j]:
                                depth[i, j] = z
                                tri[i, j] = f
                                bary[i, j, 0] = q1 / s
                                bary[i, j, 1] = q2 / s
                        else:
                            z = l0 * a[2] + l1 * b[2] + l2 * c[2] + bias
                            if z < depth[i, j]:
                                depth[i, j] = z


@kernel(inline="always")
def _skin_sample(
    f, b1, b2, vertices, normals, faces, eye, skin, wrap, nl, ldir, lrad, amb,
    lvp, dom_first, dom_layers, dom_skin, sh,
):  # fmt: skip
    """The skin's radiance at barycentrics (b1, b2) of triangle f, its colour
    interpolated from the vertices' ``skin`` (V, 3) colours as the GPU's varyings are."""
    b0 = 1.0 - b1 - b2
    v0, v1, v2 = faces[f, 0], faces[f, 1], faces[f, 2]
    P = (
        b0 * vertices[v0, 0] + b1 * vertices[v1, 0] + b2 * vertices[v2, 0],
        b0 * vertices[v0, 1] + b1 * vertices[v1, 1] + b2 * vertices[v2, 1],
        b0 * vertices[v0, 2] + b1 * vertices[v1, 2] + b2 * vertices[v2, 2],
    )
    N = unit(
        (
            b0 * normals[v0, 0] + b1 * normals[v1, 0] + b2 * normals[v2, 0],
            b0 * normals[v0, 1] + b1 * normals[v1, 1] + b2 * normals[v2, 1],
            b0 * normals[v0, 2] + b1 * normals[v1, 2] + b2 * normals[v2, 2],
        )
    )
    E = unit((eye[0] - P[0], eye[1] - P[1], eye[2] - P[2]))
    color = (
        b0 * skin[v0, 0] + b1 * skin[v1, 0] + b2 * skin[v2, 0],
        b0 * skin[v0, 1] + b1 * skin[v1, 1] + b2 * skin[v2, 1],
        b0 * skin[v0, 2] + b1 * skin[v1, 2] + b2 * skin[v2, 2],
    )
    return skin_radiance(
        P, N, E, color, wrap, nl, ldir, lrad, amb, lvp, dom_first, dom_layers, dom_skin, sh
    )


@kernel(parallel=True)
def shade_skin(
    tri,
    bary,
    k,
    vertices,
    normals,
    faces,
    eye,
    skin,
    wrap,
    nl,
    ldir,
    lrad,
    amb,
    shadow,
    out,
):
    """The skin's linear RGB into ``out`` (H, W, 3) over the background already there.

    ``tri`` and ``bary`` hold k × k samples a pixel (multisampling): as a
    GPU's MSAA, each triangle in a pixel is shaded once (at the first of its samples)
    and weighs by the share of the samples it covers; the rest keeps the background."""
    h, w = out.shape[:2]
    inv = 1.0 / (k * k)
    lvp, dom_first, dom_layers, dom_skin, sh = shadow  # separate: see hair_radiance
    for i in prange(h):
        for j in range(w):
            r = g = b = 0.0
            empty = 0
            for s in range(k * k):
                si, sj = i * k + s // k, j * k + s % k
                f = tri[si, sj]
                if f < 0:
                    empty += 1
                    continue
                seen = False
                for t in range(s):  # shaded already at an earlier sample
                    if tri[i * k + t // k, j * k + t % k] == f:
                        seen = True
                        break
                if seen:
                    continue
                count = 0
                for t in range(s, k * k):
                    if tri[i * k + t // k, j * k + t % k] == f:
                        count += 1
                rgb = _skin_sample(
                    f, bary[si, sj, 0], bary[si, sj, 1], vertices, normals, faces, eye,
                    skin, wrap, nl, ldir, lrad, amb, lvp, dom_first, dom_layers, dom_skin, sh,
                )  # fmt: skip
                r += rgb[0] * count
                g += rgb[1] * count
                b += rgb[2] * count
            if empty == k * k:
                continue
            keep = empty * inv
            out[i, j, 0] = r * inv + out[i, j, 0] * keep
            out[i, j, 1] = g * inv + out[i, j, 1] * keep
            out[i, j, 2] = b * inv + out[i, j, 2] * keep
