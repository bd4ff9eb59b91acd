"""Groom: grows every final hair from the guides, in the pipeline order of Šik 2012 §2.2.2.

roots (DensitySampler on the rest mesh) ► interpolation group ► cut factor, early vertex
culling ► interpolate (idw | barycentric | offset) ► scale ► curl ► clump ► frizz ►
kink ► multi-strand fibres ► cut ► skin collision ► colour, width, opacity ► curve normals, vertex
removal ► placed on the mesh's current pose ► HairCurves.

All shaping happens in rest-pose root-local frames. Roots, groups, interpolation
weights and clump membership (the *layout*) are computed once per id range and kept
(Šik 2012 §2.3.6, Table 2.1): a new mesh pose only re-places the hairs, a property change
regenerates them without re-sampling. Each hair is a pure function of (seed, hair id),
so generating ids [0, N) at once equals concatenating any split of them, byte for byte;
that is also what lets the chunks of one call grow side by side on numba's threads
(:mod:`follicle.threads`).
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import DTypeLike

from ..arrays import empty_touched, rigid_fit
from ..curves import HairCurves
from ..errors import InputError, ResourceError
from ..melanin import hair_pigments, melanin_color
from ..mesh.displacement import displace
from ..mesh.head import SCALP_TEXTURE, parting_texture, scalp_texture
from ..mesh.sampling import DensitySampler
from ..mesh.sdf import SDF, skin_sdf
from ..mesh.skin import SkinMesh, SurfacePoints
from ..mesh.texture import Texture
from ..rng import uniforms
from ..threads import chained, ordered_map, workers
from ..validate import whole
from .appearance import hair_ends, hair_shifts
from .barycentric import GuideTriangulation
from .clump import assign_clumps, clump
from .fibres import make_fibres
from .finalize import cut_in_place, cut_plan, finish, pack
from .guides import Guides
from .inherit import Inherited, hair_values, inherited, pack_values
from .interpolate import blend_guides, guide_turn, idw_weights, tilt, translate_guides
from .knn import PointGrid
from .properties import GroomProperties
from .settings import GroomParams
from .shape import _RAMP, _curl, _frizz, _kink, curl_phase
from .skin_collision import keep_off_skin

__all__ = ["Groom", "resolve_density", "load_texture"]

log = logging.getLogger("follicle")

CHUNK = 32768
# skin collision on a pose whose vertices are off the best rigid motion of the rest
# pose by at most this many voxels of its SDF moves the rest pose's field (distances
# then off by no more than that): no field is built for a rigidly moved mesh
_RIGID_REUSE = 0.01
BUILTIN_TEXTURES = {"builtin:scalp": scalp_texture, "builtin:parting": parting_texture}
# the output arrays: name -> (dtype, shape per vertex or per curve)
_POINT_FIELDS = {
    "points": (np.float32, (3,)),
    "normal": (np.float32, (3,)),
    "color": (np.float32, (3,)),
    "width": (np.float32, ()),
    "opacity": (np.float32, ()),
}
_CURVE_FIELDS = {
    "counts": (np.int64, ()),
    "hair_id": (np.int64, ()),
    "strand_id": (np.int64, ()),
    "root_uv": (np.float32, (2,)),
    "strand_uv": (np.float32, (2,)),
    "root_triangle": (np.int64, ()),
    "root_bary": (np.float32, (2,)),
}


# name -> (dtype, shape per vertex or per curve) of output arrays
_Fields = Mapping[str, tuple[DTypeLike, tuple[int, ...]]]


def _bytes(fields: _Fields) -> int:
    return sum(np.dtype(dtype).itemsize * int(np.prod(shape)) for dtype, shape in fields.values())


_VERTEX_BYTES = _bytes(_POINT_FIELDS)
_CURVE_BYTES = _bytes(_CURVE_FIELDS)
_LAYOUT_KEYS = ("seed", "interpolation", "guide_samples", "clump_count")
_SAMPLER_KEYS = ("density", "density_refine")
_CENTRE_IDS = 2**40  # clump centres use ids no hair has: their own random streams


def resolve_density(
    mesh: SkinMesh, spec: str | float | Texture | None, resolve_path: Callable[[str], str] = str
) -> Texture | float | None:
    """A density setting made concrete: ``builtin:scalp``, an image path, a number or None.

    None picks the mesh's own scalp map when it has one (the built-in head and bust),
    else uniform density.
    """
    if spec is None:
        return mesh.textures.get(SCALP_TEXTURE)
    if isinstance(spec, str):
        return load_texture(spec, resolve_path, mesh)
    return spec


def load_texture(
    spec: str, resolve_path: Callable[[str], str] = str, mesh: SkinMesh | None = None
) -> Texture:
    """A texture from ``builtin:NAME`` or an image path (resolved against the scene).

    ``builtin:scalp`` and ``builtin:parting`` are ``mesh``'s own map of that name when it
    has one (the built-in bust's, in its UV layout), else the built-in head's.
    """
    if spec.startswith("builtin:"):
        if spec not in BUILTIN_TEXTURES:
            raise InputError(
                f"unknown built-in texture {spec!r}; choose one of {sorted(BUILTIN_TEXTURES)}"
            )
        own = None if mesh is None else mesh.textures.get(spec.split(":", 1)[1])
        return own if own is not None else BUILTIN_TEXTURES[spec]()
    return Texture.load(resolve_path(spec))


def _referenced_builtins(params: GroomParams) -> dict[str, Texture]:
    """The built-in textures that ``params``' properties name."""
    names = set()
    for value in params.model_dump().values():
        source = value.get("texture") if isinstance(value, dict) else value
        if isinstance(source, str) and source in BUILTIN_TEXTURES:
            names.add(source)
    return {name: BUILTIN_TEXTURES[name]() for name in sorted(names)}


def _available_memory() -> int:
    """Bytes of memory available now (MemAvailable), or physical memory as a fallback."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


@dataclass
class _Layout:
    """Roots and what interpolation needs of them, for one id range (kept across poses)."""

    ids: np.ndarray
    triangles: np.ndarray
    bary: np.ndarray
    rest: SurfacePoints
    group: np.ndarray
    guide_index: np.ndarray  # (n, k) guide of each weight
    guide_weight: np.ndarray  # (n, k) float32
    clump: np.ndarray | None  # (n,) clump centre, −1 for none
    turn: np.ndarray  # (n, 2) cos, sin of the guide-aligned frame about the normal


# what finds a group's guides near a root: a triangulation for barycentric interpolation
_Finder = PointGrid | GuideTriangulation


@dataclass
class _Bucket:
    """Curves of one group with one culled vertex count, shaped and finished."""

    rows: np.ndarray  # hair row in the chunk of each curve
    strand: np.ndarray
    strand_uv: np.ndarray
    points: np.ndarray  # (m, n, 3) root-local
    n_total: int  # vertices of the uncut hairs
    length: np.ndarray  # (m,) vertices after the cut
    keep: np.ndarray  # (m, n) bool
    t_end: np.ndarray  # (m,) curve parameter of the last vertex
    ends: np.ndarray  # (m, ENDS) colour, width, opacity at root and tip
    inherited: dict[str, np.ndarray]  # attributes from the guides (.inherit.hair_values)
    shifts: np.ndarray | None  # (m, 4) hue etc. shifts of an inherited colour


class _Placed(NamedTuple):
    """Where a chunk's hairs are placed: the skin frames of their roots on the current
    pose, and that pose's SDF when ``[groom].skin_collision`` keeps them off it."""

    cur: SurfacePoints
    skin: SDF | None


class _Shaped:
    """A chunk's hairs shaped and finished (buckets), its skin frames on the current pose,
    and how many vertices and curves it adds to the output."""

    def __init__(self, cur: SurfacePoints, buckets: list[_Bucket]) -> None:
        self.cur = cur
        self.buckets = buckets
        self.counts = (
            np.concatenate([b.keep.sum(axis=1) for b in buckets])
            if buckets
            else np.zeros(0, np.int64)
        )
        self.vertices = int(self.counts.sum())
        self.curves = int(np.count_nonzero(self.counts))

    def after(self, at: tuple[int, int]) -> tuple[int, int]:
        """Output (vertex, curve) position after this chunk, from ``at`` before it."""
        return at[0] + self.vertices, at[1] + self.curves


def _turned(frame: SurfacePoints, turn: np.ndarray) -> SurfacePoints:
    """``frame`` with tangent and binormal turned about the normal by (cos, sin) ``turn``."""
    c, s = turn[:, :1], turn[:, 1:]
    tangent = c * frame.tangent + s * frame.binormal
    binormal = c * frame.binormal - s * frame.tangent  # stays tangent × normal
    return frame._replace(tangent=tangent, binormal=binormal)


def _run(rows: np.ndarray) -> np.ndarray | slice:
    """Ascending distinct ``rows`` as a slice when they are one run, else as they are."""
    if len(rows) and int(rows[-1]) - int(rows[0]) + 1 == len(rows):
        return slice(int(rows[0]), int(rows[-1]) + 1)
    return rows


def _rows(value: np.ndarray, sel: np.ndarray | slice) -> np.ndarray:
    """Per-hair property rows ``sel``; a shared single row stays shared."""
    return value if len(value) == 1 else value[sel]


def _shared_row(value: object) -> np.ndarray:
    """A setting shared by every hair (a number or 3-vector) as the shape kernels take
    it: one float64 row, (1,) or (1, 3)."""
    arr = np.asarray(value, dtype=np.float64)
    return arr.reshape(1, *arr.shape)


class Groom:
    """Grows hair on ``mesh`` from ``guides`` with ``params`` (the defaults when None).

    Hairs follow the guides' interpolation groups; each has ``params.vertices``
    vertices (default: the guides' count) unless its group sets its own.

    ``density`` overrides ``params.density`` (a Texture, number, path or None). With a
    ``displacement`` texture, roots on the pose grown on sit on the displaced skin
    (Šik 2012 §2.2.3); interpolation still uses the undisplaced rest pose. Texture paths in
    the properties resolve through ``resolve_path`` (the scene's folder).

    Set ``groom.params`` to change properties (keeps roots and weights unless the
    seed, density, interpolation or clump count change); to re-place the hairs on a
    moved skin, give :meth:`generate` that pose (``pose=mesh.posed(transform=…)``, or a
    Simulator's ``sim.pose``). The groom holds the rest mesh and never poses it.
    """

    def __init__(
        self,
        mesh: SkinMesh,
        guides: Guides | HairCurves,
        params: GroomParams | None = None,
        density: Texture | float | str | None = None,
        displacement: Texture | None = None,
        displacement_scale: float = 1.0,
        resolve_path: Callable[[str], str] = str,
    ) -> None:
        if not isinstance(mesh, SkinMesh):
            raise InputError(
                f"mesh: expected a follicle.SkinMesh (load_mesh), got {type(mesh).__name__}"
            )
        self.mesh = mesh
        if isinstance(guides, HairCurves):
            guides = Guides(guides, mesh)
        self.guides = guides
        self.displacement = displacement
        self.displacement_scale = displacement_scale
        self._density = density
        self._resolve = resolve_path
        self._p: GroomParams | None = None
        self._layouts: dict[tuple[int, int], _Layout] = {}
        self._weights_by_group: dict[int, tuple[np.ndarray, _Finder]] = {}
        self._centre_roots: tuple[SurfacePoints, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._centre_shapes: np.ndarray | None = None
        self._inherit: tuple[Inherited, ...] = ()  # [groom].inherit, checked on the guides
        self._inside_out: bool | None = None  # the guides grow on the skin's inner side
        self._lock = threading.RLock()
        self.params = params if params is not None else GroomParams()

    def with_guides(self, guides: Guides) -> Groom:
        """This groom grown from other guides on the same mesh (its parameters, density
        and displacement kept): what a brush stroke's guides grow (docs: How-to ›
        Grooming by hand). Roots, weights and clumps are worked out again for them."""
        if not isinstance(guides, Guides) or not guides.mesh.same_skin(self.mesh):
            raise InputError(f"guides: expected follicle.Guides on mesh '{self.mesh.name}'")
        return Groom(
            self.mesh,
            guides,
            self.params,
            self._density,
            self.displacement,
            self.displacement_scale,
            self._resolve,
        )

    # ------------------------------------------------------------------ parameters
    @property
    def params(self) -> GroomParams:
        # None only inside __init__, before its first assignment to self.params
        assert self._p is not None
        return self._p

    @params.setter
    def params(self, params: GroomParams) -> None:
        if not isinstance(params, GroomParams):
            raise InputError(f"params: expected GroomParams, got {type(params).__name__}")
        old = self._p
        textures = {**self.mesh.textures, **_referenced_builtins(params)}
        self.properties = GroomProperties(params, self._resolve, textures)
        if old is None or any(getattr(old, k) != getattr(params, k) for k in _SAMPLER_KEYS):
            spec = self._density if self._density is not None else params.density
            self.sampler = DensitySampler(
                self.mesh,
                resolve_density(self.mesh, spec, self._resolve),
                refine=params.density_refine,
            )
            self._layouts.clear()
        if old is None or any(getattr(old, k) != getattr(params, k) for k in _LAYOUT_KEYS):
            self._layouts.clear()
            self._weights_by_group.clear()
            self._centre_roots = None
        self._inherit = inherited(self.guides, params.inherit)
        groups = self.guides.groups
        default = params.vertices or self.guides.vertex_count
        self._vertices = np.array(
            [groups.vertex_count(g, default) for g in range(groups.count)], dtype=np.int64
        )
        self._centre_shapes = None
        self._p = params

    # ------------------------------------------------------------------ public API
    def generate(
        self,
        count: int | None = None,
        start: int = 0,
        time: float = 0.0,
        progress: Callable[[int, int], None] | None = None,
        pose: SkinMesh | None = None,
    ) -> HairCurves:
        """Hairs with ids [start, start + count) on ``pose``: the groom's mesh in some
        pose (``groom.mesh.posed(…)``, ``sim.pose``), None for the rest pose.

        ``count`` defaults to params.count; ``time`` (seconds) drives animated frizz.
        Hairs cut to nothing or degenerated to one vertex are left out (their ids are
        missing from ``curve_data['hair_id']``).
        """
        return self._grow(count, start, time, progress, self.guides, self._skin(pose))

    def _skin(self, pose: object) -> SkinMesh | None:
        """``pose`` checked as a pose of this groom's mesh (None: the rest pose)."""
        if pose is None or pose is self.mesh:
            return None
        if not isinstance(pose, SkinMesh) or not self.mesh.same_skin(pose):
            got = f"mesh '{pose.name}'" if isinstance(pose, SkinMesh) else type(pose).__name__
            raise InputError(
                f"pose: expected the groom's mesh '{self.mesh.name}' in some pose"
                f" (groom.mesh.posed(transform=…) or a Simulator's sim.pose), got {got}"
            )
        return None if pose.at_rest else pose

    def _grow(
        self,
        count: int | None,
        start: int,
        time: float,
        progress: Callable[[int, int], None] | None,
        guides: Guides,
        skin: SkinMesh | None,
    ) -> HairCurves:
        """:meth:`generate` from ``guides`` (these or moved ones) on ``skin`` (None: rest)."""
        count = self.params.count if count is None else count
        self._check_range(count, start)
        self._check_memory(count)
        spans = _spans(start, count)
        layouts = ordered_map(lambda key: self._layout(*key), spans)
        # keep the layouts of this call only: repeating it (new pose, new properties)
        # reuses them, while memory stays bounded by one call's roots
        self._layouts = dict(zip(spans, layouts, strict=True))
        bound = sum(self._vertex_bound(lay) for lay in layouts)
        out = self._allocate(bound, count * self.params.strand_count)
        v, c = chained(
            layouts,
            lambda lay: self._shape(lay, time, guides, skin),
            lambda at, shaped: shaped.after(at),
            lambda lay, shaped, at: self._assemble(lay, shaped, out, *at),
            (0, 0),
            None if progress is None else lambda k: progress(spans[k][1] - start, count),
        )
        return self._curves(out, v, c)

    def follow(
        self,
        guides: object,
        count: int | None = None,
        start: int = 0,
        time: float = 0.0,
        pose: SkinMesh | None = None,
    ) -> HairCurves:
        """The hairs of :meth:`generate` grown from moved guides: a Simulator of this
        groom's guides (on its ``sim.pose``), or their vertices (S, N, 3) on ``pose``
        (the groom's mesh in the simulated frame's pose; None: the rest pose).

        Roots, weights and clumps stay those of the rest groom, so 1,000 simulated guides
        drive any number of hairs frame after frame; a hair at a guide's root follows
        that guide. Nothing of the groom changes, so frames may grow on several threads.
        """
        positions = getattr(guides, "positions", guides)
        if pose is None and hasattr(guides, "positions"):
            pose = getattr(guides, "pose", None)
        skin = self._skin(pose)
        moved = self.guides.posed(positions, pose=skin)
        return self._grow(count, start, time, None, moved, skin)

    def regrow(
        self,
        previous: HairCurves,
        guides: object,
        changed: object,
        time: float = 0.0,
        pose: SkinMesh | None = None,
    ) -> HairCurves:
        """:meth:`follow` of ``guides`` for the hairs of ``previous`` (the result of a
        :meth:`follow` or :meth:`generate` of this groom for a range of ids, on the same
        ``pose`` and ``time``), growing again only the hairs that hang on the guides
        ``changed`` (indices: the ones that moved since ``previous``) — through their
        interpolation weights or their clump's centre — and keeping the others' curves.
        Equal, byte for byte, to growing them all; what the viewer runs as a brush moves
        over a few guides of many.
        """
        if not isinstance(previous, HairCurves) or "hair_id" not in previous.curve_data:
            raise InputError("previous: expected the HairCurves of a follow or generate")
        moved = np.unique(np.asarray(changed, dtype=np.int64).reshape(-1))
        if len(moved) and (moved[0] < 0 or moved[-1] >= self.guides.count):
            raise InputError(f"changed: guide indices must lie in [0, {self.guides.count})")
        ids = previous.curve_data["hair_id"]
        start = int(ids[0]) if len(ids) else 0
        count = int(ids[-1]) - start + 1 if len(ids) else 0
        if len(moved) == 0 or count == 0:
            return previous
        positions = getattr(guides, "positions", guides)
        skin = self._skin(pose)
        posed = self.guides.posed(positions, pose=skin)
        hit = np.zeros(self.guides.count, bool)
        hit[moved] = True
        centres = None
        if self.params.clump_count > 0:
            index, weight = self._centre_placing()[2:]
            centres = (hit[index] & (weight > 0)).any(axis=1)
        parts = []
        for span in _spans(start, count):
            lay = self._layout(*span)
            again = (hit[lay.guide_index] & (lay.guide_weight > 0)).any(axis=1)
            if centres is not None and lay.clump is not None:
                again |= (lay.clump >= 0) & centres[np.maximum(lay.clump, 0)]
            if again.any():
                parts.append(_subset(lay, np.flatnonzero(again)))
        if not parts:
            return previous
        lay = _joined(parts)
        out = self._allocate(self._vertex_bound(lay), len(lay.ids) * self.params.strand_count)
        shaped = self._shape(lay, time, posed, skin)
        self._assemble(lay, shaped, out, 0, 0)
        grown = self._curves(out, *shaped.after((0, 0)))
        strands = self.params.strand_count
        old = ids * strands + previous.curve_data["strand_id"]  # (hair id, strand) order
        new = grown.curve_data["hair_id"] * strands + grown.curve_data["strand_id"]
        regrown = np.isin(ids, lay.ids)  # per curve of previous
        at = np.flatnonzero(regrown)
        if np.array_equal(old[at], new) and np.array_equal(previous.counts[at], grown.counts):
            return previous.replaced(at, grown)  # the usual case: written over a copy
        # vertex counts changed, or a curve was cut to nothing or grew back: join anew
        keep = np.flatnonzero(~regrown)
        order = np.argsort(np.concatenate([old[keep], new]), kind="stable")
        return HairCurves.concatenate([previous[keep], grown])[order]

    def chunks(
        self,
        chunk_size: int = CHUNK,
        count: int | None = None,
        start: int = 0,
        time: float = 0.0,
        pose: SkinMesh | None = None,
    ) -> Iterator[HairCurves]:
        """The hairs of :meth:`generate` (on ``pose``) as consecutive HairCurves of
        ``chunk_size`` ids."""
        count = self.params.count if count is None else count
        self._check_range(count, start)
        chunk_size = whole(chunk_size, "chunk_size", 1)
        for a in range(start, start + count, chunk_size):
            yield self.generate(min(chunk_size, start + count - a), a, time, pose=pose)

    def roots(self, count: int | None = None, start: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Roots (triangle int32, barycentric float32 (n, 2)) of hair ids [start, start +
        count), as :meth:`generate` samples them: :meth:`generate_at` of any subset of
        them, with their ids, grows exactly those hairs of :meth:`generate`."""
        count = self.params.count if count is None else count
        self._check_range(count, start)
        tri, bary = self.sampler.sample(count, self.params.seed, "random", start)
        return tri, bary

    def guide_binding(self, hair_ids: object, k: int = 3) -> tuple[np.ndarray, np.ndarray]:
        """The ``k`` guides that weigh most in each hair's interpolation and their
        weights, renormalised to sum to 1: (index (n, k) int32, weight (n, k) float32),
        for hairs ``hair_ids`` (as in ``curve_data['hair_id']``). What Unreal's groom
        schema calls ``groom_closest_guides`` / ``groom_guide_weights``: an engine that
        interpolates hair from simulated guides then blends the guides follicle did. A
        hair with fewer guides repeats its first one with weight 0."""
        ids = np.asarray(hair_ids)
        if ids.ndim != 1 or not np.issubdtype(ids.dtype, np.integer) or (ids < 0).any():
            raise InputError("hair_ids: expected a 1-D array of hair ids ≥ 0")
        if len(ids) == 0:
            return np.zeros((0, k), np.int32), np.zeros((0, k), np.float32)
        lo = int(ids.min())
        tri, bary = self.roots(int(ids.max()) - lo + 1, lo)
        tri, bary = tri[ids - lo], bary[ids - lo]
        rest = self.mesh.evaluate(tri, bary, pose="rest")
        index, weight = self._weights(rest, self.guides.groups.group_of(rest.uv))
        top = np.argsort(-weight, axis=1, kind="stable")[:, :k]
        index = np.take_along_axis(index, top, axis=1)
        weight = np.take_along_axis(weight, top, axis=1)
        if weight.shape[1] < k:  # offset interpolation: one guide
            pad = k - weight.shape[1]
            index = np.concatenate([index, np.repeat(index[:, :1], pad, axis=1)], axis=1)
            weight = np.concatenate([weight, np.zeros((len(ids), pad), np.float32)], axis=1)
        total = weight.sum(axis=1, keepdims=True)
        weight = np.divide(weight, total, out=np.zeros_like(weight), where=total > 0)
        return index.astype(np.int32), weight.astype(np.float32)

    def generate_at(
        self,
        triangles: np.ndarray,
        bary: np.ndarray,
        ids: np.ndarray | None = None,
        time: float = 0.0,
        pose: SkinMesh | None = None,
    ) -> HairCurves:
        """Hairs rooted at given (triangle, barycentric) points of the mesh, e.g. picked
        roots, on ``pose`` (None: the rest pose).

        ``ids`` (default 0, 1, …; distinct, ≥ 0) key each hair's random choices.
        """
        skin = self._skin(pose)
        tri = np.asarray(triangles)
        ids = np.arange(len(tri), dtype=np.int64) if ids is None else np.asarray(ids)
        if ids.shape != (len(tri),) or not np.issubdtype(ids.dtype, np.integer):
            raise InputError(f"ids: expected {len(tri)} integers, got {ids.dtype} {ids.shape}")
        if len(np.unique(ids)) != len(ids) or (ids < 0).any():
            raise InputError("ids: hair ids must be distinct and ≥ 0")
        lay = self._make_layout(tri, np.asarray(bary), ids.astype(np.int64))  # mesh validates
        bound = self._vertex_bound(lay)
        out = self._allocate(bound, len(tri) * self.params.strand_count)
        shaped = self._shape(lay, time, self.guides, skin)
        self._assemble(lay, shaped, out, 0, 0)
        return self._curves(out, *shaped.after((0, 0)))

    # ------------------------------------------------------------------ checks
    @staticmethod
    def _check_range(count: int, start: int) -> None:
        whole(count, "count", 0)
        whole(start, "start", 0)
        if start + count > 2**53:
            raise InputError(f"start + count: hair ids must stay below 2**53, got {start + count}")

    def _check_memory(self, count: int) -> None:
        curves = count * self.params.strand_count
        points, per_curve = self._fields()
        vertex_bytes = _VERTEX_BYTES + _bytes(points)
        need = curves * (
            int(self._vertices.max()) * vertex_bytes + _CURVE_BYTES + _bytes(per_curve)
        )
        have = _available_memory()
        if 2 * need > have:
            raise ResourceError(
                f"count: {count:,} hairs × {self.params.strand_count} strand(s) ×"
                f" {int(self._vertices.max())} vertices need about {need / 2**30:.1f} GiB of"
                f" output (twice that while building) but {have / 2**30:.1f} GiB are free;"
                " lower count or vertices, or write the hair in pieces with Groom.chunks()"
            )

    # ------------------------------------------------------------------ layout
    def _layout(self, start: int, stop: int) -> _Layout:
        """Roots, groups, weights and clumps of ids [start, stop), computed once."""
        key = (start, stop)
        if key not in self._layouts:
            tri, bary = self.roots(stop - start, start)
            ids = np.arange(start, stop, dtype=np.int64)
            self._layouts[key] = self._make_layout(tri, bary, ids)
        return self._layouts[key]

    def _make_layout(self, tri: np.ndarray, bary: np.ndarray, ids: np.ndarray) -> _Layout:
        rest = self.mesh.evaluate(tri, bary, pose="rest")
        tri, bary = tri.astype(np.int64), bary.astype(np.float32)
        group = self.guides.groups.group_of(rest.uv)
        index, weight = self._weights(rest, group)
        turn = self._turn(rest, index, weight)
        rest = _turned(rest, turn)
        which = None
        if self.params.clump_count > 0:
            c_rest, c_group, _ = self._centres(self.guides)
            which = assign_clumps(c_rest.position, c_group, rest.position, group)
        return _Layout(ids, tri, bary, rest, group, index, weight, which, turn)

    def _turn(self, rest: SurfacePoints, index: np.ndarray, weight: np.ndarray) -> np.ndarray:
        """Each root's frame turned to its guides' (kept with the layout, same on every pose)."""
        return guide_turn(index, weight, self.guides.tangents, rest.tangent, rest.binormal)

    def _weights(self, rest: SurfacePoints, group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Guide indices and weights of every root, from its own group's guides only."""
        p = self.params
        k = {"idw": p.guide_samples + 1, "barycentric": 3, "offset": 1}[p.interpolation]
        index = np.zeros((len(group), k), dtype=np.int64)
        weight = np.zeros((len(group), k), dtype=np.float32)
        for g in np.unique(group):
            sel = np.flatnonzero(group == g)
            members, finder = self._group_guides(int(g))
            # _group_finder made the finder for p.interpolation (a change of it clears them)
            if p.interpolation == "barycentric":
                assert isinstance(finder, GuideTriangulation)
                idx, w = finder.weights(rest.position[sel], rest.normal[sel])
            elif p.interpolation == "offset":
                assert isinstance(finder, PointGrid)
                _, idx = finder.query(rest.position[sel], 1)
                w = np.ones((len(sel), 1), np.float32)
            else:
                assert isinstance(finder, PointGrid)
                idx, w = idw_weights(finder, rest.position[sel], p.guide_samples)
            index[sel, : idx.shape[1]] = members[idx]
            index[sel, idx.shape[1] :] = members[idx[:, :1]]  # padding, weight 0
            weight[sel, : idx.shape[1]] = w
        return index, weight

    def _group_guides(self, group: int) -> tuple[np.ndarray, _Finder]:
        """A group's guide indices and their PointGrid (or triangulation), made once."""
        with self._lock:  # chunks of one generate run on several threads
            if group not in self._weights_by_group:
                self._weights_by_group[group] = self._group_finder(group)
            return self._weights_by_group[group]

    def _group_finder(self, group: int) -> tuple[np.ndarray, _Finder]:
        """Make :meth:`_group_guides`' pair; an error when the group has no guides."""
        label = self.guides.groups.label(group)
        members = np.flatnonzero(self.guides.group == group)
        if len(members) == 0:
            raise InputError(
                f"interpolation group {label} has hairs but no guides; add guides in"
                " that colour's area or repaint the group texture"
            )
        want = {"idw": self.params.guide_samples, "barycentric": 3}.get(
            self.params.interpolation, 1
        )
        if len(members) < want:
            log.warning(
                "interpolation group %s has %d guide(s), fewer than the %d its hairs"
                " blend (%s): they blend all of them",
                label,
                len(members),
                want,
                self.params.interpolation,
            )
        roots = self.guides.root_positions[members]
        if self.params.interpolation == "barycentric":
            return members, GuideTriangulation(roots, self.guides.normals[members])
        return members, PointGrid(roots)

    def _centres(self, guides: Guides) -> tuple[SurfacePoints, np.ndarray, np.ndarray]:
        """Clump centres: rest frames, groups and shapes grown from ``guides`` in rest
        world space (C, N, 3).

        Their roots and weights stay with the layout; their shapes follow the properties
        and the guides (the rest guides' are kept, moved guides' made for the call).
        """
        roots = self._centre_placing()
        with self._lock:  # chunks of one generate run on several threads
            if guides is not self.guides:
                return *roots[:2], self._centre_grown(guides, *roots)
            if self._centre_shapes is None:
                self._centre_shapes = self._centre_grown(guides, *roots)
            return *roots[:2], self._centre_shapes

    def _centre_placing(self) -> tuple[SurfacePoints, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`_centre_layout`, made once."""
        with self._lock:
            if self._centre_roots is None:
                self._centre_roots = self._centre_layout()
            return self._centre_roots

    def _centre_layout(self) -> tuple[SurfacePoints, np.ndarray, np.ndarray, np.ndarray]:
        """Clump centres' rest frames (turned to their guides), groups, guide weights."""
        p = self.params
        tri, bary = self.sampler.sample(p.clump_count, p.seed, "halton", _CENTRE_IDS)
        rest = self.mesh.evaluate(tri, bary, pose="rest")
        group = self.guides.groups.group_of(rest.uv)
        index, weight = self._weights(rest, group)
        return _turned(rest, self._turn(rest, index, weight)), group, index, weight

    def _centre_grown(
        self,
        guides: Guides,
        rest: SurfacePoints,
        group: np.ndarray,
        index: np.ndarray,
        weight: np.ndarray,
    ) -> np.ndarray:
        """Clump centres' shapes (C, N, 3) in rest world space: blended, scaled, curled."""
        world = np.zeros((len(group), int(self._vertices.max()), 3))
        props = self.properties.at(rest.uv)
        ids = np.arange(_CENTRE_IDS, _CENTRE_IDS + len(group), dtype=np.int64)
        for g in np.unique(group):
            sel = np.flatnonzero(group == g)
            n = int(self._vertices[g])
            local = blend_guides(
                guides.local_shapes(n),
                index[sel],
                weight[sel],
                n,
                _rows(props["scale"], sel),
            )
            self._curl(local, props, sel, ids[sel], np.linspace(0.0, 1.0, n)[None])
            frame = np.stack([rest.tangent[sel], rest.binormal[sel], rest.normal[sel]], 1)
            world[sel, :n] = rest.position[sel, None] + np.einsum("hna,hab->hnb", local, frame)
        return world

    # ------------------------------------------------------------------ shaping
    def _vertex_bound(self, lay: _Layout) -> int:
        """Most vertices the hairs of ``lay`` can have: culled counts (Šik 2012 §2.2.8) ×
        strands."""
        cut = np.broadcast_to(self.properties.at(lay.rest.uv, ("cut",))["cut"], lay.group.shape)
        need = sum(
            int(cut_plan(cut[lay.group == g], int(self._vertices[g])).sum())
            for g in np.unique(lay.group)
        )
        return need * self.params.strand_count

    def _shape(self, lay: _Layout, time: float, guides: Guides, skin: SkinMesh | None) -> _Shaped:
        """The hairs of ``lay`` grown from ``guides`` and finished, with their skin frames
        on ``skin`` (None: the rest pose)."""
        props = self.properties.at(lay.rest.uv)
        if self.displacement is not None:
            cur = _turned(
                displace(
                    self.mesh if skin is None else skin,
                    lay.triangles,
                    lay.bary,
                    self.displacement,
                    self.displacement_scale,
                ),
                lay.turn,
            )
        elif skin is None:
            cur = lay.rest  # the layout's frames, already turned
        else:
            cur = _turned(skin.evaluate(lay.triangles, lay.bary, pose="current"), lay.turn)
        placed = _Placed(cur, self._skin_field(skin))
        buckets = []
        for g in np.unique(lay.group):
            sel = np.flatnonzero(lay.group == g)
            n_total = int(self._vertices[g])
            need = cut_plan(np.broadcast_to(props["cut"], lay.group.shape)[sel], n_total)
            for n in np.unique(need[need >= 2]):
                rows = sel[need == n]
                buckets.append(
                    self._bucket(lay, props, rows, n_total, int(n), time, guides, placed)
                )
        return _Shaped(cur, buckets)

    def _skin_field(self, skin: SkinMesh | None) -> SDF | None:
        """The SDF of the pose hairs are placed on (``skin``, None: the rest mesh) when
        ``[groom].skin_collision`` is on, else None: the rest pose's, moved, for a rigidly
        moved mesh; else built once per pose and kept with it (:func:`skin_sdf`).
        Under the lock, so chunks on several threads share one."""
        if not self.params.skin_collision:
            return None
        with self._lock:
            rest = skin_sdf(self.mesh)
            if self._inside_out is None:
                self._inside_out = _grows_inside(rest, self.guides.curves)
            if skin is None:
                return _outside(rest, self._inside_out)
            # a rigid motion of the rest pose moves its field (the hair then moves
            # rigidly with the mesh, whatever the grid's axes); else the pose's own
            fit, off = rigid_fit(self.mesh.rest_vertices, skin.vertices)
            if off <= _RIGID_REUSE * rest.voxel:
                return _outside(rest, self._inside_out).with_transform(fit)
            return _outside(skin_sdf(skin, "current"), self._inside_out)

    def _bucket(
        self,
        lay: _Layout,
        props: dict[str, np.ndarray],
        rows: np.ndarray,
        n_total: int,
        n: int,
        time: float,
        guides: Guides,
        placed: _Placed,
    ) -> _Bucket:
        """Hairs ``rows`` (one group, ``n`` of ``n_total`` vertices needed) shaped from
        ``guides``, finished for the skin they are ``placed`` on."""
        p = self.params
        pick = _run(rows)  # one run of rows (the common case): gathers below are views

        def prop(name: str) -> np.ndarray:
            return _rows(props[name], pick)

        ids = lay.ids[pick]
        t = (np.arange(n) / (n_total - 1))[None]
        scale = prop("scale")
        if (props["random_scale"] > 0).any():
            xi = uniforms(p.seed, ids, "random scale", 1)[:, 0]
            scale = scale * (1.0 - prop("random_scale") * xi)
        rest = lay.rest
        root = rest.position[pick]
        frame = (rest.tangent[pick], rest.binormal[pick], rest.normal[pick])
        index = lay.guide_index[pick]
        if p.interpolation == "offset" and p.offset_mode == "translate":
            local = translate_guides(guides.rest_shapes(n_total), index[:, 0], frame, n, scale)
        else:
            local = blend_guides(
                guides.local_shapes(n_total), index, lay.guide_weight[pick], n, scale
            )
            if p.interpolation == "offset" and p.offset_angle > 0:
                tilt(local, p.seed, ids, p.offset_angle)
        self._curl(local, props, pick, ids, t)
        if lay.clump is not None:
            centre = self._centres(guides)[2]
            clump(
                local,
                centre,
                lay.clump[pick],
                (root, *frame),
                prop("clump_root"),
                prop("clump_tip"),
                p.clump_profile,
                prop("clump_noise"),
                ids,
                p.seed,
                t,
            )
        if (props["frizz_root"] > 0).any() or (props["frizz_tip"] > 0).any():
            drift = np.asarray(p.frizz_direction) * (p.frizz_speed * time)
            _frizz(
                local,
                root,
                prop("frizz_root"),
                prop("frizz_tip"),
                _shared_row(p.frizz_frequency),
                _shared_row(drift),
                prop("frizz_blend"),
                t,
            )
        if (props["kink_root"] > 0).any() or (props["kink_tip"] > 0).any():
            _kink(
                local,
                root,
                frame,
                prop("kink_root"),
                prop("kink_tip"),
                _shared_row(p.kink_frequency),
                t,
            )
        return self._finish(local, rows, ids, prop, n_total, index, lay.guide_weight[pick], placed)

    def _curl(
        self,
        local: np.ndarray,
        props: dict[str, np.ndarray],
        rows: np.ndarray | slice,
        ids: np.ndarray,
        t: np.ndarray,
    ) -> None:
        """Almeida 2014 §3.1.2 curl on ``local`` when any hair has a curl radius."""
        if not (props["curl_radius"] > 0).any():
            return
        p = self.params
        f_root = _rows(props["curl_frequency"], rows)
        tip = p.curl_frequency_tip
        _curl(
            local,
            _rows(props["curl_radius"], rows),
            f_root,
            f_root if tip is None else _shared_row(tip),
            curl_phase(p.seed, ids),
            _RAMP,
            t,
        )

    def _finish(
        self,
        local: np.ndarray,
        rows: np.ndarray,
        ids: np.ndarray,
        prop: Callable[[str], np.ndarray],
        n_total: int,
        index: np.ndarray,
        weight: np.ndarray,
        placed: _Placed,
    ) -> _Bucket:
        """Fibres, cut, skin collision on the skin they are ``placed`` on, appearance
        (inherited from the guides weighted by ``index`` and ``weight`` as far as
        ``[groom].inherit`` says), normals and vertex removal of shaped hairs."""
        p = self.params
        m, n = local.shape[:2]
        values = hair_values(self._inherit, self.guides, index, weight, n_total, n)
        parent = None  # the hair row of each curve, when fibres multiply them
        strand = np.zeros(m, dtype=np.int64)
        strand_uv = np.zeros((m, 2), dtype=np.float32)
        if p.strand_count > 1:
            local, parent, strand, strand_uv = make_fibres(
                local,
                ids,
                p.seed,
                p.strand_count,
                prop("strand_splay_root"),
                prop("strand_splay_centre"),
                prop("strand_splay_tip"),
                np.radians(prop("strand_twist")),
                prop("strand_aspect"),
                prop("strand_offset"),
                prop("strand_randomize"),
            )

        def per_curve(name: str) -> np.ndarray:
            value = prop(name)
            return value if len(value) == 1 or parent is None else value[parent]

        if parent is not None:
            rows, ids = rows[parent], ids[parent]
            values = {k: v[parent] for k, v in values.items()}
        tcut = np.broadcast_to(per_curve("cut"), (len(local),))
        length, t_end = cut_in_place(local, tcut, n_total)
        if placed.skin is not None:
            cur = placed.cur
            frame = (cur.position, cur.tangent, cur.binormal, cur.normal)
            keep_off_skin(local, length, rows, frame, placed.skin, p.skin_clearance)
        if p.melanin is None:
            root, tip, mutant = (per_curve(k) for k in ("root_color", "tip_color", "mutant_color"))
            hue, sat, val, fraction = (
                per_curve(k)
                for k in (
                    "hue_variation",
                    "saturation_variation",
                    "value_variation",
                    "mutant_fraction",
                )
            )
        else:  # one colour from root to tip, no HSV shifts, no mutants
            pigments = self._pigments(ids)
            root = tip = mutant = melanin_color(
                pigments["melanin"], pigments["melanin_redness"], p.dye
            )
            hue = sat = val = fraction = np.zeros(1)
        ends = hair_ends(
            ids,
            p.seed,
            root,
            tip,
            hue,
            sat,
            val,
            fraction,
            mutant,
            per_curve("root_width"),
            per_curve("tip_width"),
            per_curve("root_opacity"),
            per_curve("tip_opacity"),
        )
        shifts = None
        if "color" in values:
            shifts = hair_shifts(
                ids,
                p.seed,
                per_curve("hue_variation"),
                per_curve("saturation_variation"),
                per_curve("value_variation"),
                per_curve("mutant_fraction"),
            )
        keep = finish(local, length, p.skip_threshold)
        return _Bucket(
            rows, strand, strand_uv, local, n_total, length, keep, t_end, ends, values, shifts
        )

    def _pigments(self, ids: np.ndarray) -> dict[str, np.ndarray]:
        """The curve data of hairs ``ids`` grown from melanin (none without): each
        hair's ``melanin`` and ``melanin_redness`` (:func:`follicle.melanin.hair_pigments`)
        and the ``dye``, float32, what an exported groom's shader reads."""
        p = self.params
        if p.melanin is None:
            return {}
        melanin, redness = hair_pigments(
            ids, p.seed, p.melanin, p.melanin_redness, p.random_melanin, p.random_redness
        )
        dye = np.broadcast_to(np.asarray(p.dye, np.float32), (len(ids), 3)).copy()
        return {"melanin": melanin, "melanin_redness": redness, "dye": dye}

    def _assemble(
        self, lay: _Layout, shaped: _Shaped, out: dict[str, np.ndarray], v: int, c: int
    ) -> None:
        """Shaped hairs packed in (hair id, strand) order, placed on the current pose, into
        ``out`` from vertex ``v`` and curve ``c`` on."""
        buckets, cur, counts = shaped.buckets, shaped.cur, shaped.counts
        if not buckets:
            return
        strands = self.params.strand_count
        keys = np.concatenate([b.rows * strands + b.strand for b in buckets])
        order = np.argsort(keys, kind="stable")
        ends = v + np.cumsum(counts[order])
        start = np.empty(len(keys), dtype=np.int64)
        start[order] = ends - counts[order]
        frame = (cur.position, cur.tangent, cur.binormal, cur.normal)
        first = 0
        for b in buckets:
            m = len(b.rows)
            pack(
                b.points,
                b.length,
                b.keep,
                b.rows,
                frame,
                start[first : first + m],
                b.ends,
                b.t_end,
                b.n_total,
                out,
            )
            pack_values(
                self._inherit,
                b.inherited,
                b.length,
                b.keep,
                start[first : first + m],
                b.t_end,
                b.n_total,
                b.shifts,
                out,
            )
            first += m
        kept = order[counts[order] > 0]
        rows = np.concatenate([b.rows for b in buckets])[kept]
        end = c + len(kept)
        out["counts"][c:end] = counts[kept]
        out["hair_id"][c:end] = lay.ids[rows]
        out["strand_id"][c:end] = np.concatenate([b.strand for b in buckets])[kept]
        out["root_uv"][c:end] = lay.rest.uv[rows]
        out["strand_uv"][c:end] = np.concatenate([b.strand_uv for b in buckets])[kept]
        out["root_triangle"][c:end] = lay.triangles[rows]
        out["root_bary"][c:end] = lay.bary[rows]
        for item in self._inherit:
            if not item.per_vertex:
                values = np.concatenate([b.inherited[item.name][:, 0] for b in buckets])[kept]
                out[item.name][c:end] = values.reshape(len(kept), *item.shape)

    def _fields(self) -> tuple[_Fields, ...]:
        """The output arrays ``[groom].inherit`` adds to the groom's own: (per vertex,
        per curve), name -> (dtype, shape per row)."""
        return tuple(
            {i.name: i.field() for i in self._inherit if i.per_vertex == vertex}
            for vertex in (True, False)
        )

    def _allocate(self, vertices: int, curves: int) -> dict[str, np.ndarray]:
        """Output arrays for at most ``vertices`` vertices and ``curves`` curves, paged in:
        the groom's own and the inherited ones (an inherited look is one of its own)."""
        points, per_curve = self._fields()
        return {
            k: empty_touched((n, *shape), dtype)
            for fields, n in (
                ({**_POINT_FIELDS, **points}, vertices),
                ({**_CURVE_FIELDS, **per_curve}, curves),
            )
            for k, (dtype, shape) in fields.items()
        }

    def _curves(self, out: dict[str, np.ndarray], v: int, c: int) -> HairCurves:
        """HairCurves of the first ``v`` vertices and ``c`` curves of ``out``, with the
        pigments of their hair ids (:meth:`_pigments`) beside their curve data.

        Where cutting or vertex removal left much of the room unused, the arrays are
        copied to their size so the spare memory is given back.
        """

        def fit(a: np.ndarray, n: int) -> np.ndarray:
            return a[:n].copy() if n < 0.75 * len(a) else a[:n]

        points, per_curve = self._fields()
        offsets = np.zeros(c + 1, dtype=np.int64)
        np.cumsum(out["counts"][:c], out=offsets[1:])
        curve_data = {k: fit(out[k], c) for k in {**_CURVE_FIELDS, **per_curve} if k != "counts"}
        return HairCurves(
            fit(out["points"], v),
            offsets,
            point_data={k: fit(out[k], v) for k in {**_POINT_FIELDS, **points} if k != "points"},
            curve_data=curve_data | self._pigments(curve_data["hair_id"]),
        )


def _grows_inside(skin: SDF, guides: HairCurves) -> bool:
    """Whether most guides leave their roots towards the inner side of ``skin`` (their
    first segment against the field's outward normal there): a mesh whose faces wind
    the other way (its normals point into the head), or a sheet with hair on its back.
    Skin collision then keeps hair on the side it grows on, rather than crushing every
    hair onto the skin."""
    first = guides.offsets[:-1][np.diff(guides.offsets) >= 2]
    if len(first) == 0:
        return False
    roots = guides.points[first].astype(np.float64)
    out = skin.distance_and_normal(roots)[1]
    step = guides.points[first + 1].astype(np.float64) - roots
    return float(np.median(np.sum(step * out, axis=1))) < 0.0


def _outside(skin: SDF, inside_out: bool) -> SDF:
    """``skin``, or its field negated when the hair grows on its inner side."""
    if not inside_out:
        return skin
    return SDF(-skin.values, skin.origin, skin.voxel, skin.transform)


def _subset(lay: _Layout, rows: np.ndarray) -> _Layout:
    """The roots ``rows`` of a layout."""
    return _Layout(
        ids=lay.ids[rows],
        triangles=lay.triangles[rows],
        bary=lay.bary[rows],
        rest=SurfacePoints(*(a[rows] for a in lay.rest)),
        group=lay.group[rows],
        guide_index=lay.guide_index[rows],
        guide_weight=lay.guide_weight[rows],
        clump=None if lay.clump is None else lay.clump[rows],
        turn=lay.turn[rows],
    )


def _joined(parts: list[_Layout]) -> _Layout:
    """The layouts of several id ranges as one, in their order."""

    def joined(field: Callable[[_Layout], np.ndarray]) -> np.ndarray:
        return np.concatenate([field(p) for p in parts])

    # all have clumps or none: the layouts of one params (a clump_count change clears them)
    clumps = [p.clump for p in parts if p.clump is not None]
    return _Layout(
        ids=joined(lambda p: p.ids),
        triangles=joined(lambda p: p.triangles),
        bary=joined(lambda p: p.bary),
        rest=SurfacePoints(
            *(np.concatenate(a) for a in zip(*(p.rest for p in parts), strict=True))
        ),
        group=joined(lambda p: p.group),
        guide_index=joined(lambda p: p.guide_index),
        guide_weight=joined(lambda p: p.guide_weight),
        clump=None if parts[0].clump is None else np.concatenate(clumps),
        turn=joined(lambda p: p.turn),
    )


def _spans(start: int, count: int) -> list[tuple[int, int]]:
    """Id ranges of about CHUNK hairs covering [start, start + count), as many as a
    multiple of the worker threads and of equal size, so the threads finish together."""
    if count == 0:
        return []
    threads = workers(-(-count // CHUNK))
    pieces = -(-count // (CHUNK * threads)) * threads
    size = -(-count // pieces)
    return [(a, min(a + size, start + count)) for a in range(start, start + count, size)]
