"""follicle's native lossless format: a NumPy ``.npz`` archive of a HairCurves.

Keys: ``format_version``, ``points``, ``offsets``, ``point_data.<name>`` and
``curve_data.<name>``. Arrays are stored as they are (dtype and shape kept), so a
load gives back an equal HairCurves. Written uncompressed with fixed member
timestamps, so the same curves give the same bytes.

Reading trusts nothing in the file. The archive is parsed with :mod:`zipfile` and each
member's ``.npy`` header with :mod:`numpy.lib.format` (never pickles), and before any
array is allocated:

- a member must be a stored or deflated, unencrypted ``.npy`` with a printable name,
  named once, lying inside the file;
- its header's shape × itemsize plus the header must equal the member's size in the zip
  directory, which must be its compressed size when stored and at most
  ``MAX_RATIO`` (1000) times it when deflated (deflate's own limit is about 1032:1);
- all members together may declare at most ``MAX_EXPANSION`` (64) × the file's size +
  ``EXPANSION_SLACK`` (64 MiB): a 2 MB decompression bomb is refused, not inflated.

Members are then read in ``CHUNK`` (1 MiB) pieces into a buffer of the declared size, so
a lying directory cannot make a read allocate more than that. Anything else wrong
(truncation, bad CRC, a broken header) is a FormatError naming the file and the member.
"""

from __future__ import annotations

import io
import os
import struct
import tokenize
import zipfile
import zlib
from collections.abc import Collection
from pathlib import Path
from typing import IO, cast

import numpy as np

from ..atomic import atomic_path
from ..curves import HairCurves
from ..errors import FormatError, InputError
from ..inputs import input_file
from .stream import Curves, as_chunks

__all__ = ["FORMAT_VERSION", "save_npz", "load_npz", "save_arrays", "load_arrays"]

FORMAT_VERSION = 1
_FIXED_DATE = (1980, 1, 1, 0, 0, 0)
MAX_RATIO = 1000  # a deflated member may inflate to at most this × its compressed size
MAX_EXPANSION = 64  # all members may declare at most this × the file's size ...
EXPANSION_SLACK = 64 << 20  # ... plus this many bytes
CHUNK = 1 << 20  # bytes read from a member at a time
_DAMAGED = "the file is damaged or was not written by follicle or numpy; write it again"
# What zipfile and zlib raise on damaged archives: each becomes a FormatError. RuntimeError
# covers encryption (NotImplementedError, its subclass, an unsupported method or version).
_ZIP_ERRORS = (
    zipfile.BadZipFile,
    RuntimeError,
    ValueError,
    EOFError,
    OSError,
    struct.error,
    zlib.error,
    OverflowError,
    MemoryError,
)
# What numpy's .npy header parser raises on crafted text (tokenize: unbalanced brackets).
_HEADER_ERRORS = (
    ValueError,
    SyntaxError,
    TypeError,
    RecursionError,
    MemoryError,
    EOFError,
    OverflowError,
    tokenize.TokenError,
)


def save_npz(curves: Curves, path: str | os.PathLike[str]) -> Path:
    """Write ``curves`` (HairCurves or chunks, joined in memory: .npz is not a streaming
    format) to ``path``, atomically and byte-reproducibly."""
    chunks = list(as_chunks(curves))
    curves = chunks[0] if len(chunks) == 1 else HairCurves.concatenate(chunks)
    arrays: dict[str, np.ndarray] = {
        "format_version": np.array(FORMAT_VERSION, dtype=np.int64),
        "points": curves.points,
        "offsets": curves.offsets,
    }
    for kind, data in (("point_data", curves.point_data), ("curve_data", curves.curve_data)):
        for name, arr in sorted(data.items()):
            if "/" in name or not name:
                raise InputError(f"{kind}: attribute name {name!r} cannot be stored")
            arrays[f"{kind}.{name}"] = arr
    return save_arrays(path, arrays)


def save_arrays(path: str | os.PathLike[str], arrays: dict[str, np.ndarray]) -> Path:
    """Write named arrays as an uncompressed ``.npz`` that ``np.load`` reads, atomically
    and with fixed member timestamps (``np.savez`` stamps the time: same arrays, other bytes).
    """
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_STORED) as zf:
        for key, arr in arrays.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=_FIXED_DATE)
            with zf.open(info, "w") as fh:
                np.lib.format.write_array(fh, np.require(arr, requirements="C"), allow_pickle=False)
    return Path(path)


# ---------------------------------------------------------------------- reading archives
def load_arrays(
    path: str | os.PathLike[str], only: Collection[str] | None = None
) -> tuple[Path, dict[str, np.ndarray]]:
    """Every array of an .npz archive (or those of the keys in ``only``), each checked
    against the zip directory before it is allocated (see the module docstring); no
    pickles. FormatError names the file, the member and what is wrong."""
    p = input_file(path, ".npz file")
    size = p.stat().st_size
    member = ""
    try:
        with zipfile.ZipFile(p) as zf:
            infos = _checked_directory(p, zf.infolist(), size)
            arrays = {}
            for info in infos:
                member = info.filename
                if only is None or info.filename[:-4] in only:
                    arrays[info.filename[:-4]] = _read_member(p, zf, info)
            return p, arrays
    except _ZIP_ERRORS as exc:
        where = f" member {member!r}:" if member else ""
        raise FormatError(
            f"{p}:{where} not a readable .npz archive ({_one_line(exc)}); {_DAMAGED}"
        ) from None


def _one_line(exc: BaseException) -> str:
    """``exc`` as ``Type: message`` on one line of at most 200 characters of message."""
    return f"{type(exc).__name__}: {' '.join(str(exc).split())[:200]}"


def _checked_directory(p: Path, infos: list[zipfile.ZipInfo], size: int) -> list[zipfile.ZipInfo]:
    """The members of the zip directory, or FormatError if one cannot be a plain .npy
    or together they declare more than a file of ``size`` bytes can plausibly hold."""
    seen: set[str] = set()
    for info in infos:
        _check_member(p, info, size)
        if info.filename in seen:
            raise FormatError(f"{p}: member {info.filename!r} appears twice; {_DAMAGED}")
        seen.add(info.filename)
    total = sum(info.file_size for info in infos)
    limit = MAX_EXPANSION * size + EXPANSION_SLACK
    if total > limit:
        raise FormatError(
            f"{p}: its members declare {total:,} bytes in all, more than the {limit:,} a"
            f" {size:,}-byte .npz may hold ({MAX_EXPANSION} × its size + {EXPANSION_SLACK:,});"
            " a decompression bomb or a damaged file: write it again without compression"
        )
    return infos


def _check_member(p: Path, info: zipfile.ZipInfo, size: int) -> None:
    """FormatError unless ``info`` is a readable member of a ``size``-byte archive."""
    name = info.filename
    if not name.isprintable() or not name.endswith(".npy") or name == ".npy":
        raise FormatError(
            f"{p}: member {name!r} is not a named .npy array; a .npz holds only .npy members"
        )
    if info.flag_bits & 0x1:
        raise FormatError(f"{p}: member {name!r} is encrypted; save it again without a password")
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise FormatError(
            f"{p}: member {name!r} uses zip compression method {info.compress_type}; follicle"
            " reads stored or deflated members (numpy.savez, numpy.savez_compressed)"
        )
    if info.header_offset + info.compress_size > size:
        raise FormatError(
            f"{p}: member {name!r} claims {info.compress_size:,} bytes at offset"
            f" {info.header_offset:,}, past the end of the {size:,}-byte file; {_DAMAGED}"
        )
    stored = info.compress_type == zipfile.ZIP_STORED
    if stored and info.file_size != info.compress_size:
        raise FormatError(
            f"{p}: member {name!r} is stored uncompressed but declares {info.file_size:,}"
            f" bytes in {info.compress_size:,}; {_DAMAGED}"
        )
    if not stored and info.file_size > MAX_RATIO * max(info.compress_size, 1):
        raise FormatError(
            f"{p}: member {name!r} declares {info.file_size:,} bytes from"
            f" {info.compress_size:,} compressed, beyond the {MAX_RATIO}:1 limit; a"
            " decompression bomb or a damaged file: write it again"
        )


def _read_member(p: Path, zf: zipfile.ZipFile, info: zipfile.ZipInfo) -> np.ndarray:
    """The array in member ``info``: header checked against its declared size, data read
    in chunks into a buffer of exactly that size, text checked to be valid Unicode."""
    with zf.open(info) as fh:
        shape, fortran, dtype, header = _npy_header(p, info.filename, fh)
        count = 1
        for n in shape:
            count *= n
        nbytes = count * dtype.itemsize
        if header + nbytes != info.file_size:
            raise FormatError(
                f"{p}: member {info.filename!r} declares a {dtype} array of shape {shape}"
                f" ({nbytes:,} bytes) but holds {info.file_size - header:,}; {_DAMAGED}"
            )
        buf = np.empty(nbytes, np.uint8)
        view = buf.data  # a writable memoryview of buf
        done = 0
        while done < nbytes:
            got = cast(io.BufferedIOBase, fh).readinto(view[done : done + CHUNK])  # ZipExtFile
            if not got:
                raise FormatError(
                    f"{p}: member {info.filename!r} ends after {done:,} of {nbytes:,} data"
                    f" bytes; {_DAMAGED}"
                )
            done += got
    arr = np.ndarray(shape, dtype, buffer=buf, order="F" if fortran else "C")
    if dtype.kind == "U":
        _check_text(p, info.filename, buf.view(np.dtype(np.uint32).newbyteorder(dtype.byteorder)))
    return arr if dtype.isnative else arr.astype(dtype.newbyteorder("="))


def _npy_header(p: Path, name: str, fh: IO[bytes]) -> tuple[tuple[int, ...], bool, np.dtype, int]:
    """(shape, Fortran order, dtype, header length) of the .npy stream ``fh``; only plain
    dtypes (no objects, records or sub-arrays) and .npy versions 1.0 and 2.0."""
    fmt = np.lib.format
    try:
        version = fmt.read_magic(fh)
        if version not in ((1, 0), (2, 0)):
            raise ValueError(f".npy version {version[0]}.{version[1]} (follicle reads 1.0, 2.0)")
        read = fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
        shape, fortran, dtype = read(fh)
        if any(n < 0 for n in shape):
            raise ValueError(f"negative dimension in shape {shape}")
    except _HEADER_ERRORS as exc:
        raise FormatError(
            f"{p}: member {name!r} has no valid .npy header ({_one_line(exc)}); {_DAMAGED}"
        ) from None
    if dtype.hasobject or dtype.kind == "V" or dtype.subdtype is not None:
        raise FormatError(
            f"{p}: member {name!r} has dtype {dtype}: Python objects, records and sub-arrays"
            " are not read; store plain numeric or text arrays"
        )
    return shape, fortran, dtype, fh.tell()


def _check_text(p: Path, name: str, codes: np.ndarray) -> None:
    """FormatError if the code points of a text array are not all Unicode scalar values
    (above U+10FFFF or surrogates): Python cannot turn them into text or print them."""
    if ((codes > 0x10FFFF) | ((codes >= 0xD800) & (codes <= 0xDFFF))).any():
        raise FormatError(f"{p}: member {name!r} holds text that is not valid Unicode; {_DAMAGED}")


# ---------------------------------------------------------------------- curves
def load_npz(path: str | os.PathLike[str]) -> HairCurves:
    """Read a HairCurves written by :func:`save_npz`; every array's dtype and shape is
    checked before the curves are built, so a wrong one is a FormatError naming it."""
    p, data = load_arrays(path)
    if "positions" in data and "transforms" in data:
        raise FormatError(_cache_refusal(p, data["positions"]))
    for key in ("format_version", "points", "offsets"):
        if key not in data:
            raise FormatError(f"{p}: missing array '{key}'; is this a follicle curves file?")
    _check_version(p, data["format_version"])
    point_data = _attributes(p, data, "point_data")
    curve_data = _attributes(p, data, "curve_data")
    points, offsets = data["points"], data["offsets"]
    if points.dtype not in (np.float32, np.float64) or points.ndim != 2 or points.shape[1] != 3:
        raise FormatError(
            f"{p}: points: expected a float32 or float64 (P, 3) array, got {_describe(points)}"
        )
    if offsets.dtype.kind not in "iu" or offsets.ndim != 1:
        raise FormatError(
            f"{p}: offsets: expected a 1-D integer array (C + 1,), got {_describe(offsets)}"
        )
    _check_rows(p, "point_data", point_data, len(points))
    _check_rows(p, "curve_data", curve_data, max(len(offsets) - 1, 0))
    try:
        return HairCurves(points, offsets, point_data, curve_data)
    except InputError as exc:
        raise FormatError(f"{p}: {exc}") from None


def _describe(arr: np.ndarray) -> str:
    return f"{arr.dtype} array of shape {arr.shape}"


def _cache_refusal(p: Path, positions: np.ndarray) -> str:
    """The message for a simulation cache given where curves were expected."""
    size = ""
    if positions.ndim == 4:
        f, s, n, _ = positions.shape
        size = f" ({f:,} frames of {s:,} guides × {n:,} vertices)"
    return (
        f"{p}: a follicle simulation cache{size}, not a curves file; `follicle render {p}"
        f" -o frames/` draws it and `follicle export {p} -o anim.usdc` writes it as animated USD"
    )


def _check_version(p: Path, version: np.ndarray) -> None:
    """FormatError unless ``format_version`` is an integer scalar this follicle reads."""
    if version.ndim != 0 or version.dtype.kind not in "iu":
        raise FormatError(
            f"{p}: format_version: expected an integer scalar, got {_describe(version)};"
            f" write the file again with follicle.save"
        )
    value = int(version)
    if value > FORMAT_VERSION:
        raise FormatError(
            f"{p}: format_version {value} is newer than this follicle reads"
            f" ({FORMAT_VERSION}); upgrade follicle"
        )
    if value < 1:
        raise FormatError(
            f"{p}: format_version {value} is not a follicle format version (1 to"
            f" {FORMAT_VERSION}); write the file again with follicle.save"
        )


def _attributes(p: Path, data: dict[str, np.ndarray], kind: str) -> dict[str, np.ndarray]:
    """The ``kind.<name>`` arrays by name, each of a dtype the writers take: bool,
    integer, float32 or float64 (not float16, complex, text or objects)."""
    out = {}
    for key, arr in data.items():
        if not key.startswith(kind + "."):
            continue
        name = key[len(kind) + 1 :]
        if not name:
            raise FormatError(f"{p}: {key}: an attribute needs a name; {_DAMAGED}")
        numeric = arr.dtype.kind in "biu" or arr.dtype in (np.float32, np.float64)
        if not numeric:
            raise FormatError(
                f"{p}: {kind}['{name}']: {arr.dtype} attributes are not supported; store"
                " bool, integer, float32 or float64 values"
            )
        out[name] = arr
    return out


def _check_rows(p: Path, kind: str, data: dict[str, np.ndarray], rows: int) -> None:
    """FormatError unless every attribute is (rows,) or (rows, k) with k ≥ 1."""
    for name, arr in data.items():
        if arr.ndim not in (1, 2) or arr.shape[0] != rows or 0 in arr.shape[1:]:
            raise FormatError(
                f"{p}: {kind}['{name}']: expected shape ({rows},) or ({rows}, k),"
                f" got {_describe(arr)}"
            )
