"""Mitsuba 3 curve files (``.txt``) for the ``bsplinecurve`` shape: read and write.

The file Mitsuba's ``bsplinecurve`` loads: one control point per line, ``x y z
radius``, curves separated by an empty line, each curve at least 4 control points.
Mitsuba's curves are uniform cubic B-splines: smooth (C2) and passing near, not
through, their control points, while follicle's Catmull-Rom curves pass through their
vertices and are only C1, so one cannot be rewritten exactly as the other. The writer
therefore stores, for a curve of n vertices, the n + 2 B-spline control points of
the natural cubic spline that passes through every vertex (and reaches root and tip):
vertex p_j = (c_j + 4 c_{j+1} + c_{j+2}) / 6, with zero curvature at both ends. The
radius (width / 2) is interpolated the same way. Mitsuba then renders a curve through
every follicle vertex, smooth between them and close to the Catmull-Rom curve (on
grown hair, mid-segment a median 0.04 % of the segment length away, at most 8 %, near
the ends, where the end conditions differ). The reader inverts this: it returns the
points where each B-spline segment starts and the last one ends (m − 2 points for m
control points) and width = 2 × radius there, so a written file reads back as the
original vertices (within float32 rounding), and any other B-spline file as the
points its curves pass.
Only positions and widths are stored. (Do not load these files with ``linearcurve``,
which would draw the control polygon.)
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..curves import HairCurves
from ..errors import FormatError
from ..kernels import kernel
from .attributes import widths
from .binary import read_bytes
from .text import line_at, parse_number, write_values

__all__ = ["save_mitsuba", "load_mitsuba", "to_bspline", "from_bspline"]


def to_bspline(values: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """B-spline control points (P + 2C, k) of the natural cubic splines through the rows
    of ``values`` (P, k), curve by curve (``offsets``), float64."""
    from scipy.linalg import solve_banded  # not at import: it costs 0.3 s

    p = np.asarray(values, dtype=np.float64)
    counts = np.diff(offsets)
    curve = np.repeat(np.arange(len(counts)), counts)
    first = np.zeros(len(p), dtype=bool)
    first[offsets[:-1]] = True
    last = np.zeros(len(p), dtype=bool)
    last[offsets[1:] - 1] = True
    rows = np.flatnonzero(~(first | last))  # one unknown per interior vertex
    mid = p.copy()  # c_1 .. c_n of each curve, where c_1 = p_0 and c_n = p_{n-1}
    if rows.size:
        rhs = 6.0 * p[rows]
        rhs -= np.where(first[rows - 1, None], p[rows - 1], 0.0)  # the known c_1
        rhs -= np.where(last[rows + 1, None], p[rows + 1], 0.0)  # the known c_n
        coupled = (np.diff(rows) == 1).astype(np.float64)  # neighbours in one curve
        bands = np.zeros((3, len(rows)))
        bands[0, 1:] = coupled
        bands[1] = 4.0
        bands[2, :-1] = coupled
        mid[rows] = solve_banded((1, 1), bands, rhs, check_finite=False)
    out = np.empty((len(p) + 2 * len(counts), p.shape[1]))
    out[np.arange(len(p)) + 2 * curve + 1] = mid
    starts = offsets[:-1] + 2 * np.arange(len(counts))
    out[starts] = 2.0 * mid[offsets[:-1]] - mid[offsets[:-1] + 1]
    ends = offsets[1:] - 1
    out[starts + counts + 1] = 2.0 * mid[ends] - mid[ends - 1]
    return out


def from_bspline(control: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points (Q − 2C, k) where each uniform cubic B-spline segment starts, plus each
    curve's end, and their offsets: the inverse of :func:`to_bspline`."""
    c = np.asarray(control, dtype=np.float64)
    counts = np.diff(offsets)
    keep = np.ones(len(c), dtype=bool)
    keep[offsets[1:] - 1] = False
    keep[offsets[1:] - 2] = False
    k = np.flatnonzero(keep)
    points = (c[k] + 4.0 * c[k + 1] + c[k + 2]) / 6.0
    new_offsets = np.zeros(len(counts) + 1, dtype=np.int64)
    np.cumsum(counts - 2, out=new_offsets[1:])
    return points, new_offsets


def save_mitsuba(chunks: Iterator[HairCurves], path: str | os.PathLike[str]) -> Path:
    """Write the curves as a Mitsuba ``bsplinecurve`` text file (see the module notes)."""
    target = Path(path)
    with atomic_path(target) as tmp, open(tmp, "wb") as out:
        for chunk in chunks:
            if not chunk.curve_count:
                continue
            rows = np.column_stack([chunk.points, 0.5 * widths(chunk)])
            control = to_bspline(rows, chunk.offsets).astype(np.float32)
            ends = np.zeros(control.shape, dtype=np.uint8)
            ends[:, 3] = 1
            curve_ends = chunk.offsets[1:] + 2 * np.arange(1, chunk.curve_count + 1) - 1
            ends[curve_ends, 3] = 2
            write_values(out, control.reshape(-1), ends.reshape(-1), (b" ", b"\n", b"\n\n"))
    return target


_ERRORS = {
    1: "expected four numbers 'x y z radius'",
    2: "a value is not finite as float32",
    3: "a curve has fewer than 4 control points (Mitsuba's B-splines need 4)",
}


def load_mitsuba(path: str | os.PathLike[str]) -> HairCurves:
    """Read a Mitsuba curve file: the points its B-splines pass, with ``width``."""
    p, buf = read_bytes(path)
    err, at, rows, curves = _scan(buf, False, np.empty((0, 4), np.float32), np.empty(0, np.int64))
    if not err:
        control = np.empty((rows, 4), dtype=np.float32)
        counts = np.empty(curves, dtype=np.int64)
        err, at, *_ = _scan(buf, True, control, counts)
    if err:
        raise FormatError(f"{p}: line {line_at(buf, np.empty(0, np.int64), at)}: {_ERRORS[err]}")
    offsets = np.zeros(curves + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    points, new_offsets = from_bspline(control, offsets)
    return HairCurves(
        points.astype(np.float32)[:, :3],
        new_offsets,
        {"width": (2.0 * points[:, 3]).astype(np.float32)},
    )


@kernel
def _scan(
    buf: np.ndarray, fill: bool, control: np.ndarray, counts: np.ndarray
) -> tuple[int, int, int, int]:
    """Count (``fill`` False) or store the control points and curve sizes of ``buf``:
    (error code, byte position, control points, curves)."""
    n = buf.shape[0]
    i = rows = curves = size = start = 0
    while True:
        line_start = i
        while i < n and buf[i] != 10 and buf[i] <= 32:
            i += 1
        if i >= n or buf[i] == 10:  # an empty line (or the end) closes a curve
            if size:
                if size < 4:
                    return 3, start, rows, curves
                if fill:
                    counts[curves] = size
                curves += 1
                size = 0
            if i >= n:
                break
            i += 1
            continue
        if not size:
            start = line_start
        for d in range(4):
            while i < n and buf[i] != 10 and buf[i] <= 32:
                i += 1
            value, i, ok = parse_number(buf, i, n)
            if not ok or (i < n and buf[i] > 32):
                return 1, i, rows, curves
            v32 = np.float32(value)
            if not abs(v32) <= np.float32(3.4028235e38):
                return 2, i, rows, curves
            if fill:
                control[rows, d] = v32
        while i < n and buf[i] != 10 and buf[i] <= 32:
            i += 1
        if i < n and buf[i] != 10:
            return 1, i, rows, curves
        rows += 1
        size += 1
        i += 1  # past the newline
    return 0, 0, rows, curves
