"""Colliders: spheres, capsules and the skin's SDF (Le Muzic 2012 §5.1.2 collision constraints).

A collision is a hard constraint: a vertex found inside a collider grown by the
margin is moved to its surface along the collider's normal there (Le Muzic 2012: the head sphere
first, other shapes for the body; the skin mesh through its signed distance field,
:mod:`follicle.sim.sdf`). Colliders arrive in world space as plain arrays: spheres
(K, 4) = centre, radius; capsules (L, 7) = end a, end b, radius; the SDF as the
arguments of :func:`sdf_sample` (an empty grid for none).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .sdf import sdf_lookup

__all__ = ["collide", "penetration", "clearance", "NO_SDF"]

# sdf_sample's arguments for "no skin SDF": an empty grid
NO_SDF = (np.zeros((0, 0, 0), np.float32), np.zeros(3), 1.0, np.eye(4))


@njit(cache=True, inline="always")
def _push(px, py, pz, cx, cy, cz, r, nx, ny, nz, hit, gap):
    """Project p out of the ball (c, r), its normal then in n; else shrink ``gap`` to
    p's distance from the ball."""
    dx, dy, dz = px - cx, py - cy, pz - cz
    d2 = dx * dx + dy * dy + dz * dz
    if d2 >= r * r:
        return px, py, pz, nx, ny, nz, hit, min(gap, math.sqrt(d2) - r)
    d = math.sqrt(d2)
    if d < 1e-12:  # at the centre: push straight up
        dx, dy, dz, d = 0.0, 1.0, 0.0, 1.0
    ux, uy, uz = dx / d, dy / d, dz / d
    return cx + r * ux, cy + r * uy, cz + r * uz, ux, uy, uz, True, gap


@njit(cache=True, inline="always")
def collide(px, py, pz, spheres, capsules, sdf_values, sdf_origin, sdf_inv_voxel, sdf_lfw, margin):
    """p moved out of every collider grown by ``margin``: (x, y, z, nx, ny, nz, hit,
    clearance). ``n`` is the last contact's outward normal. ``clearance`` is 0 after a
    push, else the smallest gap between p and a grown collider (for the SDF, the gap of
    :func:`sdf_lookup`'s bound: divided by √3 it bounds how far p may move before it can
    touch, as each partial derivative of a trilinear interpolant of distances is at
    most 1). The skin SDF (grid ``sdf_values`` with :func:`sdf_sample`'s arguments) is
    skipped when the grid is empty.
    """
    nx, ny, nz, hit = 0.0, 0.0, 0.0, False
    gap = math.inf
    for k in range(spheres.shape[0]):
        px, py, pz, nx, ny, nz, hit, gap = _push(
            px,
            py,
            pz,
            spheres[k, 0],
            spheres[k, 1],
            spheres[k, 2],
            spheres[k, 3] + margin,
            nx,
            ny,
            nz,
            hit,
            gap,
        )
    for k in range(capsules.shape[0]):
        ax, ay, az = capsules[k, 0], capsules[k, 1], capsules[k, 2]
        ex, ey, ez = capsules[k, 3] - ax, capsules[k, 4] - ay, capsules[k, 5] - az
        e2 = ex * ex + ey * ey + ez * ez
        s = 0.0
        if e2 > 0.0:
            s = min(max(((px - ax) * ex + (py - ay) * ey + (pz - az) * ez) / e2, 0.0), 1.0)
        px, py, pz, nx, ny, nz, hit, gap = _push(
            px,
            py,
            pz,
            ax + s * ex,
            ay + s * ey,
            az + s * ez,
            capsules[k, 6] + margin,
            nx,
            ny,
            nz,
            hit,
            gap,
        )
    if sdf_values.size > 0:
        # one lookup with the normal: the solver only asks for vertices that may touch
        d, gx, gy, gz, bound = sdf_lookup(
            sdf_values, sdf_origin, sdf_inv_voxel, sdf_lfw, px, py, pz, margin
        )
        if d < margin and (gx != 0.0 or gy != 0.0 or gz != 0.0):
            depth = margin - d
            px, py, pz = px + depth * gx, py + depth * gy, pz + depth * gz
            nx, ny, nz, hit = gx, gy, gz, True
        gap = min(gap, max(bound - margin, 0.0))
    return px, py, pz, nx, ny, nz, hit, 0.0 if hit else gap


@njit(cache=True, parallel=True)
def _clearance_kernel(x, spheres, capsules, sdf_values, sdf_origin, sdf_inv_voxel, sdf_lfw, out):
    for s in prange(x.shape[0]):
        for i in range(x.shape[1]):
            px, py, pz = x[s, i, 0], x[s, i, 1], x[s, i, 2]
            qx, qy, qz, _, _, _, hit, gap = collide(
                px, py, pz, spheres, capsules, sdf_values, sdf_origin, sdf_inv_voxel, sdf_lfw, 0.0
            )
            depth = math.sqrt((qx - px) ** 2 + (qy - py) ** 2 + (qz - pz) ** 2)
            out[s, i] = -depth if hit else gap


def clearance(
    x: np.ndarray, spheres: np.ndarray, capsules: np.ndarray, sdf: tuple = NO_SDF
) -> np.ndarray:
    """(S, N) distance of each vertex of ``x`` (S, N, 3) from the nearest collider (inf
    for none), or minus its depth inside."""
    out = np.empty(x.shape[:2])
    _clearance_kernel(np.ascontiguousarray(x, np.float64), spheres, capsules, *sdf, out)
    return out


def penetration(
    x: np.ndarray, spheres: np.ndarray, capsules: np.ndarray, sdf: tuple = NO_SDF
) -> float:
    """Deepest penetration (m) of any vertex of ``x`` (S, N, 3) into a collider or the
    skin (no margin): how far the deepest vertex would have to move to get out."""
    return max(0.0, -float(clearance(x, spheres, capsules, sdf).min()))
