"""Solver: advances a State by one fixed substep (002 §5.1.2, 001 §3.1.1).

One parallel kernel does a whole strand per iteration: pin the root to the skin,
integrate (Verlet, 002 eq. 5.1, or semi-implicit Euler) under gravity, wind and drag
with per-second damping, then ``iterations`` rounds of distance (PBD) or none (DFTL),
bending, shape matching and collisions, then for DFTL one follow-the-leader pass, the
cone limit, a last collision pass, and the velocity update (with 001 eq. 3.1's
correction for DFTL and friction at contacts). Soft constraint stiffnesses are
linearised over the iterations, k' = 1 − (1 − k)^(1/n) (002 eq. 5.5). A strand whose
step would leave a non-finite value is put back as it was and reported.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..errors import InputError
from .collision import collide
from .constraints import (
    bend_pass,
    cone_pass,
    distance_pass,
    follow_the_leader,
    global_shape_pass,
    local_shape_pass,
    rest_pose,
    skinned,
    strain_limit,
)
from .forces import acceleration
from .model import Model
from .state import State

__all__ = ["Solver", "linearised"]


def linearised(k: float | np.ndarray, iterations: int) -> float | np.ndarray:
    """002 eq. 5.5: the per-iteration stiffness that gives ``k`` after ``iterations``."""
    return 1.0 - (1.0 - k) ** (1.0 / iterations)


_CHUNK = 64  # strands per task: each task allocates its scratch rows once


@njit(cache=True, inline="always")
def _pin(roots0, frames0, roots1, frames1, f, s, root, frame):
    """``root``/``frame`` of strand s a fraction ``f`` of the way from pose 0 to pose 1:
    positions blended, the frame blended and made orthonormal again from its normal."""
    g = 1.0 - f
    for a in range(3):
        root[a] = g * roots0[s, a] + f * roots1[s, a]
        frame[2, a] = g * frames0[s, 2, a] + f * frames1[s, 2, a]
        frame[0, a] = g * frames0[s, 0, a] + f * frames1[s, 0, a]
    n = math.sqrt(frame[2, 0] ** 2 + frame[2, 1] ** 2 + frame[2, 2] ** 2)
    for a in range(3):
        frame[2, a] /= n
    d = frame[0, 0] * frame[2, 0] + frame[0, 1] * frame[2, 1] + frame[0, 2] * frame[2, 2]
    for a in range(3):
        frame[0, a] -= d * frame[2, a]
    t = math.sqrt(frame[0, 0] ** 2 + frame[0, 1] ** 2 + frame[0, 2] ** 2)
    for a in range(3):
        frame[0, a] /= t
    frame[1, 0] = frame[2, 1] * frame[0, 2] - frame[2, 2] * frame[0, 1]  # normal × tangent
    frame[1, 1] = frame[2, 2] * frame[0, 0] - frame[2, 0] * frame[0, 2]
    frame[1, 2] = frame[2, 0] * frame[0, 1] - frame[2, 1] * frame[0, 0]


@njit(cache=True)
def _collide_pass(x, w, s, ref, gap2, contact, spheres, capsules, sdf_values, sdf_origin,
                  sdf_inv_voxel, sdf_lfw, margin):  # fmt: skip
    """Push strand s's free vertices out of the colliders; contact normals into
    ``contact``. A vertex still within ``gap`` of where it was last found clear
    (``ref``) cannot have reached a collider and is not looked up again."""
    if spheres.shape[0] == 0 and capsules.shape[0] == 0 and sdf_values.size == 0:
        return
    for i in range(1, x.shape[1]):
        if w[s, i] == 0.0:
            continue
        dx = x[s, i, 0] - ref[i, 0]
        dy = x[s, i, 1] - ref[i, 1]
        dz = x[s, i, 2] - ref[i, 2]
        if dx * dx + dy * dy + dz * dz < gap2[i]:
            continue
        px, py, pz, nx, ny, nz, hit, gap = collide(
            x[s, i, 0], x[s, i, 1], x[s, i, 2], spheres, capsules, sdf_values, sdf_origin,
            sdf_inv_voxel, sdf_lfw, margin,
        )  # fmt: skip
        x[s, i, 0], x[s, i, 1], x[s, i, 2] = px, py, pz
        ref[i, 0], ref[i, 1], ref[i, 2] = px, py, pz
        gap2[i] = gap * gap
        if hit:
            contact[i, 0], contact[i, 1], contact[i, 2] = nx, ny, nz


@njit(cache=True, parallel=True)
def _substep_kernel(x, v, w, rest_length, rest_local, bend_rest, static_local, root_direction,
                    roots0, frames0, roots1, frames1, f, dt, damp, euler, dftl, iterations,
                    gravity, wind, turbulence, frequency, scroll, drag, k_stretch, k_bend,
                    bend_scale, attenuation, k_local, k_global, cos_limit, sin_limit,
                    dftl_damping, stretch_limit, limit_damping, spheres, capsules, sdf_values,
                    sdf_origin, sdf_inv_voxel, sdf_lfw, margin, friction, energy,
                    bad):  # fmt: skip
    strands, n = x.shape[0], x.shape[1]
    for chunk in prange((strands + _CHUNK - 1) // _CHUNK):
        x_old = np.empty((n, 3))
        v_old = np.empty((n, 3))
        corr = np.zeros((n, 3))
        contact = np.empty((n, 3))
        target = np.empty((n, 3))
        rest_dir = np.empty((n, 3))
        ref = np.empty((n, 3))
        gap2 = np.empty(n)
        root = np.empty(3)
        frame = np.empty((3, 3))
        for s in range(chunk * _CHUNK, min(strands, (chunk + 1) * _CHUNK)):
            for i in range(n):
                gap2[i] = -1.0  # look every vertex up once
                for a in range(3):
                    x_old[i, a] = x[s, i, a]
                    v_old[i, a] = v[s, i, a]
                    contact[i, a] = 0.0
            _pin(roots0, frames0, roots1, frames1, f, s, root, frame)
            for a in range(3):
                v[s, 0, a] = (root[a] - x[s, 0, a]) / dt
                x[s, 0, a] = root[a]
            for i in range(1, n):  # integrate
                if w[s, i] == 0.0:
                    continue
                tx = x_old[i, 0] - x_old[i - 1, 0]
                ty = x_old[i, 1] - x_old[i - 1, 1]
                tz = x_old[i, 2] - x_old[i - 1, 2]
                tl = math.sqrt(tx * tx + ty * ty + tz * tz)
                if tl > 0.0:
                    tx, ty, tz = tx / tl, ty / tl, tz / tl
                vx, vy, vz = v[s, i, 0], v[s, i, 1], v[s, i, 2]
                ax, ay, az = acceleration(x_old[i, 0], x_old[i, 1], x_old[i, 2], tx, ty, tz,
                                          vx, vy, vz, gravity, wind, turbulence, frequency,
                                          scroll, drag)  # fmt: skip
                if euler:  # v ← (v + a dt) damped, x ← x + v dt
                    vx, vy, vz = (vx + ax * dt) * damp, (vy + ay * dt) * damp, (vz + az * dt) * damp
                    x[s, i, 0] += vx * dt
                    x[s, i, 1] += vy * dt
                    x[s, i, 2] += vz * dt
                else:  # 002 eq. 5.1: P = P⁻¹ + (P⁻¹ − P⁻²) + a Δt², the implicit velocity damped
                    x[s, i, 0] += vx * dt * damp + ax * dt * dt
                    x[s, i, 1] += vy * dt * damp + ay * dt * dt
                    x[s, i, 2] += vz * dt * damp + az * dt * dt
            static = skinned(root, frame, static_local[s:s + 1], 0)
            if k_local > 0.0 or k_global[1] > 0.0:
                rest_pose(root, frame, rest_local[s], target, rest_dir)
            for _ in range(iterations):
                if not dftl:
                    distance_pass(x, w, rest_length, s, k_stretch)
                if k_bend > 0.0:
                    bend_pass(x, w, s, static, bend_rest, bend_scale, k_bend, attenuation)
                if k_local > 0.0:
                    local_shape_pass(x, w, s, target, rest_dir, k_local)
                if k_global[1] > 0.0:  # the profile never rises towards the tip
                    global_shape_pass(x, w, s, target, k_global)
                _collide_pass(x, w, s, ref, gap2, contact, spheres, capsules, sdf_values,
                              sdf_origin, sdf_inv_voxel, sdf_lfw, margin)  # fmt: skip
            if dftl:
                follow_the_leader(x, s, rest_length, corr)
            elif stretch_limit >= 0.0:
                strain_limit(x, w, s, rest_length, 0.5 * stretch_limit, corr)
            if cos_limit > -1.0:
                d = root_direction[s]
                fx = d[0] * frame[0, 0] + d[1] * frame[1, 0] + d[2] * frame[2, 0]
                fy = d[0] * frame[0, 1] + d[1] * frame[1, 1] + d[2] * frame[2, 1]
                fz = d[0] * frame[0, 2] + d[1] * frame[1, 2] + d[2] * frame[2, 2]
                cone_pass(x, s, cos_limit, sin_limit, fx, fy, fz)
            for i in range(n):  # only the last pass's contacts get friction
                contact[i, 0] = contact[i, 1] = contact[i, 2] = 0.0
            _collide_pass(x, w, s, ref, gap2, contact, spheres, capsules, sdf_values,
                          sdf_origin, sdf_inv_voxel, sdf_lfw, margin)  # collisions are hard: last
            ok = True
            correction = dftl_damping if dftl else limit_damping
            moved = 0.0
            for i in range(1, n):  # velocities from the moves
                for a in range(3):
                    va = (x[s, i, a] - x_old[i, a]) / dt
                    if w[s, i] > 0.0:
                        moved += va * va
                    if (dftl or stretch_limit >= 0.0) and i < n - 1:  # 001 eq. 3.1
                        va -= correction * corr[i + 1, a] / dt
                    v[s, i, a] = va
                nx, ny, nz = contact[i, 0], contact[i, 1], contact[i, 2]
                if nx != 0.0 or ny != 0.0 or nz != 0.0:  # in contact: no inward speed, friction
                    vn = v[s, i, 0] * nx + v[s, i, 1] * ny + v[s, i, 2] * nz
                    keep = max(vn, 0.0)
                    v[s, i, 0] = keep * nx + (1.0 - friction) * (v[s, i, 0] - vn * nx)
                    v[s, i, 1] = keep * ny + (1.0 - friction) * (v[s, i, 1] - vn * ny)
                    v[s, i, 2] = keep * nz + (1.0 - friction) * (v[s, i, 2] - vn * nz)
                for a in range(3):
                    if not (math.isfinite(x[s, i, a]) and math.isfinite(v[s, i, a])):
                        ok = False
            energy[s] = 0.5 * moved
            if not ok:
                for i in range(n):
                    for a in range(3):
                        x[s, i, a] = x_old[i, a]
                        v[s, i, a] = v_old[i, a]
            bad[s] = 0 if ok else 1


class Solver:
    """Runs substeps of a Model's strands with one set of parameters (a SimParams)."""

    def __init__(self, model: Model, params: object) -> None:
        self.model = model
        self.params = params
        self.energy = np.zeros(model.strands)  # ½ Σ |Δx / dt|² per strand, last substep
        self._bad = np.zeros(model.strands, np.uint8)
        self._for: object = None  # the params _constants were made for

    def global_profile(self) -> np.ndarray:
        """Per-vertex global shape stiffness (linearised): full up to the range start,
        falling linearly to 0 at its end, root to tip."""
        p = self.params
        t = np.linspace(0.0, 1.0, self.model.vertices)
        start, end = p.shape_global_range
        fade = np.clip((end - t) / max(end - start, 1e-9), 0.0, 1.0)
        return linearised(p.shape_global * np.where(t <= start, 1.0, fade), p.iterations)

    def _constants(self) -> tuple:
        """The kernel's parameters that stay fixed while ``params`` does (made once)."""
        p = self.params
        if self._for is not p:
            n = p.iterations
            cone = math.radians(p.cone_angle)
            self._kept = (
                math.exp(-p.damping * p.substep), p.integrator == "euler", p.solver == "dftl",
                n, np.asarray(p.gravity, np.float64),
            ), (
                p.wind_turbulence, p.wind_frequency,
            ), (
                p.drag, linearised(p.stretch_stiffness, n), linearised(p.bend_stiffness, n),
                p.bend_scale, p.bend_attenuation, linearised(p.shape_local, n),
                self.global_profile(), math.cos(cone) if p.cone_angle < 180 else -2.0,
                math.sin(cone), p.dftl_damping,
                -1.0 if p.stretch_limit is None else p.stretch_limit, p.stretch_limit_damping,
            )  # fmt: skip
            self._for = p
        return self._kept

    def substep(self, state: State, start: tuple[np.ndarray, np.ndarray],
                end: tuple[np.ndarray, np.ndarray], f: float, wind: np.ndarray,
                colliders: tuple[np.ndarray, np.ndarray, tuple]) -> None:  # fmt: skip
        """Advance ``state`` by one substep with the roots pinned a fraction ``f`` of the
        way from ``start`` to ``end`` (each (roots (S, 3), frames (S, 3, 3))), under
        ``wind`` (3,) now, against ``colliders`` (spheres, capsules, SDF arguments)."""
        p, m = self.params, self.model
        integration, noise, constraints = self._constants()
        scroll = np.asarray(p.wind_drift, np.float64) * state.time * p.wind_frequency
        spheres, capsules, sdf = colliders
        _substep_kernel(
            state.x, state.v, m.inv_mass, m.rest_length, m.rest_local, m.bend_rest,
            m.static_local, m.root_direction, *start, *end, f, p.substep, *integration, wind,
            *noise, scroll, *constraints, spheres, capsules, *sdf, p.collision_margin,
            p.friction, self.energy, self._bad,
        )  # fmt: skip
        if self._bad.any():
            raise InputError(
                f"simulation: {int(self._bad.sum())} strand(s) would get NaN or inf at"
                f" t = {state.time:.4f} s (kept as they were); lower [sim].substep"
                f" (now {p.substep:g} s), wind ({p.wind}) or drag ({p.drag}), or raise"
                f" [sim].iterations (now {p.iterations})"
            )
        state.time += p.substep
