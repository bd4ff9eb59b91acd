"""Simulator: the public facade over Model, State and Solver (issue: dynamics).

``step(dt)`` advances the caller's dt in fixed substeps of ``params.substep`` with an
accumulator, so behaviour does not depend on the caller's frame rate; the skin's new
pose (``set_pose``) is reached gradually over the step's substeps: the roots, and for a
rigid transform the colliders and the skin's SDF too. The pose is the simulator's own
value (:attr:`Simulator.pose`, a posed copy of the mesh): setting it changes no mesh
that a Groom or another simulator holds; hand it on (``groom.follow(sim)`` does).
After every substep the hair volume (``[sim].volume_*``) exchanges momentum between
neighbouring strands.

The public methods validate their arguments once and raise InputError, leaving the
simulator as it was; a step whose state leaves the meaningful range (NaN, inf, strands
flying apart) although every input was valid raises SimulationError, so no caller (nor
a cache) ever gets NaN from a step that returned.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from ..arrays import rigid, rigid_fit
from ..curves import HairCurves
from ..errors import InputError, ResourceError, SimulationError
from ..groom.guides import Guides
from ..kernels import kernel, prange
from ..mesh.sdf import SDF
from ..mesh.skin import MAX_COORDINATE, SkinMesh
from ..noise import perlin
from ..threads import threads_for
from ..validate import number
from .collision import NO_SDF, Colliders, clearance, colliders, penetration
from .model import Model
from .settings import SimParams
from .solver import Solver
from .state import State
from .volume import volume_step

__all__ = ["MAX_SUBSTEPS_PER_CALL", "MIN_SEGMENT", "MODEL_KEYS", "Simulator", "substeps_per_step"]

# [sim] keys that shape the model (vertices), the skin's field (skin_collision,
# skin_voxel) or the rest clearances (colliders): a change rebuilds them, hair at rest
MODEL_KEYS = ("vertices", "skin_collision", "skin_voxel", "colliders")
MAX_SUBSTEPS_PER_CALL = 10_000  # substeps one step() may run (83 s at the default 1/120 s)
EXPLODED = 10.0  # a vertex this many strand lengths from its root: the state blew up
# the shortest rest segment stretch is measured against (m): guide points are float32,
# so a segment shorter than this at coordinates of metres is rounding, not shape
MIN_SEGMENT = 1e-6
# a deformed skin moves the last SDF rigidly while no vertex is off the best rigid fit by
# more than this many voxels (the field's own error is ~0.06 voxel): else it is rebuilt
SDF_REUSE = 0.1
# vertices per thread below which the solver's substep keeps to fewer threads
# (benchmarks/sim_threads.py; see follicle.sim.volume.PARTICLE_GRAIN for the why)
SUBSTEP_GRAIN = 20_000


def substeps_per_step(dt: float, substep: float) -> int:
    """How many substeps of ``substep`` s a step of ``dt`` s runs (at most; the remainder
    carried between steps may add one). :meth:`Simulator.step` refuses a step that needs
    more than MAX_SUBSTEPS_PER_CALL; callers that know their frame rate check up front."""
    return math.ceil(dt / substep - 1e-9)


def _seconds(dt: object) -> float:
    """``dt`` as a finite float ≥ 0: any real number (Python, NumPy scalar or 0-d array),
    not a bool, a string or an array of several values."""
    if isinstance(dt, np.ndarray) and dt.ndim == 0 and dt.dtype.kind in "iuf":
        dt = dt.item()
    return number(dt, "dt", lo=0.0, unit="s")


def _numbers(value: object, name: str) -> np.ndarray:
    """``value`` as a float64 array, or InputError naming ``name``: strings, bools, complex
    and objects that are not numbers are refused, not converted."""
    if isinstance(value, (str, bytes)):
        raise InputError(f"{name}: expected an array of numbers, got {type(value).__name__}")
    try:
        raw = np.asarray(value)
        if raw.dtype.kind not in "iufO":
            raise TypeError(raw.dtype)
        return np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(
            f"{name}: expected an array of real numbers, got {type(value).__name__}"
        ) from None


def _head_transform(transform: object) -> np.ndarray:
    """``transform`` checked as the head's world-from-rest motion: a finite 4×4 matrix
    [R t; 0 0 0 1] with R a rotation (RᵀR = I and det R = +1, so no scale, shear or
    mirror: the skin's SDF, the roots' frames and the cache all move rigidly) and
    |t| ≤ MAX_COORDINATE (a place a mesh may be)."""
    m = _numbers(transform, "transform")
    if m.shape != (4, 4):
        hint = "; put a 3×3 rotation R in [R t; 0 0 0 1]" if m.shape == (3, 3) else ""
        raise InputError(f"transform: expected a 4×4 matrix, got shape {m.shape}{hint}")
    if not np.isfinite(m).all():
        raise InputError("transform: every entry must be finite, got NaN or inf")
    with np.errstate(over="ignore", invalid="ignore"):  # huge entries: rigid() refuses them
        det = float(np.linalg.det(m[:3, :3]))
    if det <= 0.0:
        what = "a mirror" if det < 0 else "singular"
        raise InputError(
            f"transform: {what} (det = {det:.3g}); the head moves by a rotation and a"
            " translation (det = +1)"
        )
    world = np.array(rigid(m)[0])
    move = float(np.abs(world[:3, 3]).max())
    if move > MAX_COORDINATE:
        raise InputError(
            f"transform: translation {move:.3g} m lies beyond ±{MAX_COORDINATE:g} m (where a"
            " mesh may be); give it in metres"
        )
    return world


@kernel(parallel=True)
def _reach(x, v, length):  # pragma: no cover - compiled
    """Per strand, its farthest vertex from the root in strand lengths; NaN when any of
    its positions or velocities is not finite (one pass, no temporaries)."""
    out = np.empty(x.shape[0])
    for s in prange(x.shape[0]):
        far = 0.0
        ok = True
        for i in range(x.shape[1]):
            d2 = 0.0
            for c in range(3):
                d = x[s, i, c] - x[s, 0, c]
                d2 += d * d
                ok = ok and math.isfinite(x[s, i, c]) and math.isfinite(v[s, i, c])
            far = max(far, d2)
        out[s] = math.sqrt(far) / length[s] if ok else np.nan
    return out


def _skin_field(vertices: np.ndarray, faces: np.ndarray, voxel: float | None) -> SDF:
    """The skin's SDF; its refusals (a voxel too small for the grid's limit) named by
    the user's key, ``[sim].skin_voxel``."""
    try:
        return SDF.from_mesh(vertices, faces, voxel_size=voxel)
    except (InputError, ResourceError) as exc:
        raise type(exc)(f"[sim].skin_voxel: {exc}") from None


def _orthonormal(tangent: np.ndarray, binormal: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Frames (S, 3, 3), rows tangent, binormal, normal, made exactly orthonormal from the
    normal, keeping each frame's handedness (the skin's frames are left-handed, b = t × n),
    as the solver re-makes the frames it blends between poses."""
    n = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    t = tangent - np.sum(tangent * n, axis=1, keepdims=True) * n
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n, t)
    b *= np.where(np.sum(b * binormal, axis=1, keepdims=True) < 0.0, -1.0, 1.0)
    return np.ascontiguousarray(np.stack([t, b, n], axis=1), np.float64)


def _corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The 8 corners (8, 3) of the box lo … hi."""
    return np.array([[(lo, hi)[(c >> a) & 1][a] for a in range(3)] for c in range(8)])


def _blend(a: np.ndarray, b: np.ndarray, f: float) -> np.ndarray:
    """The rigid transform a fraction ``f`` of the way from ``a`` to ``b`` (4×4): the
    translation blended linearly, the rotation along the shortest arc (slerp)."""
    if f >= 1.0 or np.array_equal(a, b):
        return b
    turn = Rotation.from_matrix(np.stack([a[:3, :3], b[:3, :3]]))
    out = np.eye(4)
    out[:3, :3] = Slerp([0.0, 1.0], turn)(f).as_matrix()
    out[:3, 3] = (1.0 - f) * a[:3, 3] + f * b[:3, 3]
    return out


class Simulator:
    """Simulates ``guides`` (Guides, or HairCurves bound to ``mesh`` when given) with
    ``params`` (SimParams; None = the defaults). Hair starts at rest on the mesh's pose."""

    def __init__(
        self,
        guides: Guides | HairCurves,
        mesh: SkinMesh | None = None,
        params: SimParams | None = None,
    ) -> None:
        if isinstance(guides, Guides) and mesh is None:
            mesh = guides.mesh
        self.mesh = mesh
        self._pose = mesh  # the skin's pose now: the mesh as given, then set_pose's
        self._guides = guides
        self._transform = np.eye(4)
        self._params: SimParams | None = None
        self.params = params if params is not None else SimParams()

    @property
    def params(self) -> SimParams:
        """The [sim] settings. Give a changed copy (``sim.params =
        sim.params.replace(gravity=(0, 0, 0))``): it applies from the next step; a change
        to a key of :data:`MODEL_KEYS` rebuilds the model, the skin's field and the rest
        clearances and puts the hair back at rest on the current pose."""
        # None only inside __init__, before its first assignment to self.params
        assert self._params is not None
        return self._params

    @params.setter
    def params(self, params: SimParams) -> None:
        if not isinstance(params, SimParams):
            raise InputError(f"params: expected SimParams, got {type(params).__name__}")
        old, self._params = self._params, params
        if old is not None and all(getattr(old, k) == getattr(params, k) for k in MODEL_KEYS):
            self.solver.params = params
            return
        self._build(params)

    def _build(self, params: SimParams) -> None:
        """Model, skin field, solver and state for ``params`` on the skin's current pose."""
        mesh = self._pose
        self.model = Model.build(self._guides, self.mesh, params.vertices)
        self._free = self.model.inv_mass != 0  # particles the volume may move (not roots)
        self._accumulator = 0.0
        self._pinned_cache: tuple[np.ndarray, np.ndarray] | None = None
        self.sdf = None  # the skin's SDF on the current pose
        if mesh is not None and params.skin_collision:
            self.sdf = _skin_field(mesh.vertices, mesh.faces, params.skin_voxel)
            self._sdf_rest = self.sdf  # built on the pose rigid transforms are applied to
            if mesh.vertices is not mesh.rest_vertices:  # posed: rigid moves start from rest
                self._sdf_rest = _skin_field(mesh.rest_vertices, mesh.faces, params.skin_voxel)
            self._sdf_built = (self.sdf, mesh.vertices)  # the last field built, and on what
        roots, frames = self._pinned()
        rest = roots[:, None] + np.einsum("snk,ska->sna", self.model.rest_local, frames)
        near = clearance(rest, self._colliders(self._transform, self.sdf))
        self.solver = Solver(self.model, params, near)
        self._reach = float(self.model.rest_length.sum(axis=1).max())  # longest strand, m
        self._last_move: tuple | None = None  # (identity, transform, colliders) last substep
        self.reset()

    # ------------------------------------------------------------------ pose
    def _pinned(self) -> tuple[np.ndarray, np.ndarray]:
        """Roots (S, 3) and root frames (S, 3, 3) on the skin's current pose (kept until
        the pose changes)."""
        if self._pinned_cache is None:
            m = self.model
            if self._pose is not None:  # None exactly when self.mesh is
                cur = self._pose.evaluate(m.triangles, m.bary, pose="current")
                frames = _orthonormal(cur.tangent, cur.binormal, cur.normal)
                self._pinned_cache = (np.ascontiguousarray(cur.position, np.float64), frames)
            else:
                r, t = self._transform[:3, :3], self._transform[:3, 3]
                self._pinned_cache = (
                    m.rest_roots @ r.T + t,
                    np.ascontiguousarray(m.rest_frames @ r.T),
                )
        return self._pinned_cache

    @property
    def pose(self) -> SkinMesh | None:
        """The skin in the pose the roots are pinned to now (the mesh given, or a posed
        copy of it made by :meth:`set_pose`; None without a mesh): a value to hand to
        ``Groom.generate(pose=…)``, a renderer or a writer."""
        return self._pose

    def set_pose(self, transform: object | None = None, vertices: object | None = None) -> None:
        """Move the skin: a 4×4 rigid ``transform`` of the rest pose, or new mesh
        ``vertices``. The roots get there over the next :meth:`step`.

        ``transform`` is [R t; 0 0 0 1] with R a proper rotation (no scale, shear or
        mirror) and every |t| ≤ 1e6 m; ``vertices`` (V, 3) finite, the rest mesh's shape,
        every coordinate within ±1e6 m. Anything else is an InputError naming the
        argument, and the pose is left as it was."""
        if (transform is None) == (vertices is None):
            raise InputError("set_pose: give exactly one of transform= or vertices=")
        if transform is not None:
            world = _head_transform(transform)
            if self.mesh is not None:  # first: it refuses a pose that moves the mesh too far
                self._pose = self.mesh.posed(transform=world)
            self._pinned_cache = None
            self._transform = world
            if self.sdf is not None:
                self.sdf = self._sdf_rest.with_transform(self._transform)
        elif self.mesh is None:
            raise InputError("set_pose: vertices= needs a mesh; without one give transform=")
        else:
            verts = _numbers(vertices, "vertices")
            rest = self.mesh.rest_vertices.shape
            if verts.shape != rest:
                raise InputError(
                    f"vertices: expected shape {rest} (the rest mesh's), got {verts.shape}"
                )
            if not np.isfinite(verts).all():
                bad = int(np.argmin(np.isfinite(verts).all(axis=1)))
                raise InputError(f"vertices: vertex {bad} is not finite: {verts[bad].tolist()}")
            pose = self.mesh.posed(vertices=verts)
            if self.sdf is not None:  # first: a new field may be refused
                self.sdf = self._deformed_field(pose)
            self._pinned_cache = None
            self._pose = pose

    def _deformed_field(self, pose: SkinMesh) -> SDF:
        """The skin's SDF on a deformed ``pose``: the last field built, moved by the rigid
        motion that best fits its vertices onto the pose's (least squares, Kabsch), while
        no vertex is off that fit by more than :data:`SDF_REUSE` voxels (distances read
        from it are then off by no more: a skinned head that mostly turns); else a new
        field (its own frame), which costs ~80 ms on the built-in head's 64³ grid."""
        built, vertices = self._sdf_built
        fit, off = rigid_fit(vertices, pose.vertices)
        if off <= SDF_REUSE * built.voxel:
            return built.with_transform(fit)
        sdf = _skin_field(pose.vertices, pose.faces, self.params.skin_voxel)
        self._sdf_built = (sdf, pose.vertices)
        return sdf

    def teleport(self, transform: object | None = None, vertices: object | None = None) -> None:
        """Re-pose at once: every strand moves rigidly with its root frame (no explosion).
        Takes what :meth:`set_pose` takes and refuses what it refuses (unmoved)."""
        old_roots, old_frames = self.state.roots, self.state.frames
        self.set_pose(transform, vertices)
        roots, frames = self._pinned()
        # x' = root' + F'ᵀ F (x − root): the strand's shape in its root frame is kept
        turn = np.einsum("sba,sbc->sac", frames, old_frames)
        x = self.state.x.astype(np.float64) - old_roots[:, None]
        self.state.x[:] = roots[:, None] + np.einsum("sac,snc->sna", turn, x)
        self.state.v[:] = np.einsum("sac,snc->sna", turn, self.state.v.astype(np.float64))
        self.state.roots, self.state.frames = roots, frames
        self.state.clear[:] = -1.0  # moved: look every vertex up again
        self._state_transform = self._transform

    def reset(self) -> None:
        """Hair back to its rest shape on the skin's current pose, at rest, time 0."""
        roots, frames = self._pinned()
        local = self.model.rest_local.astype(np.float64)
        x = roots[:, None] + np.einsum("snk,ska->sna", local, frames)
        self.state = State(x, np.zeros_like(x), 0.0, roots, frames, np.full(x.shape[:2], -1.0))
        self._state_transform = self._transform
        self._accumulator = 0.0
        self.solver.energy[:] = 0.0

    # ------------------------------------------------------------------ stepping
    def _colliders(self, transform: np.ndarray, sdf: SDF | None) -> Colliders:
        """The [sim] colliders and the skin's SDF in world space with the head at
        ``transform`` (colliders with ``follow`` move with it)."""
        sample = NO_SDF if sdf is None else sdf.sample_args
        return colliders(self.params.colliders, sample, transform)

    def _collider_move(self, transform: np.ndarray, sdf: SDF | None, now: Colliders) -> float:
        """How far any collider surface near the hair moved since the last substep (m): the
        largest move, under the head's relative motion, of the corners of the hair's and
        the SDF's boxes and of the shapes' points (a rigid motion's move
        is convex in the point, so these extreme points bound it). inf when the collider
        set changed (new parameters, a rebuilt SDF) or the state was replaced.
        ``now``: this substep's :meth:`_colliders`, kept for the next one."""
        key = (self.params, None if sdf is None else sdf.values, self.state.clear)
        last, self._last_move = self._last_move, (key, transform, now)
        if last is None or any(a is not b for a, b in zip(last[0], key, strict=True)):
            return math.inf
        relative = transform @ np.linalg.inv(last[1])
        if np.array_equal(relative, np.eye(4)):
            return 0.0
        roots, reach = self.state.roots, self._reach
        points = [_corners(roots.min(axis=0) - reach, roots.max(axis=0) + reach)]
        if sdf is not None:
            hi = sdf.origin + sdf.voxel * (np.array(sdf.values.shape) - 1)
            local = _corners(sdf.origin, hi)
            points.append(local @ sdf.transform[:3, :3].T + sdf.transform[:3, 3])
        points.append(last[2].points())  # the colliders at the last substep's transform
        p = np.concatenate(points)
        return float(np.linalg.norm(p @ relative[:3, :3].T + relative[:3, 3] - p, axis=1).max())

    def wind(self, time: float) -> np.ndarray:
        """The wind at ``time`` (s): [sim].wind × (1 + gust·g), g = ½ + Perlin noise of
        time / gust period, clipped to [0, 1] (a smooth, irregular gust signal)."""
        p = self.params
        g = min(max(0.5 + perlin(time / p.wind_gust_period + 0.5, 0.31, 0.73), 0.0), 1.0)
        return np.asarray(p.wind, np.float64) * (1.0 + p.wind_gust * g)

    def step(self, dt: float) -> None:
        """Advance ``dt`` seconds: as many fixed substeps as fit, the rest carried over.

        ``dt`` is any real number ≥ 0 (int, float, a NumPy scalar or 0-d array). One call
        runs at most MAX_SUBSTEPS_PER_CALL (10,000) substeps of ``[sim].substep`` (83 s of
        simulated time at the default 1/120 s): a longer step is a ResourceError, raised
        before anything moves; call step in smaller pieces or raise ``[sim].substep``.
        A state that blows up (NaN, inf, or a vertex ``EXPLODED`` strand lengths from its
        root) raises SimulationError, naming the settings to soften.
        """
        dt = _seconds(dt)
        p = self.params
        h = p.substep
        total = self._accumulator + dt
        steps = total / h + 1e-9  # inf for a dt near the largest float
        if steps >= MAX_SUBSTEPS_PER_CALL + 1:
            need = f"{math.floor(steps):,}" if math.isfinite(steps) else "over 10^308"
            raise ResourceError(
                f"dt: {dt:g} s needs {need} substeps of [sim].substep = {h:g} s; one step"
                f" runs at most {MAX_SUBSTEPS_PER_CALL:,}: call step in smaller pieces or"
                " raise [sim].substep"
            )
        count = int(math.floor(steps))
        self._accumulator = max(total - count * h, 0.0)
        if count == 0:
            return
        start = (self.state.roots, self.state.frames)
        end = self._pinned()
        begin, finish = self._state_transform, self._transform
        rigid_skin = self.sdf is not None and self.sdf.values is self._sdf_rest.values
        volume = p.volume_friction > 0 or p.volume_repulsion > 0
        for k in range(1, count + 1):
            f = k / count
            transform = _blend(begin, finish, f)
            sdf = self._sdf_rest.with_transform(transform) if rigid_skin else self.sdf
            world = self._colliders(transform, sdf)
            moved = self._collider_move(transform, sdf, world)
            with threads_for(self.state.x.shape[0] * self.state.x.shape[1], SUBSTEP_GRAIN):
                self.solver.substep(
                    self.state, start, end, f, self.wind(self.state.time), world, moved
                )
            if volume:  # the state is finite (the solver puts back a strand that is not)
                volume_step(
                    self.state.x,
                    self.state.v,
                    self._free,
                    h,
                    p.volume_friction,
                    p.volume_repulsion,
                    p.volume_blur,
                    p.volume_resolution,
                )
        self.state.roots, self.state.frames = end
        self._state_transform = finish
        with threads_for(self.state.x.shape[0] * self.state.x.shape[1], SUBSTEP_GRAIN):
            self._check_state()

    def _check_state(self) -> None:
        """SimulationError when the state left the meaningful range: a non-finite value
        (the solver keeps such strands as they were; this catches the rest) or a vertex
        more than EXPLODED strand lengths from its root."""
        p = self.params
        reach = _reach(self.state.x, self.state.v, self.model.rest_length.sum(axis=1))
        finite = bool(np.isfinite(reach).all())
        if finite and not (reach > EXPLODED).any():
            return
        what = (
            "NaN or inf"
            if not finite
            else f"a vertex {float(reach.max()):.3g} strand lengths from its root"
        )
        raise SimulationError(
            f"simulation: the state blew up ({what}) at t = {self.state.time:.4f} s; soften"
            f" [sim]: lower substep (now {p.substep:g} s), wind ({p.wind}), gravity"
            f" ({p.gravity}) or volume_repulsion ({p.volume_repulsion}), raise iterations"
            f" (now {p.iterations}) or stretch_stiffness ({p.stretch_stiffness}), or set"
            " stretch_limit"
        )

    # ------------------------------------------------------------------ results
    @property
    def positions(self) -> np.ndarray:
        """Strand vertices now, (S, N, 3) float64 (a view of the state: copy to keep)."""
        return self.state.x

    @property
    def stats(self) -> dict[str, float]:
        """max/mean relative stretch (|length − rest| / rest, with rests under
        MIN_SEGMENT taken as it, so a segment of no length at rest cannot dominate),
        deepest penetration (m) into a collider or the skin,
        kinetic energy (½ Σ |v|² over free vertices of unit mass, v = the last substep's
        move / its length: DFTL's stored velocities carry eq. 3.1's correction, which
        does not move a hanging strand)."""
        x = self.state.x
        seg = np.linalg.norm(np.diff(x, axis=1), axis=2)
        rest = self.model.rest_length
        stretch = np.abs(seg - rest) / np.maximum(rest, MIN_SEGMENT)
        return {
            "max_stretch": float(stretch.max()),
            "mean_stretch": float(stretch.mean()),
            "max_penetration": penetration(x, self._colliders(self._transform, self.sdf)),
            "kinetic_energy": float(self.solver.energy.sum()),
        }
