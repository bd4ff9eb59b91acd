"""Solver: advances a State by one fixed substep (Le Muzic 2012 §5.1.2, Almeida 2014 §3.1.1).

One parallel kernel takes blocks of strands (vertex-major, strands innermost, see
:mod:`.constraints`) through a whole substep: pin the root to the skin,
integrate (Verlet, Le Muzic 2012 eq. 5.1, or semi-implicit Euler) under gravity and wind, with
drag taken implicitly and per-second damping, then ``iterations`` rounds of distance
(PBD) or none (DFTL), bending, shape matching and collisions, then for DFTL one
follow-the-leader pass (PBD: the strain limit), the cone limit, a last collision pass,
a settle pass that hangs segments the collisions stretched or crushed back at length,
root to tip, and the velocity update (with Almeida 2014 eq. 3.1's correction for DFTL and the
strain limit, and friction at contacts). Soft constraint stiffnesses are linearised over
the iterations, k' = 1 − (1 − k)^(1/n) (Le Muzic 2012 eq. 5.5); the shape stiffnesses
(local and global; TressFX's local and global shape constraints) are given for a
substep of SHAPE_SUBSTEP and keep their compliance at any other (:func:`per_substep`),
so a style sags alike at any substep; the hold, global shape matching that keeps a
groom's style, is given as a compliance per vertex (:func:`hold_compliance`).
A strand whose step would leave a non-finite value is put back as it was and reported.
"""

from __future__ import annotations

import math
from typing import NamedTuple, overload

import numpy as np

from ..arrays import FMA
from ..errors import SimulationError
from ..kernels import kernel, prange
from .collision import Colliders, collide
from .constraints import (
    bend_pass,
    cone_pass,
    distance_pass,
    follow_the_leader,
    global_shape_pass,
    hold_pass,
    local_shape_pass,
    rest_pose,
    strain_limit,
)
from .forces import acceleration
from .model import Model
from .settings import SimParams
from .state import State

__all__ = [
    "SHAPE_SUBSTEP",
    "STANDARD_GRAVITY",
    "Solver",
    "hold_compliance",
    "linearised",
    "per_substep",
]

# the substep the shape stiffnesses (shape_local, shape_global) are given
# for: [sim].substep's default. At another substep they keep their compliance (below)
SHAPE_SUBSTEP = 1 / 120


@overload
def linearised(k: float, iterations: int) -> float: ...
@overload
def linearised(k: np.ndarray, iterations: int) -> np.ndarray: ...
def linearised(k: float | np.ndarray, iterations: int) -> float | np.ndarray:
    """Le Muzic 2012 eq. 5.5: the per-iteration stiffness that gives ``k`` after ``iterations``."""
    return 1.0 - (1.0 - k) ** (1.0 / iterations)


@overload
def per_substep(k: float, substep: float) -> float: ...
@overload
def per_substep(k: np.ndarray, substep: float) -> float | np.ndarray: ...  # 0-d: a float
def per_substep(k: float | np.ndarray, substep: float) -> float | np.ndarray:
    """A shape stiffness ``k`` given for a substep of SHAPE_SUBSTEP, for a substep of
    ``substep`` s with the same compliance α (XPBD, Macklin et al. 2016: a soft
    constraint moves h² / (h² + α) of the way per substep), α = H² (1 − k) / k. A
    style then sags the same under gravity (by g α) and springs back at the same rate
    at any substep; per substep, k itself would sag (1 − k) g h² / k: 16× more at
    1/30 s than at 1/120 s. k at SHAPE_SUBSTEP, 0 and 1 stay as they are."""
    k = np.asarray(k, np.float64)
    if substep == SHAPE_SUBSTEP:
        return k if k.ndim else float(k)
    ratio = (substep / SHAPE_SUBSTEP) ** 2  # h² / H²
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(k > 0.0, k * ratio / (k * ratio + 1.0 - k), 0.0)
    return out if out.ndim else float(out)


STANDARD_GRAVITY = 9.80665  # m/s²: the gravity the style length is measured under


def hold_compliance(rest_length: np.ndarray, style_length: float) -> np.ndarray:
    """Each vertex's hold compliance α (S, N), s², from the strands' segment rest lengths
    (S, N − 1): the one that lets it sag, under STANDARD_GRAVITY, as far as a level
    cantilever (Euler–Bernoulli) bent under its own weight does at its arc length s,
    w(s) = s² (6L² − 4Ls + s²) / (30 ℓ³) for a strand of length L and the style length
    ℓ (``style_length``, m): a level strand ℓ long sags a tenth of ℓ at its tip, and the
    tip's sag over the length grows as (L / ℓ)³. Where the strand bends so, each vertex's
    pull towards its rest place, w / α, is its own weight: short styled strands stand,
    long ones fall and swing, at any vertex count (the compliance follows arc length,
    not vertices) and at any substep (XPBD, Macklin et al. 2016: a vertex sags g α)."""
    seg = rest_length.astype(np.float64)
    s = np.concatenate([np.zeros(seg.shape[:1] + (1,)), np.cumsum(seg, axis=1)], axis=1)
    length = s[:, -1:]
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):  # ℓ³ may underflow
        sag = s * s * (6.0 * length * length - 4.0 * length * s + s * s) / (30.0 * style_length**3)
    return np.where(s > 0.0, sag, 0.0) / STANDARD_GRAVITY  # inf: no hold there


BLOCK = 32  # strands per block: the inner loops run across them


@kernel(inline="always")
def _pin(roots0, frames0, roots1, frames1, f, s, b, root, frame):
    """Strand s's root and frame, into column b of ``root`` (3, B) / ``frame`` (3, 3, B),
    a fraction ``f`` of the way from pose 0 to pose 1: positions blended, the frame
    blended and made orthonormal again from its normal, keeping its handedness."""
    g = 1.0 - f
    nx = g * frames0[s, 2, 0] + f * frames1[s, 2, 0]
    ny = g * frames0[s, 2, 1] + f * frames1[s, 2, 1]
    nz = g * frames0[s, 2, 2] + f * frames1[s, 2, 2]
    n = math.sqrt(nx * nx + ny * ny + nz * nz)
    nx, ny, nz = nx / n, ny / n, nz / n
    tx = g * frames0[s, 0, 0] + f * frames1[s, 0, 0]
    ty = g * frames0[s, 0, 1] + f * frames1[s, 0, 1]
    tz = g * frames0[s, 0, 2] + f * frames1[s, 0, 2]
    d = tx * nx + ty * ny + tz * nz
    tx, ty, tz = tx - d * nx, ty - d * ny, tz - d * nz
    t = math.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = tx / t, ty / t, tz / t
    bx = ny * tz - nz * ty  # normal × tangent, turned to the side the blended binormal is
    by = nz * tx - nx * tz
    bz = nx * ty - ny * tx
    for a in range(3):
        root[a, b] = g * roots0[s, a] + f * roots1[s, a]
    hand = (
        (g * frames0[s, 1, 0] + f * frames1[s, 1, 0]) * bx
        + (g * frames0[s, 1, 1] + f * frames1[s, 1, 1]) * by
        + (g * frames0[s, 1, 2] + f * frames1[s, 1, 2]) * bz
    )
    sign = -1.0 if hand < 0.0 else 1.0
    frame[0, 0, b], frame[0, 1, b], frame[0, 2, b] = tx, ty, tz
    frame[1, 0, b], frame[1, 1, b], frame[1, 2, b] = sign * bx, sign * by, sign * bz
    frame[2, 0, b], frame[2, 1, b], frame[2, 2, b] = nx, ny, nz


@kernel(error_model="numpy", fastmath=FMA)
def _collide_pass(
    X,
    W,
    ref,
    gap2,
    contact,
    colliders,
    M,
    nb,
):
    """Push the free vertices out of the colliders grown by their margins ``M`` (N, B);
    contact normals into ``contact``. A
    vertex still within ``gap`` of where it was last found clear (``ref``) cannot have
    reached a collider and is not looked up again."""
    if colliders.shapes.shape[0] == 0 and colliders.sdf_values.size == 0:
        return
    far = np.empty(X.shape[2])
    todo = np.empty(X.shape[2], np.int64)
    for i in range(1, X.shape[0]):
        looks = -math.inf
        for b in range(nb):  # branch-free, so it vectorises: which vertices may touch
            dx = X[i, 0, b] - ref[i, 0, b]
            dy = X[i, 1, b] - ref[i, 1, b]
            dz = X[i, 2, b] - ref[i, 2, b]
            far[b] = (dx * dx + dy * dy + dz * dz - gap2[i, b]) * W[i, b]
            looks = max(looks, far[b])
        if looks < 0.0:
            continue
        count = 0  # the free vertices that may touch, listed without a branch …
        for b in range(nb):
            todo[count] = b
            count += (far[b] >= 0.0) & (W[i, b] > 0.0)
        for q in range(count):  # … so the loop over them mispredicts no skip
            b = todo[q]
            px, py, pz, nx, ny, nz, hit, gap = collide(
                X[i, 0, b],
                X[i, 1, b],
                X[i, 2, b],
                colliders,
                M[i, b],
            )
            X[i, 0, b], X[i, 1, b], X[i, 2, b] = px, py, pz
            ref[i, 0, b], ref[i, 1, b], ref[i, 2, b] = px, py, pz
            gap2[i, b] = gap * gap / 3.0  # see collide: the SDF may fall √3× faster
            if hit:
                contact[i, 0, b], contact[i, 1, b], contact[i, 2, b] = nx, ny, nz


SETTLE_FROM = (
    1e-4  # relative stretch from which the settle pass moves a vertex (docs: How-to › Dynamics)
)


@kernel(inline="always")
def _hang(
    px,
    py,
    pz,
    ux,
    uy,
    uz,
    length,
    colliders,
    margin,
):
    """A child hung ``length`` from its parent p along the unit u, out of the colliders
    grown by ``margin`` as far as that length allows: ``collide``'s (x, y, z, nx, ny, nz,
    hit, clearance). Where the push out would shorten or lengthen the segment (u points
    into the collider), u is first turned within the plane of u and the contact normal
    n, just enough that the child lies on the contact's tangent plane (u·n ≥ −height of
    p above it / length); what the surface's curvature (or the SDF's interpolation)
    still pushes, and a parent too deep below the grown surface for any turn, leaves
    the child pushed, then put back at ``length`` on the line from p: the segment is
    exact and the child at most a second-order sliver inside the margin (the skin's own
    surface lies a margin further), which the next substep's collision pass takes."""
    cx, cy, cz = px + length * ux, py + length * uy, pz + length * uz
    qx, qy, qz, nx, ny, nz, hit, gap = collide(cx, cy, cz, colliders, margin)
    if not hit:
        return qx, qy, qz, nx, ny, nz, hit, gap
    need = -((px - qx) * nx + (py - qy) * ny + (pz - qz) * nz) / length
    un = ux * nx + uy * ny + uz * nz
    tx, ty, tz = ux - un * nx, uy - un * ny, uz - un * nz
    t = math.sqrt(tx * tx + ty * ty + tz * tz)
    if un < need < 1.0 and t >= 1e-9:  # a turn onto the tangent plane reaches out
        s = math.sqrt(1.0 - need * need) / t
        ux, uy, uz = need * nx + s * tx, need * ny + s * ty, need * nz + s * tz
        cx, cy, cz = px + length * ux, py + length * uy, pz + length * uz
        qx, qy, qz, mx, my, mz, again, gap = collide(cx, cy, cz, colliders, margin)
        if again:
            nx, ny, nz = mx, my, mz
    dx, dy, dz = qx - px, qy - py, qz - pz
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    if d > 1e-12:  # back at length along p → q
        qx, qy, qz = px + length * dx / d, py + length * dy / d, pz + length * dz / d
    return qx, qy, qz, nx, ny, nz, True, 0.0


@kernel(error_model="numpy", fastmath=FMA)
def _settle_pass(
    X,
    W,
    L,
    limit,
    ref,
    gap2,
    contact,
    colliders,
    M,
    nb,
):
    """After the last collision pass, root to tip: a segment that the collisions left
    outside (1 ± ``limit``) × rest (and by more than SETTLE_FROM: the collisions' slight
    pushes are left to the next substep's constraints, which cost no lookup) has its
    child hung back at that length from its settled parent and out of the colliders
    (:func:`_hang`). Too short counts as much as too long: a push out along the normal
    shortens a segment that points into the skin, and the distance constraints fighting
    the pushes crush their neighbours (10 g into the scalp: 32 %). The parent is final
    when its child is handled (follow-the-leader order, Almeida 2014 §3.1.1), so pushes out of
    the skin no longer add up into stretched or crushed segments, and every vertex still
    ends outside the colliders and their margins."""
    if colliders.shapes.shape[0] == 0 and colliders.sdf_values.size == 0:
        return  # nothing pushed after the lengths were set
    over = np.empty(X.shape[2])
    for i in range(1, X.shape[0]):
        worst = -math.inf
        for b in range(nb):  # branch-free, so it vectorises: is any segment of row i off?
            dx = X[i, 0, b] - X[i - 1, 0, b]
            dy = X[i, 1, b] - X[i - 1, 1, b]
            dz = X[i, 2, b] - X[i - 1, 2, b]
            l2 = dx * dx + dy * dy + dz * dz
            most = (1.0 + max(limit, SETTLE_FROM)) * L[i - 1, b]
            least = (1.0 - max(limit, SETTLE_FROM)) * L[i - 1, b]
            over[b] = max(l2 - most * most, least * least - l2) * W[i, b]
            worst = max(worst, over[b])
        if worst <= 0.0:
            continue
        for b in range(nb):
            if over[b] <= 0.0:
                continue
            dx = X[i, 0, b] - X[i - 1, 0, b]
            dy = X[i, 1, b] - X[i - 1, 1, b]
            dz = X[i, 2, b] - X[i - 1, 2, b]
            length = math.sqrt(dx * dx + dy * dy + dz * dz)
            if length < 1e-12:  # coincident: nowhere to hang it from
                continue
            rest = min(max(length, (1.0 - limit) * L[i - 1, b]), (1.0 + limit) * L[i - 1, b])
            px, py, pz, nx, ny, nz, hit, gap = _hang(
                X[i - 1, 0, b],
                X[i - 1, 1, b],
                X[i - 1, 2, b],
                dx / length,
                dy / length,
                dz / length,
                rest,
                colliders,
                M[i, b],
            )
            X[i, 0, b], X[i, 1, b], X[i, 2, b] = px, py, pz
            ref[i, 0, b], ref[i, 1, b], ref[i, 2, b] = px, py, pz
            gap2[i, b] = gap * gap / 3.0
            if hit:
                contact[i, 0, b], contact[i, 1, b], contact[i, 2, b] = nx, ny, nz


class Strands(NamedTuple):
    """A Model's per-strand data as the substep kernel reads it: per-vertex arrays in
    the block layout of :func:`_blocked` (inverse masses, rest lengths, rest shape in
    the root frame, bending rest, collision margins, the hold's per-iteration stiffness)
    and per-strand rows (the static point and the first segment's direction in the root
    frame)."""

    w: np.ndarray
    rest_length: np.ndarray
    rest_local: np.ndarray
    bend_rest: np.ndarray
    margin: np.ndarray
    hold: np.ndarray
    static_local: np.ndarray
    root_direction: np.ndarray


class Constants(NamedTuple):
    """The substep kernel's parameters that stay fixed while a SimParams does: made once
    from it by :meth:`Solver.constants` (stiffnesses linearised, Le Muzic 2012 eq. 5.5)."""

    dt: float  # the substep, s
    damp: float  # velocity kept per substep, exp(−damping · dt)
    euler: bool  # semi-implicit Euler, else Verlet
    dftl: bool  # Dynamic Follow-The-Leader, else PBD distances
    iterations: int
    gravity: np.ndarray  # (3,) m/s²
    turbulence: float
    frequency: float
    drag: float
    k_stretch: float
    k_bend: float
    bend_scale: float
    attenuation: float
    k_local: float
    k_global: np.ndarray  # (N,) root to tip
    cos_limit: float  # the cone limit's cosine; −2 for none
    sin_limit: float
    dftl_damping: float
    stretch_limit: float  # −1 for none
    limit_damping: float
    friction: float
    hold: bool  # the hold is on (its stiffness is per vertex, in Strands)


@kernel(parallel=True, error_model="numpy", fastmath=FMA)
def _substep_kernel(
    x, v, clear, model, start, end, f, wind, scroll, shift, c, colliders, energy, bad
):
    """One substep of every strand (see the module's docstring): state ``x``, ``v``,
    ``clear`` (S, N, …) in place, the ``model``'s :class:`Strands` with the
    :class:`Constants` ``c``, roots pinned a fraction ``f`` of the way from the pose
    ``start`` to ``end`` (roots, frames), under ``wind`` (3,) with the noise at
    ``scroll``, colliders that moved at most ``shift`` (m); ``energy`` and ``bad`` out,
    per strand."""
    w, rest_length, rest_local, bend_rest, margin, k_hold, static_local, root_direction = model
    roots0, frames0 = start
    roots1, frames1 = end
    (
        dt,
        damp,
        euler,
        dftl,
        iterations,
        gravity,
        turbulence,
        frequency,
        drag,
        k_stretch,
        k_bend,
        bend_scale,
        attenuation,
        k_local,
        k_global,
        cos_limit,
        sin_limit,
        dftl_damping,
        stretch_limit,
        limit_damping,
        friction,
        hold,
    ) = c
    strands, n = x.shape[0], x.shape[1]
    shape = k_local > 0.0 or k_global[1] > 0.0 or hold
    correct = dftl or stretch_limit >= 0.0  # Almeida 2014 eq. 3.1 applies
    correction = dftl_damping if dftl else limit_damping
    windy = wind[0] != 0.0 or wind[1] != 0.0 or wind[2] != 0.0
    for block in prange((strands + BLOCK - 1) // BLOCK):
        s0 = block * BLOCK
        nb = min(BLOCK, strands - s0)
        X = np.empty((n, 3, BLOCK))  # positions now
        X0 = np.empty((n, 3, BLOCK))  # … and at the start of the substep
        V0 = np.empty((n, 3, BLOCK))  # velocities at the start
        V = np.empty((n, 3, BLOCK))  # … and at the end
        corr = np.zeros((n, 3, BLOCK))
        contact = np.zeros((n, 3, BLOCK))
        target = np.empty((n, 3, BLOCK))
        rest_dir = np.empty((n, 3, BLOCK))
        ref = np.empty((n, 3, BLOCK))  # where each vertex was last found clear …
        gap2 = np.empty((n, BLOCK))  # … and how far (squared) it may move from there
        W, L, R, M, K = w[block], rest_length[block], bend_rest[block], margin[block], k_hold[block]
        root = np.empty((3, BLOCK))
        frame = np.empty((3, 3, BLOCK))
        static = np.empty((3, BLOCK))
        first = np.empty((3, BLOCK))
        moved = np.zeros(BLOCK)
        row = np.empty((3, BLOCK))  # one row of X on its way in (see .constraints)
        for b in range(nb):  # gather the block, vertex-major
            s = s0 + b
            for i in range(n):
                allow = clear[s, i] - shift  # the colliders' own move eats into it
                gap2[i, b] = allow * allow if allow > 0.0 else -1.0
                for a in range(3):
                    X[i, a, b] = X0[i, a, b] = ref[i, a, b] = x[s, i, a]
                    V0[i, a, b] = v[s, i, a]
            _pin(roots0, frames0, roots1, frames1, f, s, b, root, frame)
            sl, d = static_local[s], root_direction[s]
            for a in range(3):
                X[0, a, b] = root[a, b]
                static[a, b] = (
                    root[a, b]
                    + sl[0] * frame[0, a, b]
                    + sl[1] * frame[1, a, b]
                    + sl[2] * frame[2, a, b]
                )
                first[a, b] = d[0] * frame[0, a, b] + d[1] * frame[1, a, b] + d[2] * frame[2, a, b]
        # drag −b·v (Le Muzic 2012 eq. 5.3), implicit (backward Euler): v' = (v + a dt) / (1 + b dt)
        # damps towards the terminal speed a / b for any b; explicit, v' = v + (a − b v) dt,
        # overshoots and flips the velocity once b dt > 2 (b = 1000 /s stretched hair 1,900 %)
        h = dt / (1.0 + drag * dt)  # the step × 1 / (1 + b dt)
        for i in range(1, n):  # integrate
            for b in range(nb):
                m = 1.0 if W[i, b] > 0.0 else 0.0  # pinned vertices stay
                ax, ay, az = gravity[0], gravity[1], gravity[2]
                if windy:  # the tangent the wind acts across (Le Muzic 2012 eq. 5.2)
                    tx = X0[i, 0, b] - X0[i - 1, 0, b]
                    ty = X0[i, 1, b] - X0[i - 1, 1, b]
                    tz = X0[i, 2, b] - X0[i - 1, 2, b]
                    tl = math.sqrt(tx * tx + ty * ty + tz * tz)
                    if tl > 0.0:
                        tx, ty, tz = tx / tl, ty / tl, tz / tl
                    ax, ay, az = acceleration(
                        X0[i, 0, b],
                        X0[i, 1, b],
                        X0[i, 2, b],
                        tx,
                        ty,
                        tz,
                        gravity,
                        wind,
                        turbulence,
                        frequency,
                        scroll,
                    )
                vx, vy, vz = V0[i, 0, b], V0[i, 1, b], V0[i, 2, b]
                if euler:  # v ← (v + a dt) damped, x ← x + v dt
                    X[i, 0, b] += m * (vx + ax * dt) * damp * h
                    X[i, 1, b] += m * (vy + ay * dt) * damp * h
                    X[i, 2, b] += m * (vz + az * dt) * damp * h
                else:  # Le Muzic 2012 eq. 5.1: P = 2P⁻¹ − P⁻² + a Δt², implicit velocity damped
                    X[i, 0, b] += m * (vx * damp + ax * dt) * h
                    X[i, 1, b] += m * (vy * damp + ay * dt) * h
                    X[i, 2, b] += m * (vz * damp + az * dt) * h
        if shape:
            rest_pose(root, frame, rest_local[block], target, rest_dir, nb)
        for _ in range(iterations):
            if not dftl:
                distance_pass(X, W, L, k_stretch, row, nb)
            if k_bend > 0.0:
                bend_pass(X, W, static, R, bend_scale, k_bend, attenuation, nb)
            if k_local > 0.0:
                local_shape_pass(X, W, target, rest_dir, k_local, row, nb)
            if k_global[1] > 0.0:  # the profile never rises towards the tip
                global_shape_pass(X, W, target, k_global, nb)
            if hold:
                hold_pass(X, W, target, K, nb)
            _collide_pass(
                X,
                W,
                ref,
                gap2,
                contact,
                colliders,
                M,
                nb,
            )
        if dftl:
            follow_the_leader(X, L, corr, row, nb)
        elif stretch_limit >= 0.0:
            strain_limit(X, W, L, 0.5 * stretch_limit, corr, row, nb)
        if cos_limit > -1.0:
            cone_pass(X, L, cos_limit, sin_limit, first, nb)
        contact[:] = 0.0  # only the last pass's contacts get friction
        _collide_pass(
            X,
            W,
            ref,
            gap2,
            contact,
            colliders,
            M,
            nb,
        )  # collisions are hard: last
        if dftl or stretch_limit >= 0.0:  # … and lengths are settled around them
            _settle_pass(
                X,
                W,
                L,
                0.0 if dftl else 0.5 * stretch_limit,
                ref,
                gap2,
                contact,
                colliders,
                M,
                nb,
            )
        keep = 1.0 - friction
        for i in range(n):  # velocities from the moves
            fix = correction / dt if correct and 0 < i < n - 1 else 0.0  # Almeida 2014 eq. 3.1
            j = min(i + 1, n - 1)
            for b in range(nb):
                vx = (X[i, 0, b] - X0[i, 0, b]) / dt
                vy = (X[i, 1, b] - X0[i, 1, b]) / dt
                vz = (X[i, 2, b] - X0[i, 2, b]) / dt
                moved[b] += (vx * vx + vy * vy + vz * vz) if W[i, b] > 0.0 else 0.0
                vx -= fix * corr[j, 0, b]
                vy -= fix * corr[j, 1, b]
                vz -= fix * corr[j, 2, b]
                # in contact (n ≠ 0): no speed into the collider, tangential speed × keep
                nx, ny, nz = contact[i, 0, b], contact[i, 1, b], contact[i, 2, b]
                vn = vx * nx + vy * ny + vz * nz
                touching = nx != 0.0 or ny != 0.0 or nz != 0.0
                t = keep if touching else 1.0
                r = max(vn, 0.0) - t * vn if touching else 0.0
                V[i, 0, b] = r * nx + t * vx
                V[i, 1, b] = r * ny + t * vy
                V[i, 2, b] = r * nz + t * vz
        ok = np.ones(BLOCK, np.bool_)
        for i in range(n):
            for a in range(3):
                for b in range(nb):
                    ok[b] &= math.isfinite(X[i, a, b]) & math.isfinite(V[i, a, b])
        for i in range(n):  # the allowance left after this substep (-1: unknown)
            for b in range(nb):
                dx = X[i, 0, b] - ref[i, 0, b]
                dy = X[i, 1, b] - ref[i, 1, b]
                dz = X[i, 2, b] - ref[i, 2, b]
                g = gap2[i, b]
                left = math.sqrt(max(g, 0.0)) - math.sqrt(dx * dx + dy * dy + dz * dz)
                gap2[i, b] = left if g >= 0.0 else -1.0
        for b in range(nb):  # scatter back, or keep the old state where anything blew up
            s = s0 + b
            src_x, src_v = (X, V) if ok[b] else (X0, V0)
            for i in range(n):
                for a in range(3):
                    x[s, i, a] = src_x[i, a, b]
                    v[s, i, a] = src_v[i, a, b]
                clear[s, i] = gap2[i, b] if ok[b] else -1.0
            energy[s] = 0.5 * moved[b] if ok[b] else 0.0
            bad[s] = 0 if ok[b] else 1


def _blocked(a: np.ndarray, vertices: int) -> np.ndarray:
    """Per-vertex strand data (S, M, …), M ≤ ``vertices``, in the kernel's block layout
    (blocks, N, …, BLOCK): strands innermost, padded with zeros (missing vertices and the
    last block's missing strands), so a block reads its rows as contiguous vectors."""
    s, m = a.shape[:2]
    blocks = (s + BLOCK - 1) // BLOCK
    out = np.zeros((blocks * BLOCK, vertices) + a.shape[2:], a.dtype)
    out[:s, :m] = a
    out = out.reshape((blocks, BLOCK) + out.shape[1:])
    return np.ascontiguousarray(np.moveaxis(out, 1, -1))


class Solver:
    """Runs substeps of a Model's strands with one set of parameters (a SimParams)."""

    def __init__(
        self, model: Model, params: SimParams, rest_clearance: np.ndarray | None = None
    ) -> None:
        """``rest_clearance`` (S, N): each vertex's distance from the colliders at rest
        (negative inside): a vertex groomed nearer than the margin keeps that nearness as
        its margin, so the rest pose is never pushed (nor stretched) by collisions."""
        self.model = model
        self.params = params
        self.rest_clearance = rest_clearance
        n = model.vertices
        self._static = tuple(
            _blocked(a, n)
            for a in (model.inv_mass, model.rest_length, model.rest_local, model.bend_rest)
        )
        self.energy = np.zeros(model.strands)  # ½ Σ |Δx / dt|² per strand, last substep
        self._bad = np.zeros(model.strands, np.uint8)
        self._for: SimParams | None = None  # the params the constants were made for

    def global_profile(self) -> np.ndarray:
        """Per-vertex global shape stiffness (linearised): full up to the range start,
        falling linearly to 0 at its end, root to tip."""
        p = self.params
        t = np.linspace(0.0, 1.0, self.model.vertices)
        start, end = p.shape_global_range
        fade = np.clip((end - t) / max(end - start, 1e-9), 0.0, 1.0)
        k = per_substep(p.shape_global * np.where(t <= start, 1.0, fade), p.substep)
        assert isinstance(k, np.ndarray)  # (N,): only a 0-d array comes back as a float
        return linearised(k, p.iterations)

    def hold_profile(self) -> np.ndarray:
        """Per-vertex hold stiffness (S, N), linearised: the compliance of
        :func:`hold_compliance` for ``shape_hold`` as the style length, per substep
        (k = h² / (h² + α)); zero where the hold is off (``shape_hold`` = 0)."""
        p = self.params
        if p.shape_hold <= 0.0:
            return np.zeros((self.model.strands, self.model.vertices))
        h2 = p.substep * p.substep
        k = h2 / (h2 + hold_compliance(self.model.rest_length, p.shape_hold))
        return linearised(k, p.iterations)

    def constants(self) -> tuple[Strands, Constants]:
        """The kernel's strands and constants for ``params`` (made again only when the
        params object changes; params cannot change in place, so they cannot go stale)."""
        p = self.params
        if self._for is not p:
            n = p.iterations
            cone = math.radians(p.cone_angle)
            self._constants = Constants(
                dt=p.substep,
                damp=math.exp(-p.damping * p.substep),
                euler=p.integrator == "euler",
                dftl=p.solver == "dftl",
                iterations=n,
                gravity=np.asarray(p.gravity, np.float64),
                turbulence=p.wind_turbulence,
                frequency=p.wind_frequency,
                drag=p.drag,
                k_stretch=linearised(p.stretch_stiffness, n),
                k_bend=linearised(p.bend_stiffness, n),
                bend_scale=p.bend_scale,
                attenuation=p.bend_attenuation,
                k_local=linearised(per_substep(p.shape_local, p.substep), n),
                k_global=self.global_profile(),
                cos_limit=math.cos(cone) if p.cone_angle < 180 else -2.0,
                sin_limit=math.sin(cone),
                dftl_damping=p.dftl_damping,
                stretch_limit=-1.0 if p.stretch_limit is None else p.stretch_limit,
                limit_damping=p.stretch_limit_damping,
                friction=p.friction,
                hold=p.shape_hold > 0.0,
            )
            m = self.model
            margin = np.full(m.rest_length.shape[:1] + (m.vertices,), p.collision_margin)
            if self.rest_clearance is not None:
                np.minimum(margin, self.rest_clearance, out=margin)
            w, length, local, bend = self._static
            self._strands = Strands(
                w,
                length,
                local,
                bend,
                _blocked(margin, m.vertices),
                _blocked(self.hold_profile(), m.vertices),
                m.static_local,
                m.root_direction,
            )
            self._for = p
        return self._strands, self._constants

    def substep(
        self,
        state: State,
        start: tuple[np.ndarray, np.ndarray],
        end: tuple[np.ndarray, np.ndarray],
        f: float,
        wind: np.ndarray,
        colliders: Colliders,
        moved: float = math.inf,
    ) -> None:
        """Advance ``state`` by one substep with the roots pinned a fraction ``f`` of the
        way from ``start`` to ``end`` (each (roots (S, 3), frames (S, 3, 3))), under
        ``wind`` (3,) now, against ``colliders`` (:class:`~.collision.Colliders`), whose
        surfaces moved at most ``moved`` (m) since the last substep (inf: unknown, every
        vertex is looked up again)."""
        p = self.params
        strands, constants = self.constants()
        scroll = np.asarray(p.wind_drift, np.float64) * state.time * p.wind_frequency
        _substep_kernel(
            state.x,
            state.v,
            state.clear,
            strands,
            start,
            end,
            f,
            wind,
            scroll,
            moved,
            constants,
            colliders,
            self.energy,
            self._bad,
        )
        if self._bad.any():
            raise SimulationError(
                f"simulation: {int(self._bad.sum())} strand(s) would get NaN or inf at"
                f" t = {state.time:.4f} s (kept as they were); lower [sim].substep"
                f" (now {p.substep:g} s), wind ({p.wind}) or drag ({p.drag}), or raise"
                f" [sim].iterations (now {p.iterations})"
            )
        state.time += p.substep
