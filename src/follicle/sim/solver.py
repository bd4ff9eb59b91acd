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
    segment,
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


@njit(cache=True, parallel=True)
def _substep_kernel(x, v, x_old, v_old, corr, contact, w, rest_length, rest_local, bend_rest,
                    static_local, root_direction, roots, frames, dt, damp, euler, dftl,
                    iterations, gravity, wind, turbulence, frequency, scroll, drag, k_stretch,
                    k_bend, bend_scale, attenuation, k_local, k_global, cos_limit, sin_limit,
                    dftl_damping, stretch_limit, limit_damping, spheres, capsules, margin,
                    friction, bad):  # fmt: skip
    n = x.shape[1]
    for s in prange(x.shape[0]):
        for i in range(n):
            for a in range(3):
                x_old[s, i, a] = x[s, i, a]
                v_old[s, i, a] = v[s, i, a]
                contact[s, i, a] = 0.0
        root = roots[s]
        frame = frames[s]
        for a in range(3):
            v[s, 0, a] = (root[a] - x[s, 0, a]) / dt
            x[s, 0, a] = root[a]
        for i in range(1, n):  # integrate
            if w[s, i] == 0.0:
                continue
            tx, ty, tz, tl = segment(x_old, s, i - 1, i)
            if tl > 0.0:
                tx, ty, tz = tx / tl, ty / tl, tz / tl
            vx, vy, vz = v[s, i, 0], v[s, i, 1], v[s, i, 2]
            ax, ay, az = acceleration(x_old[s, i, 0], x_old[s, i, 1], x_old[s, i, 2], tx, ty, tz,
                                      vx, vy, vz, gravity, wind, turbulence, frequency, scroll,
                                      drag)  # fmt: skip
            if euler:  # v ← (v + a dt) damped, x ← x + v dt
                vx, vy, vz = (vx + ax * dt) * damp, (vy + ay * dt) * damp, (vz + az * dt) * damp
                x[s, i, 0] += vx * dt
                x[s, i, 1] += vy * dt
                x[s, i, 2] += vz * dt
            else:  # 002 eq. 5.1: P = P⁻¹ + (P⁻¹ − P⁻²) + a Δt², the implicit velocity damped
                x[s, i, 0] += vx * dt * damp + ax * dt * dt
                x[s, i, 1] += vy * dt * damp + ay * dt * dt
                x[s, i, 2] += vz * dt * damp + az * dt * dt
        sx, sy, sz = skinned(root, frame, static_local[s:s + 1], 0)
        static = (sx, sy, sz)
        for _ in range(iterations):
            if not dftl:
                distance_pass(x, w, rest_length, s, k_stretch)
            if k_bend > 0.0:
                bend_pass(x, w, s, static, bend_rest, bend_scale, k_bend, attenuation)
            if k_local > 0.0:
                local_shape_pass(x, w, s, root, frame, rest_local[s], k_local)
            if k_global[1] > 0.0:  # the profile never rises towards the tip
                global_shape_pass(x, w, s, root, frame, rest_local[s], k_global)
            for i in range(1, n):
                x[s, i, 0], x[s, i, 1], x[s, i, 2], _, _, _, _ = collide(
                    x[s, i, 0], x[s, i, 1], x[s, i, 2], spheres, capsules, margin
                )
        if dftl:
            follow_the_leader(x, s, rest_length, corr[s])
        elif stretch_limit >= 0.0:
            strain_limit(x, w, s, rest_length, 0.5 * stretch_limit, corr[s])
        if cos_limit > -1.0:
            d = root_direction[s]
            fx = d[0] * frame[0, 0] + d[1] * frame[1, 0] + d[2] * frame[2, 0]
            fy = d[0] * frame[0, 1] + d[1] * frame[1, 1] + d[2] * frame[2, 1]
            fz = d[0] * frame[0, 2] + d[1] * frame[1, 2] + d[2] * frame[2, 2]
            cone_pass(x, s, cos_limit, sin_limit, fx, fy, fz)
        for i in range(1, n):  # collisions are hard: last
            px, py, pz, nx, ny, nz, hit = collide(
                x[s, i, 0], x[s, i, 1], x[s, i, 2], spheres, capsules, margin
            )
            if hit:
                x[s, i, 0], x[s, i, 1], x[s, i, 2] = px, py, pz
                contact[s, i, 0], contact[s, i, 1], contact[s, i, 2] = nx, ny, nz
        ok = True
        correction = dftl_damping if dftl else limit_damping
        for i in range(1, n):  # velocities from the moves
            for a in range(3):
                va = (x[s, i, a] - x_old[s, i, a]) / dt
                if (dftl or stretch_limit >= 0.0) and i < n - 1:  # 001 eq. 3.1
                    va -= correction * corr[s, i + 1, a] / dt
                v[s, i, a] = va
            nx, ny, nz = contact[s, i, 0], contact[s, i, 1], contact[s, i, 2]
            if nx != 0.0 or ny != 0.0 or nz != 0.0:  # in contact: no inward speed, friction
                vn = v[s, i, 0] * nx + v[s, i, 1] * ny + v[s, i, 2] * nz
                keep = max(vn, 0.0)
                v[s, i, 0] = keep * nx + (1.0 - friction) * (v[s, i, 0] - vn * nx)
                v[s, i, 1] = keep * ny + (1.0 - friction) * (v[s, i, 1] - vn * ny)
                v[s, i, 2] = keep * nz + (1.0 - friction) * (v[s, i, 2] - vn * nz)
            for a in range(3):
                if not (math.isfinite(x[s, i, a]) and math.isfinite(v[s, i, a])):
                    ok = False
        if not ok:
            for i in range(n):
                for a in range(3):
                    x[s, i, a] = x_old[s, i, a]
                    v[s, i, a] = v_old[s, i, a]
        bad[s] = 0 if ok else 1


class Solver:
    """Runs substeps of a Model's strands with one set of parameters (a SimParams)."""

    def __init__(self, model: Model, params: object) -> None:
        self.model = model
        self.params = params
        shape = model.rest_local.shape
        self._x_old = np.empty(shape, np.float64)
        self._v_old = np.empty(shape, np.float64)
        self._corr = np.zeros(shape, np.float64)
        self._contact = np.zeros(shape, np.float64)
        self._bad = np.zeros(shape[0], np.uint8)
        self._stepped = False

    def last_velocity(self, state: State) -> np.ndarray:
        """(x − x before the last substep) / substep: how fast the strands really move."""
        if not self._stepped:
            return np.zeros_like(state.x)
        return (state.x - self._x_old) / self.params.substep

    def global_profile(self) -> np.ndarray:
        """Per-vertex global shape stiffness (linearised): full up to the range start,
        falling linearly to 0 at its end, root to tip."""
        p = self.params
        t = np.linspace(0.0, 1.0, self.model.vertices)
        start, end = p.shape_global_range
        fade = np.clip((end - t) / max(end - start, 1e-9), 0.0, 1.0)
        return linearised(p.shape_global * np.where(t <= start, 1.0, fade), p.iterations)

    def substep(self, state: State, roots: np.ndarray, frames: np.ndarray, dt: float,
                spheres: np.ndarray, capsules: np.ndarray) -> None:  # fmt: skip
        """Advance ``state`` by ``dt`` seconds with the roots pinned at ``roots``/``frames``."""
        p, m = self.params, self.model
        n = p.iterations
        cone = math.radians(p.cone_angle)
        scroll = np.asarray(p.wind_drift, np.float64) * state.time * p.wind_frequency
        _substep_kernel(
            state.x, state.v, self._x_old, self._v_old, self._corr, self._contact, m.inv_mass,
            m.rest_length, m.rest_local, m.bend_rest, m.static_local, m.root_direction,
            roots, frames, dt, math.exp(-p.damping * dt), p.integrator == "euler",
            p.solver == "dftl", n, np.asarray(p.gravity, np.float64),
            np.asarray(p.wind, np.float64), p.wind_turbulence, p.wind_frequency, scroll,
            p.drag, linearised(p.stretch_stiffness, n), linearised(p.bend_stiffness, n),
            p.bend_scale, p.bend_attenuation, linearised(p.shape_local, n),
            self.global_profile(), math.cos(cone) if p.cone_angle < 180 else -2.0,
            math.sin(cone), p.dftl_damping,
            -1.0 if p.stretch_limit is None else p.stretch_limit, p.stretch_limit_damping,
            spheres, capsules, p.collision_margin,
            p.friction, self._bad,
        )  # fmt: skip
        if self._bad.any():
            raise InputError(
                f"simulation: {int(self._bad.sum())} strand(s) would get NaN or inf at"
                f" t = {state.time:.4f} s (kept as they were); lower [sim].substep"
                f" (now {p.substep:g} s), wind ({p.wind}) or drag ({p.drag}), or raise"
                f" [sim].iterations (now {n})"
            )
        self._stepped = True
        state.time += dt
        state.roots, state.frames = roots, frames
