"""Bounded, validated binary I/O shared by the cyHair and TressFX modules.

Reading: every count × item size is checked against the file's size before anything
is allocated, so a corrupt header costs an error, never gigabytes; array sections are
checked for alignment, bounds and overlap; floats for NaN/inf. Every error is a
FormatError naming the file and the field. Writing: :class:`Spool` keeps each array
section in its own temporary file while chunks stream in, so a header that needs the
totals can be written first and the sections joined after it.
"""

from __future__ import annotations

import os
import shutil
import struct
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from itertools import pairwise
from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..arrays import all_finite
from ..errors import FileAccessError, FormatError
from ..inputs import input_file

__all__ = ["BinaryFile", "open_binary", "read_bytes", "check_finite", "Spool"]


class BinaryFile:
    """An open file and its size; reads exactly what a field needs or raises FormatError."""

    def __init__(self, path: Path, fh: BinaryIO) -> None:
        self.path = path
        self.fh = fh
        self.size = os.fstat(fh.fileno()).st_size

    def fail(self, message: str) -> FormatError:
        return FormatError(f"{self.path}: {message}")

    def need(self, field: str, offset: int, nbytes: int) -> None:
        """FormatError unless bytes [offset, offset + nbytes) lie inside the file."""
        if offset < 0 or nbytes < 0 or offset + nbytes > self.size:
            raise self.fail(
                f"{field} needs bytes {offset}..{offset + nbytes} but the file has {self.size}"
                " bytes (truncated or corrupt)"
            )

    def bytes(self, field: str, offset: int, nbytes: int) -> bytes:
        """Exactly ``nbytes`` bytes at ``offset``."""
        self.need(field, offset, nbytes)
        self.fh.seek(offset)
        data = self.fh.read(nbytes)
        if len(data) != nbytes:
            raise self.fail(f"{field}: read {len(data)} of {nbytes} bytes (file changed?)")
        return data

    def unpack(self, field: str, fmt: str, offset: int = 0) -> tuple:
        """``struct.unpack`` of the bytes at ``offset`` (``fmt`` little-endian, '<...')."""
        return struct.unpack(fmt, self.bytes(field, offset, struct.calcsize(fmt)))

    def array(
        self, field: str, offset: int, count: int, dtype: str, shape: Sequence[int] = ()
    ) -> np.ndarray:
        """``count`` items of ``dtype`` (e.g. '<f4') at ``offset``, reshaped to
        (count, *shape) and native-endian; the size is checked before allocating."""
        dt = np.dtype(dtype)
        items = count * int(np.prod(shape, dtype=np.int64))
        self.need(field, offset, items * dt.itemsize)
        self.fh.seek(offset)
        arr = np.fromfile(self.fh, dtype=dt, count=items)
        if arr.size != items:
            raise self.fail(f"{field}: read {arr.size} of {items} values (file changed?)")
        return arr.astype(dt.newbyteorder("="), copy=False).reshape(count, *shape)

    def sections(
        self, header_size: int, sections: dict[str, tuple[int, int]], align: int = 8
    ) -> None:
        """Check array sections ``name -> (offset, nbytes)``: after the header, aligned to
        ``align`` bytes, inside the file and not overlapping one another."""
        spans = []
        for name, (offset, nbytes) in sections.items():
            if offset < header_size:
                raise self.fail(f"{name} offset {offset} points into the {header_size}-byte header")
            if offset % align:
                raise self.fail(f"{name} offset {offset} is not a multiple of {align}")
            self.need(name, offset, nbytes)
            spans.append((offset, offset + nbytes, name))
        spans.sort()
        for (_, end, a), (start, _, b) in pairwise(spans):
            if start < end:
                raise self.fail(f"{a} and {b} sections overlap (bytes {start}..{end})")


def _cannot_read(p: Path, exc: OSError) -> FileAccessError:
    reason = "no such file" if isinstance(exc, FileNotFoundError) else exc.strerror
    return FileAccessError(f"{p}: {reason}")


@contextmanager
def open_binary(path: str | os.PathLike[str]) -> Iterator[BinaryFile]:
    """A :class:`BinaryFile` for ``path``; FormatError when it cannot be opened or is
    not a regular file (a FIFO would block, a device never end)."""
    p = input_file(path, "hair curves file")
    try:
        fh = open(p, "rb")
    except OSError as exc:
        raise _cannot_read(p, exc) from None
    with fh:
        yield BinaryFile(p, fh)


def read_bytes(path: str | os.PathLike[str]) -> tuple[Path, np.ndarray]:
    """The whole file as uint8 (for the text readers' compiled scanners); FormatError
    naming the file when it cannot be read or is not a regular file."""
    p = input_file(path, "hair curves file")
    try:
        return p, np.fromfile(p, dtype=np.uint8)
    except OSError as exc:
        raise _cannot_read(p, exc) from None


def check_finite(f: BinaryFile, field: str, arr: np.ndarray) -> np.ndarray:
    """``arr`` unchanged, or FormatError naming the first NaN/inf value of ``field``."""
    if arr.size and not all_finite(arr):
        flat = arr.reshape(len(arr), -1)
        bad = int(np.argmax(~np.isfinite(flat).all(axis=1)))
        raise f.fail(f"{field}: entry {bad} is not finite (NaN or inf)")
    return arr


class Spool:
    """One anonymous temporary file per array section, in the folder ``where``.

    ``write`` appends little-endian bytes to a section; ``join`` copies the sections,
    in the order given, to an output file; ``close`` (or leaving a ``with``) removes
    them. Sizes are tracked so a header can give each section's offset.
    """

    def __init__(self, where: Path, names: Sequence[str]) -> None:
        self._files: dict[str, BinaryIO] = {}
        self.sizes = dict.fromkeys(names, 0)
        try:
            for name in names:
                self._files[name] = tempfile.TemporaryFile(dir=where, prefix=".spool.")
        except BaseException:
            self.close()
            raise

    def __enter__(self) -> Spool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def write(self, name: str, arr: np.ndarray) -> None:
        data = np.ascontiguousarray(arr)
        data.tofile(self._files[name])
        self.sizes[name] += data.nbytes

    def join(self, out: BinaryIO, names: Sequence[str], align: int = 1) -> None:
        """Copy sections ``names`` to ``out`` in order, zero-padding each to ``align``."""
        for name in names:
            fh = self._files[name]
            fh.flush()
            fh.seek(0)
            shutil.copyfileobj(fh, out, 1 << 22)
            out.write(bytes(-self.sizes[name] % align))

    def close(self) -> None:
        for fh in self._files.values():
            fh.close()
