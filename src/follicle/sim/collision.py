"""Sphere and capsule colliders (002 §5.1.2 collision constraints, extended to capsules).

A collision is a hard constraint: a vertex found inside a collider grown by the
margin is moved to its surface along the collider's normal there (002: the head sphere
first, other shapes for the body). Colliders arrive in world space as plain arrays:
spheres (K, 4) = centre, radius; capsules (L, 7) = end a, end b, radius.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["collide", "penetration"]


@njit(cache=True, inline="always")
def _push(px, py, pz, cx, cy, cz, r, nx, ny, nz, hit):
    """Project p out of the ball (c, r); keep the deepest contact normal in n."""
    dx, dy, dz = px - cx, py - cy, pz - cz
    d2 = dx * dx + dy * dy + dz * dz
    if d2 >= r * r:
        return px, py, pz, nx, ny, nz, hit
    d = math.sqrt(d2)
    if d < 1e-12:  # at the centre: push straight up
        dx, dy, dz, d = 0.0, 1.0, 0.0, 1.0
    ux, uy, uz = dx / d, dy / d, dz / d
    return cx + r * ux, cy + r * uy, cz + r * uz, ux, uy, uz, True


@njit(cache=True)
def collide(px, py, pz, spheres, capsules, margin):
    """p moved out of every collider (grown by ``margin``): (x, y, z, nx, ny, nz, hit)."""
    nx, ny, nz, hit = 0.0, 0.0, 0.0, False
    for k in range(spheres.shape[0]):
        px, py, pz, nx, ny, nz, hit = _push(
            px, py, pz, spheres[k, 0], spheres[k, 1], spheres[k, 2], spheres[k, 3] + margin,
            nx, ny, nz, hit,
        )  # fmt: skip
    for k in range(capsules.shape[0]):
        ax, ay, az = capsules[k, 0], capsules[k, 1], capsules[k, 2]
        ex, ey, ez = capsules[k, 3] - ax, capsules[k, 4] - ay, capsules[k, 5] - az
        e2 = ex * ex + ey * ey + ez * ez
        s = 0.0
        if e2 > 0.0:
            s = min(max(((px - ax) * ex + (py - ay) * ey + (pz - az) * ez) / e2, 0.0), 1.0)
        px, py, pz, nx, ny, nz, hit = _push(
            px, py, pz, ax + s * ex, ay + s * ey, az + s * ez, capsules[k, 6] + margin,
            nx, ny, nz, hit,
        )  # fmt: skip
    return px, py, pz, nx, ny, nz, hit


@njit(cache=True)
def _depth_kernel(x, spheres, capsules):
    worst = 0.0
    for s in range(x.shape[0]):
        for i in range(x.shape[1]):
            px, py, pz = x[s, i, 0], x[s, i, 1], x[s, i, 2]
            qx, qy, qz, _, _, _, hit = collide(px, py, pz, spheres, capsules, 0.0)
            if hit:
                worst = max(worst, math.sqrt((qx - px) ** 2 + (qy - py) ** 2 + (qz - pz) ** 2))
    return worst


def penetration(x: np.ndarray, spheres: np.ndarray, capsules: np.ndarray) -> float:
    """Deepest penetration (m) of any vertex of ``x`` (S, N, 3) into a collider (no margin)."""
    return float(_depth_kernel(x, spheres, capsules))
