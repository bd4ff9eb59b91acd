"""Attributes across a chunk stream, for the writers.

Every writer takes the hair through :func:`conventional` (``as_chunks`` and
:func:`consistent` call it), so colour, opacity and width reach it in follicle's shapes
whatever made them: a 4-channel RGBA ``color`` (Blender's colour attributes, USD's
``color4f``) is split into RGB and opacity, never written as if it were RGB. A file's
header says which arrays it holds, so every chunk must carry the attributes of the
first; a format that needs a width the hair lacks writes :data:`DEFAULT_WIDTH`.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator

import numpy as np

from ..curves import HairCurves
from ..errors import InputError

__all__ = [
    "DEFAULT_WIDTH",
    "MAX_HAIR_WIDTH",
    "column",
    "conventional",
    "consistent",
    "widths",
    "plausible_widths",
]

log = logging.getLogger("follicle")

DEFAULT_WIDTH = 1e-4  # metres (a 0.1 mm diameter), for hair without point_data['width']
MAX_HAIR_WIDTH = 5e-3  # metres: a median diameter above this is not hair (thick fur is < 1 mm)


def _scalar(chunk: HairCurves, key: str) -> np.ndarray | None:
    """``point_data[key]`` as (P,), from (P,) or (P, 1); None when absent."""
    arr = chunk.point_data.get(key)
    if arr is None or arr.ndim == 1 and arr.dtype.kind in "fiu":
        return arr
    if arr.ndim == 2 and arr.shape[1] == 1 and arr.dtype.kind in "fiu":
        return arr[:, 0]
    raise InputError(
        f"point_data['{key}']: expected one number a point, shape"
        f" ({chunk.point_count},), got {arr.dtype} of shape {arr.shape}"
    )


def column(curves: HairCurves, key: str, comps: int) -> np.ndarray | None:
    """``point_data[key]`` as float32 of ``comps`` components a vertex, or None if absent
    (USD's and Alembic's writers copy it into their own arrays: no copy here)."""
    values = curves.point_data.get(key)
    if values is None:
        return None
    shape = (curves.point_count,) if comps == 1 else (curves.point_count, comps)
    if values.shape != shape:
        raise InputError(f"point_data['{key}']: expected shape {shape}, got {values.shape}")
    return np.asarray(values, dtype=np.float32)


def conventional(chunk: HairCurves) -> HairCurves:
    """``chunk`` with ``color`` as (P, 3) RGB and ``opacity`` and ``width`` as (P,): a
    (P, 4) colour gives its first three channels as ``color`` and its fourth as
    ``opacity`` (unless the hair has an ``opacity`` of its own, which wins), (P, 1)
    columns are flattened. InputError naming the attribute and the shape it needs for
    anything else. The chunk itself when it is already so."""
    pd = chunk.point_data
    fixed: dict[str, np.ndarray] = {}
    color = pd.get("color")
    if color is not None and not (color.ndim == 2 and color.shape[1] == 3):
        if color.ndim != 2 or color.shape[1] != 4 or color.dtype.kind not in "fiu":
            raise InputError(
                f"point_data['color']: expected RGB or RGBA numbers a point, shape"
                f" ({chunk.point_count}, 3) or ({chunk.point_count}, 4), got"
                f" {color.dtype} of shape {color.shape}"
            )
        fixed["color"] = np.ascontiguousarray(color[:, :3])
        if "opacity" not in pd:
            fixed["opacity"] = np.ascontiguousarray(color[:, 3])
    for key in ("opacity", "width"):
        arr = _scalar(chunk, key)
        if arr is not pd.get(key):
            fixed[key] = np.ascontiguousarray(arr)
    if not fixed:
        return chunk
    return HairCurves(chunk.points, chunk.offsets, {**pd, **fixed}, chunk.curve_data)


def consistent(chunks: Iterable[HairCurves]) -> Iterator[HairCurves]:
    """The chunks, :func:`conventional`, each checked to carry the same attribute names
    as the first."""
    first: HairCurves | None = None
    for i, chunk in enumerate(chunks):
        chunk = conventional(chunk)
        if first is None:
            first = chunk
        elif (
            chunk.point_data.keys() != first.point_data.keys()
            or chunk.curve_data.keys() != first.curve_data.keys()
        ):
            raise InputError(
                f"curves: chunk {i} has attributes {sorted(chunk.point_data)} /"
                f" {sorted(chunk.curve_data)}, chunk 0 has {sorted(first.point_data)} /"
                f" {sorted(first.curve_data)}; a file holds the same arrays for every hair"
            )
        yield chunk


def widths(chunk: HairCurves) -> np.ndarray:
    """Per-vertex diameters (P,) float32: ``point_data['width']`` or DEFAULT_WIDTH."""
    width = _scalar(chunk, "width")
    if width is not None:
        return np.asarray(width, dtype=np.float32)
    return np.full(chunk.point_count, DEFAULT_WIDTH, dtype=np.float32)


def plausible_widths(curves: HairCurves, source: object) -> None:
    """Log one warning naming ``source`` when the hair's median ``width`` is over
    MAX_HAIR_WIDTH: a tool's default radius (Blender's 1 cm gives 2 cm widths), not
    hair, which renders as thick tubes until the widths are fixed."""
    width = curves.point_data.get("width")
    if width is None or not width.size:
        return
    median = float(np.median(width))
    if median > MAX_HAIR_WIDTH:
        log.warning(
            "%s: widths look like a tool's default radius, not hair: the median width"
            " (diameter) is %.3g m, hair is 2e-5 to 2e-4 m; fix: set the curves' radius"
            " where they were made (Blender: the Radius attribute) or scale"
            " point_data['width'] before rendering",
            source,
            median,
        )
