"""Cem Yuksel's cyHair ``.hair`` format: read and write.

Little-endian. A 128-byte header: ``HAIR``; uint32 hair count; uint32 point count;
uint32 flags (1 segments array, 2 points, 4 thickness, 8 transparency, 16 colours);
uint32 default segments; float default thickness; float default transparency;
float[3] default colour; char[88] information. Then the arrays present, in this
order: segments (uint16 per hair, vertices − 1), points (float32 × 3), thickness
(float32), transparency (float32) and colours (float32 × 3), one value per point.

Conventions: thickness is follicle's ``width``, the DIAMETER in metres;
transparency = 1 − ``opacity``; colours are ``color`` (linear RGB). The writer omits
the segments array when every hair has the same vertex count (the default segments
say it), omits the arrays of attributes the hair lacks (the defaults then hold:
thickness 0.1 mm, transparency 0, grey 0.5), and writes "follicle" as the
information. A hair may have at most 65,536 vertices (the uint16 segment count).
The reader takes missing arrays from the defaults, so it always returns ``width``,
``opacity`` and ``color``.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..curves import HairCurves
from ..errors import InputError, ResourceError
from .attributes import DEFAULT_WIDTH, consistent
from .binary import BinaryFile, Spool, check_finite, open_binary

__all__ = ["save_cyhair", "load_cyhair"]

MAGIC = b"HAIR"
HEADER = struct.Struct("<4s4I5f88s")  # 128 bytes
SEGMENTS, POINTS, THICKNESS, TRANSPARENCY, COLORS = 1, 2, 4, 8, 16
MAX_VERTICES = 65536  # segments are uint16
DEFAULT_COLOR = (0.5, 0.5, 0.5)
_U32 = 2**32 - 1


def save_cyhair(chunks: Iterator[HairCurves], path: str | os.PathLike[str]) -> Path:
    """Write hair chunks as a cyHair file, streaming: each array goes to its own
    temporary file beside ``path`` and they are joined after the header at the end."""
    target = Path(path)
    names = ("segments", "points", "thickness", "transparency", "colors")
    hairs = points = 0
    first_count, uniform = 0, True  # the segments array is left out when uniform
    flags = POINTS
    with atomic_path(target) as tmp, Spool(tmp.parent, names) as spool:
        for i, chunk in enumerate(consistent(chunks)):
            counts = chunk.counts
            if counts.size and counts.max() > MAX_VERTICES:
                bad = int(np.argmax(counts > MAX_VERTICES))
                raise InputError(
                    f"curves: hair {hairs + bad} has {int(counts[bad])} vertices; cyHair"
                    f" stores at most {MAX_VERTICES} per hair (resample it)"
                )
            if i == 0:
                pd = chunk.point_data
                flags |= (
                    (THICKNESS if "width" in pd else 0)
                    | (TRANSPARENCY if "opacity" in pd else 0)
                    | (COLORS if "color" in pd else 0)
                )
            if counts.size:
                first_count = first_count or int(counts[0])
                uniform = uniform and bool((counts == first_count).all())
            hairs += chunk.curve_count
            points += chunk.point_count
            if points > _U32:
                raise ResourceError(
                    f"curves: {points:,} points; cyHair counts them in a uint32: write fewer"
                    " hairs per file"
                )
            spool.write("segments", (counts - 1).astype("<u2"))
            spool.write("points", np.asarray(chunk.points, "<f4"))
            if flags & THICKNESS:
                spool.write("thickness", np.asarray(chunk.point_data["width"], "<f4"))
            if flags & TRANSPARENCY:
                opacity = chunk.point_data["opacity"].astype(np.float64)
                spool.write("transparency", (1.0 - opacity).astype("<f4"))
            if flags & COLORS:
                spool.write("colors", np.asarray(chunk.point_data["color"], "<f4"))
        flags |= 0 if uniform else SEGMENTS
        header = HEADER.pack(
            MAGIC,
            hairs,
            points,
            flags,
            max(first_count - 1, 0) if uniform else 0,
            DEFAULT_WIDTH,
            0.0,
            *DEFAULT_COLOR,
            b"follicle",
        )
        with open(tmp, "wb") as out:
            out.write(header)
            bits = (SEGMENTS, POINTS, THICKNESS, TRANSPARENCY, COLORS)
            spool.join(out, [n for n, bit in zip(names, bits, strict=True) if flags & bit])
    return target


def load_cyhair(path: str | os.PathLike[str]) -> HairCurves:
    """Read a cyHair file: curves with ``width``, ``opacity`` and ``color`` per point."""
    with open_binary(path) as f:
        magic, hairs, points, flags, dseg, dthick, dtrans, *dcolor, _ = HEADER.unpack(
            f.bytes("header", 0, HEADER.size)
        )
        if magic != MAGIC:
            raise f.fail(f"magic {magic!r} is not b'HAIR'; not a cyHair file")
        if not flags & POINTS:
            raise f.fail(f"header flags {flags:#x} say the file has no points array")
        sizes = {
            "segments": 2 * hairs if flags & SEGMENTS else 0,
            "points": 12 * points,
            "thickness": 4 * points if flags & THICKNESS else 0,
            "transparency": 4 * points if flags & TRANSPARENCY else 0,
            "colors": 12 * points if flags & COLORS else 0,
        }
        if HEADER.size + sum(sizes.values()) > f.size:
            raise f.fail(
                f"header hair_count {hairs} and point_count {points} (flags {flags:#x}) need"
                f" {HEADER.size + sum(sizes.values())} bytes but the file has {f.size}"
            )
        offset = HEADER.size
        counts = _counts(f, hairs, points, dseg, flags, offset)
        offset += sizes["segments"]
        pts = check_finite(f, "points", f.array("points", offset, points, "<f4", (3,)))
        offset += sizes["points"]
        point_data = {
            "width": _per_point(f, flags & THICKNESS, "thickness", offset, points, (), dthick),
        }
        offset += sizes["thickness"]
        transparency = _per_point(
            f, flags & TRANSPARENCY, "transparency", offset, points, (), dtrans
        )
        point_data["opacity"] = (1.0 - transparency.astype(np.float64)).astype(np.float32)
        offset += sizes["transparency"]
        point_data["color"] = _per_point(f, flags & COLORS, "colors", offset, points, (3,), dcolor)
    offsets = np.zeros(len(counts) + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    return HairCurves(pts, offsets, point_data)


def _counts(
    f: BinaryFile, hairs: int, points: int, dseg: int, flags: int, offset: int
) -> np.ndarray:
    """Vertices of every hair, from the segments array or the default segments."""
    if flags & SEGMENTS:
        counts = f.array("segments", offset, hairs, "<u2").astype(np.int64) + 1
        total = int(counts.sum())
        if total != points:
            raise f.fail(f"segments add up to {total} points but header point_count is {points}")
    else:
        if hairs * (dseg + 1) != points:
            raise f.fail(
                f"header hair_count {hairs} × (default segments {dseg} + 1) ="
                f" {hairs * (dseg + 1)} is not point_count {points}"
            )
        counts = np.full(hairs, dseg + 1, dtype=np.int64)
    if counts.size and counts.min() < 2:
        bad = int(np.argmax(counts < 2))
        raise f.fail(f"hair {bad} has 0 segments; every hair needs at least 1")
    return counts


def _per_point(
    f: BinaryFile,
    present: int,
    field: str,
    offset: int,
    points: int,
    shape: tuple[int, ...],
    default: float | list[float],
) -> np.ndarray:
    """A per-point float32 array from the file, or the header default repeated."""
    if present:
        return check_finite(f, field, f.array(field, offset, points, "<f4", shape))
    value = np.asarray(default, dtype=np.float32)
    if not np.isfinite(value).all():
        raise f.fail(f"header default {field} {value.tolist()} is not finite")
    return np.ascontiguousarray(np.broadcast_to(value, (points, *shape)))
