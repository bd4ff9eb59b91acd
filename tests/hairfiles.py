"""Hair shared by the format tests: random curves, and TressFX 3 files built by hand."""

from __future__ import annotations

import struct

import numpy as np

from follicle import HairCurves


def hair(counts: tuple[int, ...] = (4, 6, 2, 5), seed: int = 0, uv: bool = True) -> HairCurves:
    """Random-walk curves with width, color and opacity (and root_uv)."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(scale=0.01, size=(sum(counts), 3))
    ends = np.cumsum(counts)
    pts = np.concatenate([np.cumsum(s, axis=0) for s in np.split(steps, ends[:-1])])
    p = len(pts)
    point_data = {"width": rng.uniform(2e-5, 1e-4, p).astype(np.float32),
                  "color": rng.random((p, 3)).astype(np.float32),
                  "opacity": rng.random(p).astype(np.float32)}
    curve_data = {"root_uv": rng.random((len(counts), 2)).astype(np.float32)} if uv else {}
    return HairCurves.from_polylines(np.split(pts, ends[:-1]), point_data, curve_data)


def tfx3_table(strands: int, n: int, vertices: object, thickness: object = None,
               uv: object = None, colors: object = None) -> bytes:
    """A TressFX 3 file with the offset table of TressFX 3's TressFXFileFormat.h: the
    144-byte preamble, six offsets and 32 reserved uints, then 8-aligned sections."""
    sections, offsets, end = [], [0] * 6, 296
    for slot, arr in ((0, vertices), (1, thickness), (2, uv), (3, colors)):
        if arr is not None:
            data = np.asarray(arr, "<f4").tobytes()
            data += bytes(-len(data) % 8)
            offsets[slot] = end
            sections.append(data)
            end += len(data)
    head = struct.pack("<f4I31I", 3.0, strands, n, 2, 0, *[0] * 31)
    return head + struct.pack("<6I32I", *offsets, *[0] * 32) + b"".join(sections)
