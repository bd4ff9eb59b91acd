"""Wavefront OBJ polylines: read and write.

Written: ``# follicle hair curves``, every vertex as ``v x y z`` (float32 exactly, see
:mod:`follicle.io.text`), then one ``l i j k …`` line per curve with 1-based indices.
OBJ lines carry positions only: widths, colours and other attributes are not written.

Read: ``v`` and ``l`` records; ``l`` indices may be negative (relative to the vertices
read so far) or ``v/vt`` pairs, and a line ending in ``\\`` continues on the next.
Every ``l`` record becomes one curve of the vertices it lists, in order; other records
(``vt``, ``f``, ``g``, comments, …) are ignored. Errors name the line.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..curves import HairCurves
from ..errors import FormatError
from ..kernels import kernel
from .binary import read_bytes
from .text import join_continued, line_at, parse_number, write_values

__all__ = ["save_obj", "load_obj"]

HEADER = b"# follicle hair curves\n"
_FLT_MAX = np.float32(3.4028235e38)


def save_obj(chunks: Iterator[HairCurves], path: str | os.PathLike[str]) -> Path:
    """Write the curves as OBJ ``v`` and ``l`` records; the ``l`` lines are spooled to a
    temporary file beside ``path`` and appended after every vertex."""
    target = Path(path)
    base = 0
    with (
        atomic_path(target) as tmp,
        open(tmp, "wb") as out,
        tempfile.TemporaryFile(dir=tmp.parent, prefix=".spool.") as lines,
    ):
        out.write(HEADER)
        for chunk in chunks:
            p = chunk.point_count
            if not p:
                continue
            ends = np.zeros(3 * p, dtype=np.uint8)
            ends[2::3] = 1
            ends[-1] = 2
            out.write(b"v ")
            write_values(out, chunk.points.reshape(-1), ends, (b" ", b"\nv ", b"\n"))
            ends = np.zeros(p, dtype=np.uint8)
            ends[chunk.offsets[1:] - 1] = 1
            ends[-1] = 2
            lines.write(b"l ")
            write_values(lines, np.arange(base + 1, base + p + 1), ends, (b" ", b"\nl ", b"\n"))
            base += p
        lines.seek(0)
        shutil.copyfileobj(lines, out, 1 << 22)
    return target


_ERRORS = {
    1: "a 'v' record needs three numbers x y z",
    2: "a vertex coordinate is not finite as float32",
    3: "an 'l' index is not an integer",
    4: "an 'l' index is 0 (OBJ indices start at 1)",
    5: "an 'l' index refers to a vertex that does not exist",
    6: "an 'l' record has fewer than 2 vertices",
}


def load_obj(path: str | os.PathLike[str]) -> HairCurves:
    """Read the ``l`` polylines of an OBJ file as curves (positions only)."""
    p, raw = read_bytes(path)
    buf, joined = join_continued(raw)
    err, at, nv, ni, nl = _scan(
        buf, False, np.empty((0, 3), np.float32), np.empty(0, np.int64), np.empty(0, np.int64), 0
    )
    if not err:
        verts = np.empty((nv, 3), dtype=np.float32)
        index = np.empty(ni, dtype=np.int64)
        counts = np.empty(nl, dtype=np.int64)
        err, at, *_ = _scan(buf, True, verts, index, counts, nv)
    if err:
        raise FormatError(f"{p}: line {line_at(buf, joined, at)}: {_ERRORS[err]}")
    offsets = np.zeros(nl + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    return HairCurves(verts[index], offsets)


@kernel
def _scan(
    buf: np.ndarray,
    fill: bool,
    verts: np.ndarray,
    index: np.ndarray,
    counts: np.ndarray,
    total: int,
) -> tuple[int, int, int, int, int]:
    """Count (``fill`` False: a quick pass over records and ``l`` entries) or parse,
    check and store (``fill`` True) the ``v`` and ``l`` records of ``buf`` (lines).

    Returns (error code, byte position, vertices, indices, curves); ``total`` is the
    file's vertex count, known in the second pass, for forward references.
    """
    n = buf.shape[0]
    i = nv = ni = nl = 0
    while i < n:
        start = i
        while i < n and buf[i] != 10 and buf[i] <= 32:
            i += 1
        keyword = 0
        if i < n and buf[i] > 32 and (i + 1 == n or buf[i + 1] <= 32):  # one letter
            keyword = buf[i]
            i += 1
        if keyword == 118:  # v
            for d in range(3 if fill else 0):
                while i < n and buf[i] != 10 and buf[i] <= 32:
                    i += 1
                value, i, ok = parse_number(buf, i, n)
                if not ok or (i < n and buf[i] > 32):
                    return 1, i, nv, ni, nl
                v32 = np.float32(value)
                if not abs(v32) <= _FLT_MAX:  # inf (NaN is never parsed)
                    return 2, i, nv, ni, nl
                verts[nv, d] = v32
            nv += 1
        elif keyword == 108:  # l
            count = 0
            while True:
                while i < n and buf[i] != 10 and buf[i] <= 32:
                    i += 1
                if i >= n or buf[i] == 10:
                    break
                if fill:
                    code = _index(buf, i, n, nv, total)
                    if code <= 0:
                        return -code, i, nv, ni, nl
                    index[ni] = code - 1
                while i < n and buf[i] > 32:
                    i += 1
                ni += 1
                count += 1
            if count < 2:
                return 6, start, nv, ni, nl
            if fill:
                counts[nl] = count
            nl += 1
        while i < n and buf[i] != 10:  # the rest of the record
            i += 1
        i += 1
    return 0, 0, nv, ni, nl


@kernel
def _index(buf: np.ndarray, i: int, n: int, nv: int, total: int) -> int:
    """The 1-based vertex index of the ``l`` entry at ``i`` (``v`` or ``v/vt``; negative:
    relative to the ``nv`` vertices read so far), or minus an error code."""
    value, i, ok = parse_number(buf, i, n)
    while ok and i < n and buf[i] == 47:  # v/vt: skip the texture index
        i += 1
        while i < n and (48 <= buf[i] <= 57 or buf[i] == 45):
            i += 1
    if not ok or value != np.floor(value) or (i < n and buf[i] > 32):
        return -3
    if value == 0:
        return -4
    if abs(value) > 2.0**53:
        return -5
    v = np.int64(value) if value > 0 else nv + 1 + np.int64(value)
    return v if 1 <= v <= total else -5
