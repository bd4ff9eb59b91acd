"""PBRT-v4 scene include file (``.pbrt``) of the hair: write only.

``Include "hair.pbrt"`` inside a scene's world block. The file defines the named
material ``follicle_hair`` (pbrt's ``hair`` material with its defaults), then one
``AttributeBegin`` block that uses it and holds one ``Shape "curve"`` per hair:
``"string type" "cylinder"``, the cubic Bézier control points of every Catmull-Rom
segment in one ``"point3 P"`` list (3n + 1 points for n segments, which pbrt-v4
splits into n curves; its defaults ``"string basis" "bezier"`` and ``"integer degree"
3`` apply), and the widths at root and tip as ``"float width0"`` /
``"float width1"`` (diameters, as in follicle; pbrt varies the width linearly over
the segments between them, so inner widths are not kept). The segment from P_i to
P_{i+1} has control points P_i, P_i + (P_{i+1} − P_{i−1}) / 6, P_{i+1} − (P_{i+2} −
P_i) / 6, P_{i+1}, with P_{−1} = P_0 and P_n = P_{n−1} duplicated at the ends: the
same curve exactly. Colour and opacity are not written (one material for all hairs).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from .. import spline
from ..atomic import atomic_path
from ..curves import HairCurves
from .attributes import widths
from .text import write_values

__all__ = ["save_pbrt"]

PREAMBLE = b"""# follicle hair curves for pbrt-v4: Include this file inside the world block.
MakeNamedMaterial "follicle_hair" "string type" "hair"
AttributeBegin
  NamedMaterial "follicle_hair"
"""
_SHAPE = b'  Shape "curve" "string type" "cylinder" "float width0" '
# literal after each value: width0, width1, a coordinate, a curve's last coordinate
_LITERALS = (b' "float width1" ', b' "point3 P" [ ', b" ", b" ]\n" + _SHAPE, b" ]\n")


def save_pbrt(chunks: Iterator[HairCurves], path: str | os.PathLike[str]) -> Path:
    """Write the curves as a pbrt-v4 include file of Bézier ``curve`` shapes."""
    target = Path(path)
    with atomic_path(target) as tmp, open(tmp, "wb") as out:
        out.write(PREAMBLE)
        for chunk in chunks:
            if chunk.curve_count:
                out.write(_SHAPE)
                values, ends = _curve_values(chunk)
                write_values(out, values, ends, _LITERALS)
        out.write(b"AttributeEnd\n")
    return target


def _curve_values(chunk: HairCurves) -> tuple[np.ndarray, np.ndarray]:
    """Per curve: width0, width1 and its 3n + 1 Bézier control points, flat (float32),
    and the index of the literal that follows each value."""
    offsets, counts = chunk.offsets, chunk.counts
    bezier = spline.to_bezier(chunk.points, offsets).astype(np.float32)  # (P - C, 4, 3)
    segment_offsets = offsets - np.arange(len(offsets))
    controls = 3 * (counts - 1) + 1
    control_offsets = np.zeros(len(offsets), dtype=np.int64)
    np.cumsum(controls, out=control_offsets[1:])
    points = np.empty((control_offsets[-1], 3), dtype=np.float32)
    seg_curve = np.repeat(np.arange(chunk.curve_count), counts - 1)
    seg_in_curve = np.arange(len(bezier)) - segment_offsets[seg_curve]
    at = control_offsets[seg_curve] + 3 * seg_in_curve
    for j in range(3):
        points[at + j] = bezier[:, j]
    points[control_offsets[1:] - 1] = bezier[segment_offsets[1:] - 1, 3]
    w = widths(chunk)
    sizes = 2 + 3 * controls  # values per curve
    starts = np.zeros(chunk.curve_count, dtype=np.int64)
    np.cumsum(sizes[:-1], out=starts[1:])
    values = np.empty(int(sizes.sum()), dtype=np.float32)
    ends = np.full(len(values), 2, dtype=np.uint8)
    values[starts] = w[offsets[:-1]]
    values[starts + 1] = w[offsets[1:] - 1]
    ends[starts] = 0
    ends[starts + 1] = 1
    coords = np.ones(len(values), dtype=bool)
    coords[starts] = coords[starts + 1] = False
    values[coords] = points.reshape(-1)
    ends[starts + sizes - 1] = 3
    ends[-1] = 4
    return values, ends
