"""What the animation writers (USD, Alembic) take, checked once for both: the frames
(HairCurves, or a SimCache's guide strands), their fps and first frame, and the head
transforms that move the skin; and the guides a groom writer adds beside the hair."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from ..curves import HairCurves
from ..errors import InputError

if TYPE_CHECKING:
    from ..mesh.skin import SkinMesh
    from ..sim.cache import SimCache

__all__ = ["Animation", "animation", "as_guides", "head_matrices"]

Animation = tuple[Iterable[HairCurves], float, int, "np.ndarray | None"]


def as_guides(guides: object) -> HairCurves:
    """The HairCurves of a Guides object (or HairCurves themselves); InputError else."""
    curves = getattr(guides, "curves", guides)
    if not isinstance(curves, HairCurves):
        raise InputError(f"guides: expected HairCurves or Guides, got {type(guides).__name__}")
    return curves


def head_matrices(transforms: object) -> np.ndarray:
    """``transforms`` as (F, 4, 4) float64 affine matrices acting on column vectors
    (``p' = M @ p``, translation in the last column, as a SimCache keeps them);
    InputError naming the first bad one."""
    try:
        m = np.asarray(transforms, dtype=np.float64)
    except (TypeError, ValueError):
        m = np.zeros(0)
    if m.ndim != 3 or m.shape[1:] != (4, 4):
        raise InputError(f"transforms: expected one 4x4 matrix per frame, shape (F, 4, 4),"
                         f" got {m.shape if m.size else repr(transforms)[:60]}")  # fmt: skip
    bad = ~np.isfinite(m).all(axis=(1, 2)) | (np.abs(m[:, 3] - (0, 0, 0, 1)).max(axis=1) > 1e-9)
    if np.any(bad):
        f = int(np.argmax(bad))
        raise InputError(f"transforms: frame {f} is not a finite affine matrix (last row"
                         f" {m[f, 3].tolist()}, expected [0, 0, 0, 1])")  # fmt: skip
    return m


def animation(frames: Iterable[HairCurves] | SimCache, fps: float | None, start: int,
              mesh: SkinMesh | None, transforms: object | None) -> Animation:  # fmt: skip
    """(frames, fps, start, head transforms or None), checked: a SimCache gives its guide
    strands per frame, its fps (unless ``fps``; else 24) and, when ``mesh`` is given, its
    head transforms (unless ``transforms``); transforms without a mesh are refused."""
    positions = getattr(frames, "positions", None)
    cache_fps = cache_transforms = None
    if isinstance(positions, np.ndarray) and positions.ndim == 4:
        cache_fps, cache_transforms = float(frames.fps), frames.transforms
        frames = (HairCurves.from_array(p) for p in positions)
    elif isinstance(frames, HairCurves) or not isinstance(frames, Iterable):
        raise InputError(f"frames: expected an iterable of HairCurves or a SimCache, got"
                         f" {type(frames).__name__}")  # fmt: skip
    if transforms is not None and mesh is None:
        raise InputError("transforms: given without mesh=; they move the skin mesh, so pass"
                         " the SkinMesh too")  # fmt: skip
    if mesh is not None and transforms is None:
        transforms = cache_transforms
    head = None if transforms is None else head_matrices(transforms)
    rate = fps if fps is not None else cache_fps if cache_fps is not None else 24.0
    real = (int, float, np.integer, np.floating)
    if isinstance(rate, bool) or not isinstance(rate, real) or not 0 < rate < np.inf:
        raise InputError(f"fps: expected a finite number > 0, got {rate!r}")
    if isinstance(start, bool) or not isinstance(start, (int, np.integer)):
        raise InputError(f"start: expected a whole number (the first frame), got {start!r}")
    return frames, float(rate), int(start), head
