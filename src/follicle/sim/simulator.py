"""Simulator: the public facade over Model, State and Solver (issue: dynamics).

``step(dt)`` advances the caller's dt in fixed substeps of ``params.substep`` with an
accumulator, so behaviour does not depend on the caller's frame rate; the skin's new
pose (``set_pose``) is reached by the roots gradually over the step's substeps.
"""

from __future__ import annotations

import math

import numpy as np

from ..arrays import rigid
from ..curves import HairCurves
from ..errors import InputError
from ..groom.guides import Guides
from ..mesh.skin import SkinMesh
from ..scene import SimParams
from .collision import penetration
from .model import Model
from .solver import Solver
from .state import State

__all__ = ["Simulator"]


def _orthonormal(frames: np.ndarray) -> np.ndarray:
    """Rows tangent, binormal, normal made orthonormal again (Gram-Schmidt from the normal)."""
    n = frames[:, 2] / np.linalg.norm(frames[:, 2], axis=1, keepdims=True)
    t = frames[:, 0] - np.sum(frames[:, 0] * n, axis=1, keepdims=True) * n
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return np.stack([t, np.cross(n, t), n], axis=1)


class Simulator:
    """Simulates ``guides`` (Guides, or HairCurves bound to ``mesh`` when given) with
    ``params`` (SimParams; None = the defaults). Hair starts at rest on the mesh's pose."""

    def __init__(
        self, guides: Guides | HairCurves, mesh: SkinMesh | None = None,
        params: SimParams | None = None,
    ) -> None:  # fmt: skip
        params = params if params is not None else SimParams()
        if not isinstance(params, SimParams):
            raise InputError(f"params: expected SimParams, got {type(params).__name__}")
        if isinstance(guides, Guides) and mesh is None:
            mesh = guides.mesh
        self.mesh = mesh
        self.params = params
        self.model = Model.build(guides, mesh, params.vertices)
        self.solver = Solver(self.model, params)
        self._transform = np.eye(4)
        self._accumulator = 0.0
        self.reset()

    # ------------------------------------------------------------------ pose
    def _pinned(self) -> tuple[np.ndarray, np.ndarray]:
        """Roots (S, 3) and root frames (S, 3, 3) on the skin's current pose."""
        m = self.model
        if self.mesh is not None:
            cur = self.mesh.evaluate(m.triangles, m.bary, pose="current")
            frames = np.stack([cur.tangent, cur.binormal, cur.normal], axis=1)
            return np.ascontiguousarray(cur.position, np.float64), np.ascontiguousarray(frames)
        r, t = self._transform[:3, :3], self._transform[:3, 3]
        return m.rest_roots @ r.T + t, np.ascontiguousarray(m.rest_frames @ r.T)

    def set_pose(self, transform: object | None = None, vertices: object | None = None) -> None:
        """Move the skin: a 4×4 rigid ``transform`` of the rest pose, or new mesh
        ``vertices``. The roots get there over the next :meth:`step`."""
        if (transform is None) == (vertices is None):
            raise InputError("set_pose: give exactly one of transform= or vertices=")
        if transform is not None:
            self._transform = np.array(rigid(transform)[0])
            if self.mesh is not None:
                self.mesh.set_pose(transform=self._transform)
        elif self.mesh is None:
            raise InputError("set_pose: vertices= needs a mesh; without one give transform=")
        else:
            self.mesh.set_pose(vertices=vertices)

    def teleport(self, transform: object | None = None, vertices: object | None = None) -> None:
        """Re-pose at once: every strand moves rigidly with its root frame (no explosion)."""
        old_roots, old_frames = self.state.roots, self.state.frames
        self.set_pose(transform, vertices)
        roots, frames = self._pinned()
        # x' = root' + F'ᵀ F (x − root): the strand's shape in its root frame is kept
        turn = np.einsum("sba,sbc->sac", frames, old_frames)
        x = self.state.x.astype(np.float64) - old_roots[:, None]
        self.state.x[:] = roots[:, None] + np.einsum("sac,snc->sna", turn, x)
        self.state.v[:] = np.einsum("sac,snc->sna", turn, self.state.v.astype(np.float64))
        self.state.roots, self.state.frames = roots, frames

    def reset(self) -> None:
        """Hair back to its rest shape on the skin's current pose, at rest, time 0."""
        roots, frames = self._pinned()
        local = self.model.rest_local.astype(np.float64)
        x = roots[:, None] + np.einsum("snk,ska->sna", local, frames)
        self.state = State(x, np.zeros_like(x), 0.0, roots, frames)
        self._accumulator = 0.0

    # ------------------------------------------------------------------ stepping
    def _colliders(self) -> tuple[np.ndarray, np.ndarray]:
        """Spheres (K, 4) and capsules (L, 7) in world space now."""
        r, t = self._transform[:3, :3], self._transform[:3, 3]
        spheres, capsules = [], []
        for c in self.params.colliders:
            move = (lambda p: r @ np.asarray(p) + t) if c.follow else np.asarray
            if c.kind == "sphere":
                spheres.append([*move(c.centre), c.radius])
            else:
                capsules.append([*move(c.a), *move(c.b), c.radius])
        return (np.array(spheres, np.float64).reshape(-1, 4),
                np.array(capsules, np.float64).reshape(-1, 7))  # fmt: skip

    def step(self, dt: float) -> None:
        """Advance ``dt`` seconds: as many fixed substeps as fit, the rest carried over."""
        if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not math.isfinite(dt):
            raise InputError(f"dt: expected a finite number of seconds, got {dt!r}")
        if dt < 0:
            raise InputError(f"dt: must be ≥ 0, got {dt}")
        h = self.params.substep
        self._accumulator += dt
        count = int(math.floor(self._accumulator / h + 1e-9))
        self._accumulator = max(self._accumulator - count * h, 0.0)
        if count == 0:
            return
        start_roots, start_frames = self.state.roots, self.state.frames
        end_roots, end_frames = self._pinned()
        spheres, capsules = self._colliders()
        for k in range(1, count + 1):
            f = k / count
            roots = (1.0 - f) * start_roots + f * end_roots
            frames = _orthonormal((1.0 - f) * start_frames + f * end_frames)
            self.solver.substep(self.state, roots, frames, h, spheres, capsules)

    # ------------------------------------------------------------------ results
    @property
    def positions(self) -> np.ndarray:
        """Strand vertices now, (S, N, 3) float64 (a view of the state: copy to keep)."""
        return self.state.x

    @property
    def stats(self) -> dict[str, float]:
        """max/mean relative stretch, deepest collider penetration (m), kinetic energy
        (½ Σ |v|² over free vertices of unit mass, v = the last substep's move / its
        length: DFTL's stored velocities carry eq. 3.1's correction, which does not move
        a hanging strand)."""
        x = self.state.x
        seg = np.linalg.norm(np.diff(x, axis=1), axis=2)
        stretch = np.abs(seg / self.model.rest_length - 1.0)
        free = self.model.inv_mass > 0
        v2 = np.sum(self.solver.last_velocity(self.state) ** 2, axis=2)
        spheres, capsules = self._colliders()
        return {
            "max_stretch": float(stretch.max()),
            "mean_stretch": float(stretch.mean()),
            "max_penetration": penetration(self.state.x, spheres, capsules),
            "kinetic_energy": float(0.5 * v2[free].sum()),
        }
