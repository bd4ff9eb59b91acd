"""Strand constraints, each an njit function over a *block* of strands.

A block holds up to B strands vertex-major, ``X[i, axis, b]`` (N, 3, B): every loop
runs over the block's strands innermost, so the strands' independent dependency chains
(follow-the-leader and shape matching go root to tip) overlap in the CPU and the
compiler can vectorise them. ``nb`` ≤ B is the number of strands in use. A pass that
writes one row of X while reading another first computes the row into ``row`` (3, B)
and then copies it: the compiler cannot tell two rows of X apart and would otherwise
keep such loops scalar (6× slower). Per-vertex
values are (N, B): ``W`` inverse masses (0 pins a vertex), ``L`` rest lengths of the
segment starting at each vertex.

- distance (Le Muzic 2012 §5.1.2): segments solved even then odd, so no two in a batch share a
  vertex; the pinned root (inverse mass 0) never moves.
- bending (Le Muzic 2012 eq. 5.6): a long-range distance from each vertex to the strand's static
  point (one rest segment below the root, along the groomed root direction) with the
  rest distance × ``scale``, weakened along the strand by the attenuation.
- follow-the-leader (Almeida 2014 §3.1.1, Alg. 2): one root-to-tip pass that restores every
  segment length exactly and records each vertex's correction for the velocity
  update of eq. 3.1.
- strain limit: after PBD's iterations, no segment stays longer than (1 + limit) × rest.
- cone (Almeida 2014 §3.3.3): a segment may turn away from the previous one by at most the
  bend limit; beyond it, it is put on the cone at its rest length. Root to tip, each
  segment hangs from its parent's new place.
- shape matching: local (each segment towards its rest direction in the frame of the
  previous segment, so curls and partings keep their form) and global (each vertex
  towards the skinned rest pose, by a root-to-tip profile).
- hold: global shape matching again, each vertex's stiffness from its place along its
  strand (:func:`.solver.hold_compliance`): the compliance that lets it sag as far as
  a level cantilever of the style length's stiffness would there, so short styled
  strands stand and long ones fall and swing (issue 41: styled hair must hold).
"""

from __future__ import annotations

import math

from ..arrays import FMA
from ..kernels import kernel

__all__ = [
    "distance_pass",
    "bend_pass",
    "follow_the_leader",
    "strain_limit",
    "cone_pass",
    "rest_pose",
    "local_shape_pass",
    "global_shape_pass",
    "hold_pass",
]

_TINY = 1e-12  # segments shorter than this have no direction

_jit = kernel(error_model="numpy", fastmath=FMA)


@kernel(inline="always")
def _segment(X, i, b):
    """(dx, dy, dz, length) of strand b's segment from vertex i − 1 to vertex i."""
    dx = X[i, 0, b] - X[i - 1, 0, b]
    dy = X[i, 1, b] - X[i - 1, 1, b]
    dz = X[i, 2, b] - X[i - 1, 2, b]
    return dx, dy, dz, math.sqrt(dx * dx + dy * dy + dz * dz)


@_jit
def distance_pass(X, W, L, k, row, nb):
    """One even/odd sweep of the segment length constraints."""
    for parity in range(2):
        for i in range(parity, X.shape[0] - 1, 2):
            for b in range(nb):  # the move along the segment, per unit inverse mass
                dx, dy, dz, length = _segment(X, i + 1, b)
                total = W[i, b] + W[i + 1, b]
                c = 0.0
                if total > 0.0 and length > _TINY:
                    c = k * (length - L[i, b]) / (length * total)
                row[0, b], row[1, b], row[2, b] = c * dx, c * dy, c * dz
            for a in range(3):
                for b in range(nb):
                    X[i, a, b] += W[i, b] * row[a, b]
                for b in range(nb):
                    X[i + 1, a, b] -= W[i + 1, b] * row[a, b]


@_jit
def bend_pass(X, W, static, bend_rest, scale, k, attenuation, nb):
    """Pull vertices 2 … N−1 to ``scale`` × their rest distance ``bend_rest`` (N, B) from
    the static point ``static`` (3, B), which does not move; vertex i's coefficient is
    k / (1 + att·(i − 1)) (Le Muzic 2012 eq. 5.6 with att = 1 is k / i)."""
    for i in range(2, X.shape[0]):
        ki = k / (1.0 + attenuation * (i - 1))
        for b in range(nb):
            dx = X[i, 0, b] - static[0, b]
            dy = X[i, 1, b] - static[1, b]
            dz = X[i, 2, b] - static[2, b]
            length = math.sqrt(dx * dx + dy * dy + dz * dz)
            c = 0.0
            if W[i, b] > 0.0 and length > _TINY:
                c = ki * (length - scale * bend_rest[i, b]) / length
            X[i, 0, b] -= c * dx
            X[i, 1, b] -= c * dy
            X[i, 2, b] -= c * dz


@_jit
def follow_the_leader(X, L, corr, row, nb):
    """FTL root to tip: each vertex put at its rest length from the previous one along
    their current direction; ``corr`` (N, 3, B) gets each vertex's move."""
    for b in range(nb):
        corr[0, 0, b] = corr[0, 1, b] = corr[0, 2, b] = 0.0
    for i in range(1, X.shape[0]):
        for b in range(nb):
            dx, dy, dz, length = _segment(X, i, b)
            if length < _TINY:  # coincident: keep the previous segment's direction
                dx, dy, dz = 0.0, 1.0, 0.0
                if i >= 2:
                    px, py, pz, lp = _segment(X, i - 1, b)
                    if lp >= _TINY:
                        dx, dy, dz = px / lp, py / lp, pz / lp
                length = 1.0
            f = L[i - 1, b] / length
            row[0, b] = X[i - 1, 0, b] + f * dx
            row[1, b] = X[i - 1, 1, b] + f * dy
            row[2, b] = X[i - 1, 2, b] + f * dz
        _put_row(X, i, row, corr, nb)


@_jit
def strain_limit(X, W, L, limit, corr, row, nb):
    """Root to tip, bring any segment outside (1 ± ``limit``) × rest back to that bound
    by moving its child along it (Provot's strain limiting, both ways): PBD's iterations
    leave the rest of the stretch, and bending and shape matching, which keep no
    lengths, crush short segments (a 2 mm strand of 48 segments: 3.6 % in free fall).
    ``corr`` (N, 3, B) gets each vertex's move, for Almeida 2014 eq. 3.1's velocity fix."""
    for b in range(nb):
        corr[0, 0, b] = corr[0, 1, b] = corr[0, 2, b] = 0.0
    for i in range(1, X.shape[0]):
        for b in range(nb):
            dx, dy, dz, length = _segment(X, i, b)
            most = (1.0 + limit) * L[i - 1, b]
            least = (1.0 - limit) * L[i - 1, b]
            f = 0.0
            if W[i, b] > 0.0 and length > most:
                f = most / length - 1.0
            elif W[i, b] > 0.0 and _TINY < length < least:
                f = least / length - 1.0
            row[0, b] = X[i, 0, b] + f * dx
            row[1, b] = X[i, 1, b] + f * dy
            row[2, b] = X[i, 2, b] + f * dz
        _put_row(X, i, row, corr, nb)


@_jit
def _put_row(X, i, row, corr, nb):
    """Row i of X becomes ``row``; ``corr[i]`` gets the move."""
    for a in range(3):
        for b in range(nb):
            corr[i, a, b] = row[a, b] - X[i, a, b]
            X[i, a, b] = row[a, b]


@_jit
def cone_pass(X, L, cos_limit, sin_limit, first, nb):
    """Limit each segment's turn from the previous one (the first from the unit root
    direction ``first`` (3, B)) to the cone of half-angle acos(cos_limit) (Almeida 2014 §3.3.3).

    Root to tip like follow-the-leader (Almeida 2014 §3.1.1): each segment keeps the vector it had
    before the pass, hung from its parent's new place, and a segment outside the cone is
    put on it at its rest length ``L``. So no segment gets longer and a vertex moves at
    most by the turns above it: with any limit, down to 0 (a rigid straight strand at
    rest lengths), the pass cannot stretch a strand or throw it away (reading lengths
    from the moved parent did: a 1e-9° cone sent a curled strand 2 km off in one
    substep)."""
    for b in range(nb):
        px, py, pz = first[0, b], first[1, b], first[2, b]
        ox, oy, oz = X[0, 0, b], X[0, 1, b], X[0, 2, b]  # the parent before the pass
        for i in range(1, X.shape[0]):
            dx, dy, dz = X[i, 0, b] - ox, X[i, 1, b] - oy, X[i, 2, b] - oz
            ox, oy, oz = X[i, 0, b], X[i, 1, b], X[i, 2, b]
            length = math.sqrt(dx * dx + dy * dy + dz * dz)
            if length >= _TINY:
                ux, uy, uz = dx / length, dy / length, dz / length
                c = ux * px + uy * py + uz * pz
                if c < cos_limit:
                    # the cone's axis component plus the unit perpendicular in the plane of u, p
                    qx, qy, qz = ux - c * px, uy - c * py, uz - c * pz
                    q = math.sqrt(qx * qx + qy * qy + qz * qz)
                    if q < _TINY:  # straight back: any perpendicular will do
                        qx, qy, qz = (1.0, 0.0, 0.0) if abs(px) < 0.9 else (0.0, 1.0, 0.0)
                        d = qx * px + qy * py + qz * pz
                        qx, qy, qz = qx - d * px, qy - d * py, qz - d * pz
                        q = math.sqrt(qx * qx + qy * qy + qz * qz)
                    ux = cos_limit * px + sin_limit * qx / q
                    uy = cos_limit * py + sin_limit * qy / q
                    uz = cos_limit * pz + sin_limit * qz / q
                    dx, dy, dz = L[i - 1, b] * ux, L[i - 1, b] * uy, L[i - 1, b] * uz
                px, py, pz = ux, uy, uz
            X[i, 0, b] = X[i - 1, 0, b] + dx
            X[i, 1, b] = X[i - 1, 1, b] + dy
            X[i, 2, b] = X[i - 1, 2, b] + dz


@_jit
def rest_pose(root, frame, local, target, rest_dir, nb):
    """The rest shape skinned to the roots: ``target`` (N, 3, B) = root + frame ·
    ``local`` (N, 3, B) (rows tangent, binormal, normal of ``frame`` (3, 3, B)), and
    ``rest_dir`` (N, 3, B) its unit segments, row i the one ending at vertex i (zero when
    degenerate): what shape matching reads, made once per substep."""
    for i in range(target.shape[0]):
        for a in range(3):
            for b in range(nb):
                target[i, a, b] = (
                    root[a, b]
                    + local[i, 0, b] * frame[0, a, b]
                    + local[i, 1, b] * frame[1, a, b]
                    + local[i, 2, b] * frame[2, a, b]
                )
    for b in range(nb):
        rest_dir[0, 0, b] = rest_dir[0, 1, b] = rest_dir[0, 2, b] = 0.0
    for i in range(1, target.shape[0]):
        for b in range(nb):
            ex = target[i, 0, b] - target[i - 1, 0, b]
            ey = target[i, 1, b] - target[i - 1, 1, b]
            ez = target[i, 2, b] - target[i - 1, 2, b]
            le = math.sqrt(ex * ex + ey * ey + ez * ez)
            inv = 1.0 / le if le > _TINY else 0.0
            rest_dir[i, 0, b], rest_dir[i, 1, b], rest_dir[i, 2, b] = ex * inv, ey * inv, ez * inv


@_jit
def local_shape_pass(X, W, target, rest_dir, k, row, nb):
    """Move each vertex towards its rest place relative to the previous segment.

    Segment 0 follows the root frame; segment i the rest segment i turned by the
    smallest rotation (Rodrigues) from rest segment i−1 to the current segment i−1
    (``target`` and ``rest_dir`` from :func:`rest_pose`). Without branches, so the
    loop over the block vectorises: the exceptions are multiplied away.
    """
    for b in range(nb):
        kb = k if W[1, b] > 0.0 else 0.0
        for a in range(3):
            X[1, a, b] += kb * (X[0, a, b] + target[1, a, b] - target[0, a, b] - X[1, a, b])
    for i in range(1, X.shape[0] - 1):
        j = i + 1
        for b in range(nb):
            rx = target[j, 0, b] - target[i, 0, b]  # rest segment i, world axes
            ry = target[j, 1, b] - target[i, 1, b]
            rz = target[j, 2, b] - target[i, 2, b]
            ax, ay, az = rest_dir[i, 0, b], rest_dir[i, 1, b], rest_dir[i, 2, b]
            cx = X[i, 0, b] - X[i - 1, 0, b]
            cy = X[i, 1, b] - X[i - 1, 1, b]
            cz = X[i, 2, b] - X[i - 1, 2, b]
            lc2 = cx * cx + cy * cy + cz * cz
            # a degenerate current or rest segment, or a pinned vertex: no move
            ok = (lc2 > _TINY * _TINY) & (ax * ax + ay * ay + az * az > 0.0) & (W[j, b] > 0.0)
            kb = k if ok else 0.0
            inv = 1.0 / math.sqrt(max(lc2, 1e-300))
            bx, by, bz = cx * inv, cy * inv, cz * inv
            c = ax * bx + ay * by + az * bz
            m = 1.0 if c > -1.0 + 1e-9 else 0.0  # opposite: no unique rotation, r kept
            vx = (ay * bz - az * by) * m
            vy = (az * bx - ax * bz) * m
            vz = (ax * by - ay * bx) * m
            f = m / (2.0 + c - m)  # 1 / (1 + c), or 0
            wx = vy * rz - vz * ry
            wy = vz * rx - vx * rz
            wz = vx * ry - vy * rx
            rx += wx + f * (vy * wz - vz * wy)
            ry += wy + f * (vz * wx - vx * wz)
            rz += wz + f * (vx * wy - vy * wx)
            row[0, b] = X[j, 0, b] + kb * (X[i, 0, b] + rx - X[j, 0, b])
            row[1, b] = X[j, 1, b] + kb * (X[i, 1, b] + ry - X[j, 1, b])
            row[2, b] = X[j, 2, b] + kb * (X[i, 2, b] + rz - X[j, 2, b])
        for a in range(3):
            for b in range(nb):
                X[j, a, b] = row[a, b]


@_jit
def global_shape_pass(X, W, target, k_profile, nb):
    """Move vertex i towards the skinned rest pose ``target`` by ``k_profile[i]``."""
    for i in range(1, X.shape[0]):
        k = k_profile[i]
        if k <= 0.0:
            continue
        for b in range(nb):
            kb = k if W[i, b] > 0.0 else 0.0
            X[i, 0, b] += kb * (target[i, 0, b] - X[i, 0, b])
            X[i, 1, b] += kb * (target[i, 1, b] - X[i, 1, b])
            X[i, 2, b] += kb * (target[i, 2, b] - X[i, 2, b])


@_jit
def hold_pass(X, W, target, k, nb):
    """Move vertex i of strand b towards the skinned rest pose ``target`` by ``k[i, b]``."""
    for i in range(1, X.shape[0]):
        for b in range(nb):
            kb = k[i, b] if W[i, b] > 0.0 else 0.0
            X[i, 0, b] += kb * (target[i, 0, b] - X[i, 0, b])
            X[i, 1, b] += kb * (target[i, 1, b] - X[i, 1, b])
            X[i, 2, b] += kb * (target[i, 2, b] - X[i, 2, b])
