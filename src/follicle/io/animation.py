"""What the animation writers (USD, Alembic) take, checked once for both: the frames
(HairCurves, or a SimCache's guide strands) as the target reads them, their fps and
first frame, and the head transforms that move the skin; and the guides a groom writer
adds beside the hair."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, TypeGuard

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..validate import positive, whole
from .attributes import conventional
from .targets import Target, for_target, get_target

if TYPE_CHECKING:
    from ..mesh.skin import SkinMesh
    from .sim_cache import SimCache

__all__ = ["Animation", "animation", "as_guides", "head_matrices"]


@dataclass(frozen=True)
class Animation:
    """An animation checked for writing: ``frames`` yields each frame as the target
    reads it (checked as it comes: HairCurves, frame 0's topology, one head transform
    or skin each; the stream's end checks it was not empty and used every one), at
    ``fps`` from frame ``start``; ``head`` (F, 4, 4) moves the skin (translations in the
    target's units), or None; ``skin`` (F, V, 3) float32, the deforming skin's vertices
    per frame (in the target's units), or None."""

    frames: Iterator[HairCurves]
    fps: float
    start: int
    head: np.ndarray | None
    skin: np.ndarray | None = None


def as_guides(guides: object) -> HairCurves:
    """The HairCurves of a Guides object (or HairCurves themselves); InputError else."""
    curves = getattr(guides, "curves", guides)
    if not isinstance(curves, HairCurves):
        raise InputError(f"guides: expected HairCurves or Guides, got {type(guides).__name__}")
    return curves


def target_guides(guides: object | None, tool: Target, in_units: bool = True) -> HairCurves | None:
    """``guides`` (Guides or HairCurves; None for none) as a writer for ``tool`` stores
    them: the conventional attributes, named, typed and (``in_units``) scaled for it;
    for a tool that reads interpolation groups (Unreal's ``groom_group_id``) a Guides
    object's ``group`` as ``curve_data['group']``."""
    if guides is None:
        return None
    curves = conventional(as_guides(guides))
    group = getattr(guides, "group", None)  # a Guides object's interpolation groups
    if tool.groups and group is not None and "group" not in curves.curve_data:
        curve_data = {**curves.curve_data, "group": np.asarray(group, np.int32)}
        curves = HairCurves(curves.points, curves.offsets, curves.point_data, curve_data)
    return for_target(curves, tool, "guides", in_units)


def with_groups(curves: HairCurves, guides: object | None, tool: Target) -> HairCurves:
    """Hair ``curves`` with the interpolation group each grew in, for a ``tool`` that
    reads groups (Unreal's ``groom_group_id``, Unity's strand groups): from its root UV
    through a Guides object's groups, as the generator finds it
    (``curve_data['group']``); as they are when they have one, or have no root UVs, or
    ``guides`` has no groups."""
    groups = getattr(guides, "groups", None)
    data = curves.curve_data
    if not tool.groups or groups is None or "group" in data or "root_uv" not in data:
        return curves
    group = groups.group_of(data["root_uv"])
    return HairCurves(curves.points, curves.offsets, curves.point_data, {**data, "group": group})


def head_matrices(transforms: object) -> np.ndarray:
    """``transforms`` as (F, 4, 4) float64 affine matrices acting on column vectors
    (``p' = M @ p``, translation in the last column, as a SimCache keeps them);
    InputError naming the first bad one."""
    try:
        m = np.asarray(transforms, dtype=np.float64)
    except (TypeError, ValueError):
        m = np.zeros(0)
    if m.ndim != 3 or m.shape[1:] != (4, 4):
        raise InputError(
            f"transforms: expected one 4x4 matrix per frame, shape (F, 4, 4),"
            f" got {m.shape if m.size else repr(transforms)[:60]}"
        )
    bad = ~np.isfinite(m).all(axis=(1, 2)) | (np.abs(m[:, 3] - (0, 0, 0, 1)).max(axis=1) > 1e-9)
    if np.any(bad):
        f = int(np.argmax(bad))
        raise InputError(
            f"transforms: frame {f} is not a finite affine matrix (last row"
            f" {m[f, 3].tolist()}, expected [0, 0, 0, 1])"
        )
    return m


def _checked(
    frames: Iterable[object],
    poses: tuple[str, str, np.ndarray] | None,
    target: Target,
    role: str,
    in_units: bool,
) -> Iterator[HairCurves]:
    """Each frame checked and as ``target`` reads it (see :class:`Animation`); ``poses``:
    (argument, what one is, the poses), one a frame."""
    first = None
    f = -1
    for f, frame in enumerate(frames):
        if not isinstance(frame, HairCurves):
            raise InputError(f"frames: frame {f} is a {type(frame).__name__}, not HairCurves")
        if poses is not None and f >= len(poses[2]):
            name, what, given = poses
            raise InputError(
                f"{name}: {len(given)} {what} for {f + 1} or more frames; give one per frame"
            )
        if first is not None and not np.array_equal(frame.offsets, first.offsets):
            raise InputError(
                f"frames: frame {f} has {frame.curve_count} curves / {frame.point_count} points"
                f" laid out differently from frame 0 ({first.curve_count} / {first.point_count});"
                " every frame must share the first frame's topology"
            )
        if first is None:
            first = frame
        yield for_target(conventional(frame), target, role, in_units)
    if first is None:
        raise InputError("frames: the frame stream is empty; nothing to write")
    if poses is not None and len(poses[2]) != f + 1:
        name, what, given = poses
        raise InputError(f"{name}: {len(given)} {what} for {f + 1} frames; give one per frame")


class _CacheFrames(Protocol):
    """What :func:`animation` reads of a SimCache (or of anything holding its arrays):
    guide ``positions`` (F, S, N, 3), head ``transforms``, ``fps``, ``skin_vertices``."""

    @property
    def positions(self) -> np.ndarray: ...
    @property
    def transforms(self) -> np.ndarray: ...
    @property
    def fps(self) -> float: ...
    @property
    def skin_vertices(self) -> np.ndarray | None: ...


def _is_cache(frames: object) -> TypeGuard[_CacheFrames]:
    """Whether ``frames`` is a simulation cache: its ``positions`` are (F, S, N, 3)."""
    positions = getattr(frames, "positions", None)
    return isinstance(positions, np.ndarray) and positions.ndim == 4


def animation(
    frames: Iterable[HairCurves] | SimCache,
    fps: float | None,
    start: int,
    mesh: SkinMesh | None,
    transforms: object | None,
    target: Target | str = "generic",
    in_units: bool = True,
    role: str | None = None,
    skin_vertices: object | None = None,
) -> Animation:
    """The animation to write, checked: a SimCache gives its guide strands per frame
    (written as guides unless ``role`` says "hair"; other frames as hair unless it says
    "guides"), its fps (unless ``fps``; else 24) and, when ``mesh`` is given,
    its head transforms or its animated skin's vertices (unless ``transforms`` or
    ``skin_vertices``, (F, V, 3) for the V vertices of ``mesh``); either without a mesh
    is refused, and so are both. ``target`` and ``in_units`` as
    :func:`follicle.io.targets.for_target` takes them."""
    tool = get_target(target)
    if role not in (None, "hair", "guides"):
        raise InputError(f"role: expected 'hair', 'guides' or None, got {role!r}")
    cache_fps: float | None = None
    cache_transforms: np.ndarray | None = None
    cache_skin: np.ndarray | None = None
    if _is_cache(frames):
        role = role if role is not None else "guides"
        cache_fps, cache_transforms = float(frames.fps), frames.transforms
        cache_skin = frames.skin_vertices
        frames = (HairCurves.from_array(p) for p in frames.positions)
    elif isinstance(frames, HairCurves) or not isinstance(frames, Iterable):
        raise InputError(
            f"frames: expected an iterable of HairCurves or a SimCache, got {type(frames).__name__}"
        )
    else:
        role = role if role is not None else "hair"
    for name, given in (("transforms", transforms), ("skin_vertices", skin_vertices)):
        if given is not None and mesh is None:
            raise InputError(
                f"{name}: given without mesh=; they move the skin mesh, so pass the SkinMesh too"
            )
    if transforms is not None and skin_vertices is not None:
        raise InputError("transforms and skin_vertices both pose the skin: give one")
    if mesh is not None and transforms is None and skin_vertices is None:
        transforms, skin_vertices = (
            (cache_transforms, None) if cache_skin is None else (None, cache_skin)
        )
    scale = tool.scale if in_units else 1.0
    head = skin = poses = None
    if transforms is not None:
        head = head_matrices(transforms)
        if scale != 1.0:
            head = head.copy()
            head[:, :3, 3] *= scale
        poses = ("transforms", "matrices", head)
    if skin_vertices is not None:
        assert mesh is not None  # refused above without one; a cache's skin is used with one
        skin = _skin_frames(skin_vertices, mesh) * np.float32(scale)
        poses = ("skin_vertices", "skins", skin)
    rate = positive(fps if fps is not None else cache_fps if cache_fps is not None else 24.0, "fps")
    start = whole(start, "start", what="a whole number (the first frame)")
    return Animation(_checked(frames, poses, tool, role, in_units), rate, start, head, skin)


def _skin_frames(vertices: object, mesh: SkinMesh) -> np.ndarray:
    """``vertices`` as (F, V, 3) float32 finite poses of ``mesh``; InputError else."""
    try:
        v = np.asarray(vertices, dtype=np.float32)
    except (TypeError, ValueError):
        v = np.zeros(0, np.float32)
    rest = getattr(mesh, "rest_vertices", None)
    if rest is None:
        raise InputError(f"mesh: expected a SkinMesh, got {type(mesh).__name__}")
    count = len(rest)
    if v.ndim != 3 or v.shape[1:] != (count, 3):
        raise InputError(
            f"skin_vertices: expected one pose of the mesh's {count:,} vertices per frame,"
            f" shape (F, {count}, 3), got {v.shape}"
        )
    if not np.isfinite(v).all():
        f = int(np.argmin(np.isfinite(v).reshape(len(v), -1).all(axis=1)))
        raise InputError(f"skin_vertices: frame {f} contains NaN or inf")
    return v
