"""Per-strand position constraints, each an njit function over one strand ``s`` of (S, N, 3).

- distance (002 §5.1.2): segments solved even then odd, so no two in a batch share a
  vertex; the pinned root (inverse mass 0) never moves.
- bending (002 eq. 5.6): a long-range distance from each vertex to the strand's static
  point (one rest segment below the root, along the groomed root direction) with the
  rest distance × ``scale``, weakened along the strand by the attenuation.
- follow-the-leader (001 §3.1.1, Alg. 2): one root-to-tip pass that restores every
  segment length exactly and records each vertex's correction for the velocity
  update of eq. 3.1.
- strain limit: after PBD's iterations, no segment stays longer than (1 + limit) × rest.
- cone (001 §3.3.3): a segment may turn away from the previous one by at most the
  bend limit; beyond it, it is put on the cone, keeping its length.
- shape matching: local (each segment towards its rest direction in the frame of the
  previous segment, so curls and partings keep their form) and global (each vertex
  towards the skinned rest pose, by a root-to-tip profile).
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["segment", "skinned", "distance_pass", "bend_pass", "follow_the_leader",
           "strain_limit", "cone_pass", "rest_pose", "local_shape_pass",
           "global_shape_pass"]  # fmt: skip


@njit(cache=True, inline="always")
def segment(x, s, i, j):
    """(dx, dy, dz, length) of x[s, j] − x[s, i]."""
    dx = x[s, j, 0] - x[s, i, 0]
    dy = x[s, j, 1] - x[s, i, 1]
    dz = x[s, j, 2] - x[s, i, 2]
    return dx, dy, dz, math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True, inline="always")
def skinned(root, frame, local, i):
    """Vertex ``i`` of ``local`` (N, 3) root-frame coordinates placed at ``root`` with
    ``frame`` (3, 3) rows tangent, binormal, normal."""
    lx, ly, lz = local[i, 0], local[i, 1], local[i, 2]
    return (root[0] + lx * frame[0, 0] + ly * frame[1, 0] + lz * frame[2, 0],
            root[1] + lx * frame[0, 1] + ly * frame[1, 1] + lz * frame[2, 1],
            root[2] + lx * frame[0, 2] + ly * frame[1, 2] + lz * frame[2, 2])  # fmt: skip


@njit(cache=True, inline="always")
def _project_pair(x, w, s, i, j, rest, k):
    wi, wj = w[s, i], w[s, j]
    total = wi + wj
    if total <= 0.0:
        return
    dx, dy, dz, length = segment(x, s, i, j)
    if length < 1e-12:
        return
    c = k * (length - rest) / (length * total)
    x[s, i, 0] += wi * c * dx
    x[s, i, 1] += wi * c * dy
    x[s, i, 2] += wi * c * dz
    x[s, j, 0] -= wj * c * dx
    x[s, j, 1] -= wj * c * dy
    x[s, j, 2] -= wj * c * dz


@njit(cache=True)
def distance_pass(x, w, rest_length, s, k):
    """One even/odd sweep of the segment length constraints of strand ``s``."""
    n = x.shape[1]
    for parity in range(2):
        for i in range(parity, n - 1, 2):
            _project_pair(x, w, s, i, i + 1, rest_length[s, i], k)


@njit(cache=True)
def bend_pass(x, w, s, static, bend_rest, scale, k, attenuation):
    """Pull vertices 2 … N−1 of strand ``s`` to ``scale`` × their rest distance from the
    static point ``static`` (3,), which does not move; vertex i's coefficient is
    k / (1 + att·(i − 1)) (002 eq. 5.6 with att = 1 is k / i).
    """
    for i in range(2, x.shape[1]):
        if w[s, i] == 0.0:
            continue
        dx = x[s, i, 0] - static[0]
        dy = x[s, i, 1] - static[1]
        dz = x[s, i, 2] - static[2]
        length = math.sqrt(dx * dx + dy * dy + dz * dz)
        if length < 1e-12:
            continue
        c = k / (1.0 + attenuation * (i - 1)) * (length - scale * bend_rest[s, i]) / length
        x[s, i, 0] -= c * dx
        x[s, i, 1] -= c * dy
        x[s, i, 2] -= c * dz


@njit(cache=True)
def follow_the_leader(x, s, rest_length, correction):
    """FTL root to tip: each vertex put at its rest length from the previous one along
    their current direction; ``correction`` (N, 3) gets each vertex's move."""
    correction[0, 0] = correction[0, 1] = correction[0, 2] = 0.0
    for i in range(1, x.shape[1]):
        dx, dy, dz, length = segment(x, s, i - 1, i)
        if length < 1e-12:  # coincident: keep the previous segment's direction
            if i >= 2:
                dx, dy, dz, length = segment(x, s, i - 2, i - 1)
            if length < 1e-12:
                dx, dy, dz, length = 0.0, 1.0, 0.0, 1.0
        f = rest_length[s, i - 1] / length
        nx = x[s, i - 1, 0] + f * dx
        ny = x[s, i - 1, 1] + f * dy
        nz = x[s, i - 1, 2] + f * dz
        correction[i, 0] = nx - x[s, i, 0]
        correction[i, 1] = ny - x[s, i, 1]
        correction[i, 2] = nz - x[s, i, 2]
        x[s, i, 0], x[s, i, 1], x[s, i, 2] = nx, ny, nz


@njit(cache=True)
def strain_limit(x, w, s, rest_length, limit, correction):
    """Root to tip, shorten any segment longer than (1 + ``limit``) × rest by moving its
    child (Provot's strain limiting): PBD's iterations leave the rest of the stretch.
    ``correction`` (N, 3) gets each vertex's move, for 001 eq. 3.1's velocity fix."""
    correction[0, 0] = correction[0, 1] = correction[0, 2] = 0.0
    for i in range(1, x.shape[1]):
        correction[i, 0] = correction[i, 1] = correction[i, 2] = 0.0
        if w[s, i] == 0.0:
            continue
        dx, dy, dz, length = segment(x, s, i - 1, i)
        most = (1.0 + limit) * rest_length[s, i - 1]
        if length > most:
            f = most / length - 1.0
            for a, d in ((0, dx), (1, dy), (2, dz)):
                correction[i, a] = f * d
                x[s, i, a] += f * d


@njit(cache=True)
def cone_pass(x, s, cos_limit, sin_limit, first_x, first_y, first_z):
    """Limit each segment's turn from the previous one (the first from the unit root
    direction ``first``) to the cone of half-angle acos(cos_limit), keeping lengths."""
    px, py, pz = first_x, first_y, first_z
    for i in range(1, x.shape[1]):
        dx, dy, dz, length = segment(x, s, i - 1, i)
        if length < 1e-12:
            continue
        ux, uy, uz = dx / length, dy / length, dz / length
        c = ux * px + uy * py + uz * pz
        if c < cos_limit:
            # the cone's axis component plus the unit perpendicular in the plane of u, p
            qx, qy, qz = ux - c * px, uy - c * py, uz - c * pz
            q = math.sqrt(qx * qx + qy * qy + qz * qz)
            if q < 1e-12:  # straight back: any perpendicular will do
                qx, qy, qz = (1.0, 0.0, 0.0) if abs(px) < 0.9 else (0.0, 1.0, 0.0)
                d = qx * px + qy * py + qz * pz
                qx, qy, qz = qx - d * px, qy - d * py, qz - d * pz
                q = math.sqrt(qx * qx + qy * qy + qz * qz)
            ux = cos_limit * px + sin_limit * qx / q
            uy = cos_limit * py + sin_limit * qy / q
            uz = cos_limit * pz + sin_limit * qz / q
            x[s, i, 0] = x[s, i - 1, 0] + length * ux
            x[s, i, 1] = x[s, i - 1, 1] + length * uy
            x[s, i, 2] = x[s, i - 1, 2] + length * uz
        px, py, pz = ux, uy, uz


@njit(cache=True, inline="always")
def _rotate_min(ax, ay, az, bx, by, bz, ux, uy, uz):
    """u turned by the smallest rotation taking unit a to unit b (Rodrigues)."""
    vx = ay * bz - az * by
    vy = az * bx - ax * bz
    vz = ax * by - ay * bx
    c = ax * bx + ay * by + az * bz
    if c <= -1.0 + 1e-9:  # opposite: no unique smallest rotation, leave u
        return ux, uy, uz
    f = 1.0 / (1.0 + c)
    wx = vy * uz - vz * uy
    wy = vz * ux - vx * uz
    wz = vx * uy - vy * ux
    return (ux + wx + f * (vy * wz - vz * wy),
            uy + wy + f * (vz * wx - vx * wz),
            uz + wz + f * (vx * wy - vy * wx))  # fmt: skip


@njit(cache=True)
def rest_pose(root, frame, local, target, rest_dir):
    """Fill ``target`` (N, 3) with the rest shape ``local`` skinned to ``root``/``frame``
    and ``rest_dir`` (N, 3) with its unit segments, row i the one ending at vertex i
    (zero when degenerate): what shape matching reads, once per substep."""
    for i in range(local.shape[0]):
        target[i, 0], target[i, 1], target[i, 2] = skinned(root, frame, local, i)
    rest_dir[0, 0] = rest_dir[0, 1] = rest_dir[0, 2] = 0.0
    for i in range(1, local.shape[0]):
        ex = target[i, 0] - target[i - 1, 0]
        ey = target[i, 1] - target[i - 1, 1]
        ez = target[i, 2] - target[i - 1, 2]
        le = math.sqrt(ex * ex + ey * ey + ez * ez)
        le = 1.0 / le if le > 1e-12 else 0.0
        rest_dir[i, 0], rest_dir[i, 1], rest_dir[i, 2] = ex * le, ey * le, ez * le


@njit(cache=True)
def local_shape_pass(x, w, s, target, rest_dir, k):
    """Move each vertex towards its rest place relative to the previous segment.

    Segment 0 follows the root frame; segment i the rest segment i turned by the
    smallest rotation from rest segment i−1 to the current segment i−1 (``target``
    and ``rest_dir`` from :func:`rest_pose`).
    """
    n = x.shape[1]
    for i in range(n - 1):
        j = i + 1
        if w[s, j] == 0.0:
            continue
        rx = target[j, 0] - target[i, 0]  # rest segment i, world axes
        ry = target[j, 1] - target[i, 1]
        rz = target[j, 2] - target[i, 2]
        if i > 0:
            ex, ey, ez = rest_dir[i, 0], rest_dir[i, 1], rest_dir[i, 2]
            cx, cy, cz, lc = segment(x, s, i - 1, i)
            if lc < 1e-12 or (ex == 0.0 and ey == 0.0 and ez == 0.0):
                continue
            rx, ry, rz = _rotate_min(ex, ey, ez, cx / lc, cy / lc, cz / lc, rx, ry, rz)
        x[s, j, 0] += k * (x[s, i, 0] + rx - x[s, j, 0])
        x[s, j, 1] += k * (x[s, i, 1] + ry - x[s, j, 1])
        x[s, j, 2] += k * (x[s, i, 2] + rz - x[s, j, 2])


@njit(cache=True)
def global_shape_pass(x, w, s, target, k_profile):
    """Move vertex i towards the skinned rest pose ``target`` (N, 3) by ``k_profile[i]``."""
    for i in range(1, x.shape[1]):
        k = k_profile[i]
        if k <= 0.0 or w[s, i] == 0.0:
            continue
        x[s, i, 0] += k * (target[i, 0] - x[s, i, 0])
        x[s, i, 1] += k * (target[i, 1] - x[s, i, 1])
        x[s, i, 2] += k * (target[i, 2] - x[s, i, 2])
