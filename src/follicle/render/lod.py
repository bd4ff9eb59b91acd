"""Level of detail for hair: draw a stable subset of the hairs, widened to keep coverage.

Hair thinner than a pixel covers each pixel in proportion to its width, so a far groom
looks the same when only a share ``f`` of its hairs is drawn, each ``1/f`` times as wide,
for a fraction of the cost. This is the practice of game engines' strand LOD: Unreal's
groom LOD (``CurveDecimation`` per LOD entry, or the Auto mode that reduces the curve
count from screen size, with an automatic thickness increase that compensates the
dropped curves) and AMD TressFX (``LODPercent`` of the strands drawn and their width
scaled by ``LODWidthMultiplier`` between ``LODStartDistance`` and ``LODEndDistance``).

The subset is chosen per hair from a counter-based random number keyed on its
``hair_id`` (:mod:`follicle.rng`, purpose ``"lod"``), so it is the same in every frame,
chunk and process, the strands of one multi-strand fibre go together, and it is nested:
a hair drawn at fraction ``f`` is drawn at every larger fraction, so a fraction that
changes from frame to frame makes hairs appear or vanish only at the margin, never pop.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..rng import uniforms
from ..validate import number, positive
from .camera import Camera
from .options import DEFAULT_HAIR_WIDTH, parse_size

__all__ = ["keep_mask", "thin_out", "lod_fraction"]

_SAMPLE = 4096  # vertices looked at by lod_fraction, at most
_PHI = 0.6180339887498949  # golden ratio - 1
_SEED = 0  # the LOD subset is a property of the hair ids, not of a user seed


def _curves(curves: object) -> HairCurves:
    if not isinstance(curves, HairCurves):
        raise InputError(f"curves: expected a HairCurves, got {type(curves).__name__}")
    return curves


def _fraction(value: object, name: str) -> float:
    return number(value, name, lo=0.0, hi=1.0, lo_open=True)


def _hair_u(curves: HairCurves) -> np.ndarray:
    """Per curve, the hair's number in [0, 1) of the ``"lod"`` stream, float64 (C,)."""
    ids = curves.curve_data.get("hair_id")
    if ids is None:
        ids = np.arange(curves.curve_count, dtype=np.int64)
    elif ids.ndim != 1 or (ids.size and not np.issubdtype(ids.dtype, np.integer)):
        raise InputError(
            f"curve_data['hair_id']: expected integers of shape (C,), got dtype {ids.dtype}"
            f" and shape {ids.shape}; store whole-number ids or drop the key"
        )
    return uniforms(_SEED, ids, "lod", 1)[:, 0]


def _mask(curves: HairCurves, fraction: float) -> np.ndarray:
    if fraction >= 1.0 or curves.curve_count == 0:
        return np.ones(curves.curve_count, dtype=bool)
    u = _hair_u(curves)
    keep = u < fraction
    if not keep.any():  # keep the first hair to enter (all strands of its fibre)
        keep = u <= u.min()
    return keep


def keep_mask(curves: HairCurves, fraction: float) -> np.ndarray:
    """Which curves are drawn at ``fraction`` in (0, 1]: bool (C,).

    Deterministic and nested (see the module docstring); keyed on
    ``curve_data['hair_id']`` when present, else on the curve index. At least one curve
    is kept when there are any; at fraction 1 all of them.
    """
    return _mask(_curves(curves), _fraction(fraction, "fraction"))


def thin_out(
    curves: HairCurves, fraction: float, *, default_width: float = DEFAULT_HAIR_WIDTH
) -> HairCurves:
    """The curves of :func:`keep_mask`, their ``width`` times (curves / curves kept).

    The compensation uses the kept count, not the nominal ``fraction``, so the summed
    width of hairs of one width profile is preserved exactly (of varied widths, on
    average). Curves without a ``width`` get one: ``default_width`` (the renderer's
    ``hair_width``, metres) times the compensation. When nothing is dropped (fraction 1)
    the input itself is returned.
    """
    curves = _curves(curves)
    fraction = _fraction(fraction, "fraction")
    default_width = positive(default_width, "default_width", unit="m")
    keep = _mask(curves, fraction)
    kept = int(np.count_nonzero(keep))
    if kept == curves.curve_count:
        return curves
    scale = curves.curve_count / kept
    thin = curves[keep]
    width = thin.point_data.get("width")
    if width is None:
        thin.point_data["width"] = np.full(thin.point_count, default_width * scale, np.float32)
    else:
        dtype = width.dtype if np.issubdtype(width.dtype, np.floating) else np.float32
        thin.point_data["width"] = (width.astype(np.float64) * scale).astype(dtype)
    return thin


def lod_fraction(
    curves: HairCurves,
    camera: Camera,
    size: Sequence[int],
    max_width_px: float = 1.0,
    min_fraction: float = 0.05,
    *,
    default_width: float = DEFAULT_HAIR_WIDTH,
) -> float:
    """The fraction of hairs to draw for this view: clamp(w / max_width_px, min_fraction, 1).

    ``w`` is the median on-screen width in pixels of a fixed, even sample of at most 4096
    vertices in front of the camera (width / (pixel size at unit depth × view depth));
    hair thinned out at that fraction is then ``max_width_px`` wide on screen. ``size``
    is (width, height) in pixels; ``default_width`` stands in for a missing ``width``.
    With no vertex in front of the camera the answer is 1.
    """
    curves = _curves(curves)
    if not isinstance(camera, Camera):
        raise InputError(f"camera: expected a Camera, got {type(camera).__name__}")
    height = parse_size(size)[1]
    max_width_px = positive(max_width_px, "max_width_px", unit="px")
    min_fraction = _fraction(min_fraction, "min_fraction")
    default_width = positive(default_width, "default_width", unit="m")
    n = curves.point_count
    if n > _SAMPLE:  # golden-ratio spaced: even, and never in step with the vertex count
        sample = (np.arange(_SAMPLE) * _PHI % 1.0 * n).astype(np.int64)
    else:
        sample = np.arange(n)
    pts = curves.points[sample].astype(np.float64)
    width = curves.point_data.get("width")
    w = np.full(len(pts), default_width) if width is None else width[sample].astype(np.float64)
    depth = (pts - camera.eye) @ camera.basis()[2]
    front = depth > 0.0
    if not front.any():
        return 1.0
    px = w[front] / (camera.pixel_scale(height) * depth[front])
    return float(np.clip(np.median(px) / max_width_px, min_fraction, 1.0))
