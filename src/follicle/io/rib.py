"""RenderMan RIB text: hair as ``Curves "cubic" … "nonperiodic"`` with the Catmull-Rom basis.

The file starts ``##RenderMan RIB`` / ``version 3.04`` and holds one
``AttributeBegin`` … ``AttributeEnd`` block: ``Basis "catmull-rom" 1 "catmull-rom" 1``,
then one ``Curves`` request per chunk of the stream. Each curve's first and last vertex
are written twice, so an n-vertex hair has n + 2 control vertices, n − 1 segments and
spans root to tip exactly as follicle's own spline does (end points duplicated, seed
Fig. 2.8). A nonperiodic cubic curve with vstep 1 takes (n + 2 − 4) + 1 + 1 = n varying
values (RISpec: Σ(nsegs + 1)), so every varying variable is the hair's own per-vertex data:

- ``"P"`` (vertex): the n + 2 control vertices;
- ``"width"`` (varying float, diameter; ``"constantwidth" [0.0001]`` for hair without
  widths, since RenderMan's default is 1 unit), ``"Cs"`` (varying color), ``"Os"`` (varying
  color: the opacity in all three channels), ``"N"`` (varying normal, when the curves carry
  normals and ``normals=True``; N makes RenderMan draw ribbons facing it);
- per curve (Šik 2012 §2.3.5): ``"uniform float[2] hair_uv"`` (root_uv), ``"uniform float[2]
  strand_uv"`` (strand_uv, else root_uv), ``"uniform int hair_index"`` (hair_id, else the
  curve's place in the file) and ``"uniform int strand_index"`` (strand_id, else 0); ``int``
  is the RISpec's ``integer`` as RenderMan spells it, exact where a float would not be.

Numbers are printed like C's ``%.7g`` (7 significant digits; the same curves give the same
bytes) by a compiled kernel, a block at a time. :func:`save_rib_motion` writes deformation
motion blur: ``MotionBegin [t0 t1 …]`` with one ``Curves`` per time sample;
:func:`write_block` the attribute block alone (a RenderMan procedural's reply).
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..atomic import atomic_path
from ..curves import HairCurves
from ..errors import InputError
from ..kernels import kernel, prange
from .attributes import DEFAULT_WIDTH, conventional
from .stream import Curves, as_chunks
from .text import write_values

__all__ = ["save_rib", "save_rib_motion", "write_block", "format_floats"]

_VERSION = b"##RenderMan RIB\nversion 3.04\n"
_BEGIN = b'AttributeBegin\n  Basis "catmull-rom" 1 "catmull-rom" 1\n'
_FOOTER = b"AttributeEnd\n"
_BLOCK = 1 << 20  # numbers formatted at a time
_INT32_MAX = 2**31 - 1
_POW10 = np.array([float(f"1e{k}") for k in range(-64, 65)])  # correctly rounded 10^k
_LOG10_2 = math.log10(2.0)


# ------------------------------------------------------------------ number formatting
@kernel
def _put_float(x: float, out: np.ndarray, pos: int, digits: np.ndarray) -> int:
    """Write ``x`` as C's %.7g would into ``out`` at ``pos`` (``digits``: 7 bytes of
    scratch); return the new position. Unsigned multiply-shift digits: no divisions."""
    if x == 0.0:
        out[pos] = 48
        return pos + 1
    if x < 0.0:
        out[pos] = 45
        pos += 1
        x = -x
    e = int(math.floor((math.frexp(x)[1] - 1) * _LOG10_2))  # e or e - 1
    if x >= _POW10[e + 65]:
        e += 1
    for _ in range(2):  # x · 10^(6 − e) as a 7-digit integer; twice if e was one too high
        m = np.rint(x * _POW10[70 - e]) if e <= 6 else np.rint(x / _POW10[e + 58])
        if m >= 1e6:
            break
        e -= 1
    if m >= 1e7:  # rounded up to the next power of ten
        e += 1
        m = 1e6
    mant = np.uint64(m)
    for k in range(6, -1, -1):
        q = (mant * np.uint64(0xCCCCCCCD)) >> np.uint64(35)  # mant // 10 for mant < 2^32
        digits[k] = 48 + (mant - q * np.uint64(10))
        mant = q
    ndig = 7
    while digits[ndig - 1] == 48:
        ndig -= 1
    if -4 <= e < 7:  # fixed notation
        if e < 0:
            out[pos] = 48
            out[pos + 1] = 46
            pos += 2
            for _ in range(-e - 1):
                out[pos] = 48
                pos += 1
            for k in range(ndig):
                out[pos] = digits[k]
                pos += 1
            return pos
        for k in range(e + 1):
            out[pos] = digits[k] if k < ndig else 48
            pos += 1
        if ndig > e + 1:
            out[pos] = 46
            pos += 1
            for k in range(e + 1, ndig):
                out[pos] = digits[k]
                pos += 1
        return pos
    out[pos] = digits[0]
    pos += 1
    if ndig > 1:
        out[pos] = 46
        pos += 1
        for k in range(1, ndig):
            out[pos] = digits[k]
            pos += 1
    out[pos] = 101
    out[pos + 1] = 45 if e < 0 else 43
    ae = -e if e < 0 else e
    out[pos + 2] = 48 + ae // 10
    out[pos + 3] = 48 + ae % 10
    return pos + 4


@kernel(parallel=True)
def _format_parts(values: np.ndarray, per_line: int, parts: int, out: np.ndarray) -> np.ndarray:
    """Format ``values`` in ``parts`` runs of whole lines, run p into ``out`` from
    16 · (its first index); return each run's byte count."""
    n = values.size
    lines = (n + per_line - 1) // per_line
    lengths = np.zeros(parts, np.int64)
    for p in prange(parts):
        a = min(n, (lines * p // parts) * per_line)
        b = min(n, (lines * (p + 1) // parts) * per_line)
        digits = np.empty(7, np.uint8)
        pos = 16 * a
        for i in range(a, b):
            if i > a:
                out[pos] = 10 if i % per_line == 0 else 32
                pos += 1
            pos = _put_float(np.float64(values[i]), out, pos, digits)
        lengths[p] = pos - 16 * a
    return lengths


def _write_floats(fh: BinaryIO, values: np.ndarray, per_line: int) -> None:
    """``values`` (any shape) as %.7g numbers, ``per_line`` to a line, a block at a time."""
    flat = np.ascontiguousarray(values, dtype=np.float32).reshape(-1)
    block = _BLOCK - _BLOCK % per_line
    out = np.empty(16 * min(block, flat.size), dtype=np.uint8)
    import numba

    parts = numba.get_num_threads()
    for a in range(0, flat.size, block):
        run = flat[a : a + block]
        lengths = _format_parts(run, per_line, parts, out)
        lines = -(-run.size // per_line)
        for p, length in enumerate(lengths.tolist()):
            start = 16 * min(run.size, (lines * p // parts) * per_line)
            if length:
                fh.write(b"\n" if a or start else b"")
                fh.write(out.data[start : start + length])  # out: 1-D uint8


def format_floats(values: np.ndarray, per_line: int = 12) -> bytes:
    """``values`` (float32, any shape) as C's %.7g numbers, ``per_line`` to a line."""
    buffer = io.BytesIO()
    _write_floats(buffer, values, per_line)
    return buffer.getvalue()


def _write_ints(fh: BinaryIO, values: np.ndarray) -> None:
    """Whole numbers (1-D, non-empty) on one line, a blank between them."""
    ends = np.zeros(len(values), dtype=np.uint8)
    ends[-1] = 1
    write_values(fh, values, ends, (b" ", b""))


# ------------------------------------------------------------------ Curves requests
def _with_end_copies(values: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Per-vertex ``values`` with each curve's first and last row written twice."""
    c = len(offsets) - 1
    shift = 2 * np.arange(c)
    out = np.empty((len(values) + 2 * c,) + values.shape[1:], values.dtype)
    out[np.arange(len(values)) + np.repeat(shift + 1, np.diff(offsets))] = values
    out[offsets[:-1] + shift] = values[offsets[:-1]]
    out[offsets[1:] + shift + 1] = values[offsets[1:] - 1]
    return out


def _indices(curves: HairCurves, key: str, default: np.ndarray) -> np.ndarray:
    values = curves.curve_data.get(key)
    if values is None:
        return default
    if values.ndim != 1 or values.dtype.kind not in "iu" and not np.all(np.mod(values, 1) == 0):
        raise InputError(
            f"curve_data['{key}']: expected whole numbers (C,), got {values.dtype} {values.shape}"
        )
    if values.size and (values.min() < -_INT32_MAX - 1 or values.max() > _INT32_MAX):
        raise InputError(f"curve_data['{key}']: values beyond RIB's 32-bit int range")
    return values.astype(np.int64)


def _curves(fh: BinaryIO, curves: HairCurves, first_index: int, normals: bool) -> None:
    """One ``Curves`` request of ``curves`` (the first curve's default hair_index is
    ``first_index``)."""
    curves = conventional(curves)  # motion samples come here without as_chunks
    offs, pd, cd = curves.offsets, curves.point_data, curves.curve_data
    c = curves.curve_count
    hair_index = _indices(curves, "hair_id", np.arange(first_index, first_index + c))
    strand_index = _indices(curves, "strand_id", np.zeros(c, np.int64))
    fh.write(b'  Curves "cubic" [')
    _write_ints(fh, curves.counts + 2)
    fh.write(b']\n    "nonperiodic"\n    "P" [')
    _write_floats(fh, _with_end_copies(curves.points, offs), 12)
    if "width" not in pd:  # RenderMan's own default width is 1 unit: a metre
        fh.write(f']\n    "constantwidth" [{DEFAULT_WIDTH:g}'.encode())
    varying = [("width", "width", 1), ("color", "Cs", 3), ("opacity", "Os", 1)]
    if normals:
        varying.append(("normal", "N", 3))
    for key, token, comps in varying:
        if key not in pd:
            continue
        values = pd[key].reshape(len(pd[key]), -1)
        if values.shape[1] != comps:
            raise InputError(
                f"point_data['{key}']: expected {comps} values a vertex for"
                f' "{token}", got shape {pd[key].shape}'
            )
        if token == "Os":
            values = np.repeat(values, 3, axis=1)  # RIB opacity is a colour
        fh.write(f']\n    "{token}" ['.encode())
        _write_floats(fh, values, 12)
    uv = cd.get("root_uv")
    for name, uvs in (("hair_uv", uv), ("strand_uv", cd.get("strand_uv", uv))):
        if uvs is None:
            continue
        if uvs.shape != (c, 2):
            raise InputError(
                f'curve_data uv for "{name}": expected shape ({c}, 2), got {uvs.shape}'
            )
        fh.write(f']\n    "uniform float[2] {name}" ['.encode())
        _write_floats(fh, uvs, 12)
    for name, values in (("hair_index", hair_index), ("strand_index", strand_index)):
        fh.write(f']\n    "uniform int {name}" ['.encode())
        _write_ints(fh, values)
    fh.write(b"]\n")


def save_rib(curves: Curves, path: str | os.PathLike[str], normals: bool = True) -> Path:
    """Write ``curves`` (HairCurves or a stream of chunks) as a RIB archive, one
    ``Curves`` request per non-empty chunk, atomically."""
    target = Path(path)
    with atomic_path(target) as tmp, open(tmp, "wb") as fh:
        fh.write(_VERSION)
        write_block(fh, curves, normals)
    return target


def write_block(fh: BinaryIO, curves: Curves, normals: bool = True) -> None:
    """The ``AttributeBegin`` … ``AttributeEnd`` block of :func:`save_rib` (no file header),
    e.g. the reply of a RenderMan procedural: the basis, one ``Curves`` per non-empty chunk."""
    fh.write(_BEGIN)
    start = 0
    for chunk in as_chunks(curves):
        if chunk.curve_count:
            _curves(fh, chunk, start, normals)
        start += chunk.curve_count
    fh.write(_FOOTER)


def save_rib_motion(
    samples: Sequence[HairCurves],
    times: Sequence[float],
    path: str | os.PathLike[str],
    normals: bool = True,
) -> Path:
    """Write deformation motion blur: ``MotionBegin [times]`` and one ``Curves`` per
    sample, all with the same curves and attributes; ``times`` strictly increasing."""
    if isinstance(samples, (HairCurves, str, bytes)) or not isinstance(samples, Sequence):
        raise InputError("samples: expected a sequence of HairCurves, one per time")
    try:
        stamps = np.asarray(times, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"times: expected numbers, got {times!r}") from None
    if len(samples) < 2 or len(stamps) != len(samples):
        raise InputError(
            f"samples/times: need two or more samples and one time each, got"
            f" {len(samples)} samples and {len(stamps)} times"
        )
    if not np.all(np.isfinite(stamps)) or np.any(np.diff(stamps) <= 0):
        raise InputError(f"times: must be finite and strictly increasing, got {stamps.tolist()}")
    first = samples[0]
    for i, sample in enumerate(samples):
        if not isinstance(sample, HairCurves):
            raise InputError(f"samples: sample {i} is a {type(sample).__name__}, not HairCurves")
        if (
            not np.array_equal(sample.offsets, first.offsets)
            or set(sample.point_data) != set(first.point_data)
            or set(sample.curve_data) != set(first.curve_data)
        ):
            raise InputError(
                f"samples: sample {i} differs from sample 0 in its curves, vertex"
                " counts or attribute names; motion samples must match"
            )
    if not first.curve_count:
        raise InputError("samples: the curves are empty; nothing to write")
    target = Path(path)
    with atomic_path(target) as tmp, open(tmp, "wb") as fh:
        fh.write(_VERSION + _BEGIN)
        fh.write(b"  MotionBegin [")
        fh.write(format_floats(stamps, len(stamps)))
        fh.write(b"]\n")
        for sample in samples:
            _curves(fh, sample, 0, normals)
        fh.write(b"  MotionEnd\n")
        fh.write(_FOOTER)
    return target
