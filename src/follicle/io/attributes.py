"""Attributes across a chunk stream, for writers of fixed-layout formats.

A file's header says which arrays it holds, so every chunk must carry the attributes
of the first; a format that needs a width the hair lacks writes :data:`DEFAULT_WIDTH`.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

from ..curves import HairCurves
from ..errors import InputError

__all__ = ["DEFAULT_WIDTH", "consistent", "widths"]

DEFAULT_WIDTH = 1e-4  # metres (a 0.1 mm diameter), for hair without point_data['width']


def consistent(chunks: Iterable[HairCurves]) -> Iterator[HairCurves]:
    """The chunks, each checked to carry the same attribute names as the first."""
    first: HairCurves | None = None
    for i, chunk in enumerate(chunks):
        if first is None:
            first = chunk
        elif chunk.point_data.keys() != first.point_data.keys() or \
                chunk.curve_data.keys() != first.curve_data.keys():  # fmt: skip
            raise InputError(
                f"curves: chunk {i} has attributes {sorted(chunk.point_data)} /"
                f" {sorted(chunk.curve_data)}, chunk 0 has {sorted(first.point_data)} /"
                f" {sorted(first.curve_data)}; a file holds the same arrays for every hair"
            )
        yield chunk


def widths(chunk: HairCurves) -> np.ndarray:
    """Per-vertex diameters (P,) float32: ``point_data['width']`` or DEFAULT_WIDTH."""
    if "width" in chunk.point_data:
        return np.asarray(chunk.point_data["width"], dtype=np.float32)
    return np.full(chunk.point_count, DEFAULT_WIDTH, dtype=np.float32)
