"""Opening an Alembic archive that may be hostile: cheap container checks, then alembic3d
in a child process under limits.

Alembic is C++ and trusts its input: a flipped byte in an archive can make it read
past the end of the file, allocate without end or crash. So the readers here

1. check the container in Python, reading only its structure: an Ogawa archive starts
   with ``Ogawa``, the byte that says its writer finished, version 1 and the position
   of its root group; every group's children (groups, and data blocks with their
   sizes) lie inside the file, and the groups do not overlap (their child tables fit
   the file once). An HDF5 archive (Alembic before 1.5) is refused by name: alembic3d
   is built without HDF5;
2. read it with alembic3d in a child process (:mod:`follicle.io.alembic_archive`)
   under the limits of a read of the file's size, which turns a refusal, a crash, the
   memory limit or the time limit into one FormatError naming the file
   (:func:`follicle.io.guard.read_guarded`).
"""

from __future__ import annotations

import mmap
from pathlib import Path

import numpy as np

from ..errors import FormatError
from .guard import GuardedReader, checking

__all__ = ["check_archive", "read_curves", "read_mesh", "OGAWA_MAGIC"]

OGAWA_MAGIC = b"Ogawa"
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
_DATA = np.uint64(1 << 63)  # the high bit of a child's position marks a data block
_HINT = "is it a valid Alembic file?"


def _u64(mm: mmap.mmap, at: np.ndarray) -> np.ndarray:
    """The little-endian uint64 at each byte position ``at`` of ``mm`` (all in range)."""
    view = np.frombuffer(mm, np.uint8)
    values = view[at.astype(np.int64)[:, None] + np.arange(8)].view("<u8").reshape(-1)
    del view  # no buffer left exported: the map can close
    return values


def _check_ogawa(path: Path, mm: mmap.mmap, size: int) -> None:
    """Every group reachable from the root lies in the file, with its children."""
    head = mm[:16]
    if head[5] != 0xFF:
        raise FormatError(
            f"{path}: the Alembic archive was never finished (its writer"
            " stopped before closing it); write it again"
        )
    if head[6:8] != b"\x00\x01":
        raise FormatError(
            f"{path}: Ogawa version {int.from_bytes(head[6:8], 'big')} is not 1; {_HINT}"
        )
    groups, seen, entries = [int.from_bytes(head[8:16], "little")], set(), 0
    while groups:
        at = groups.pop()
        if at == 0 or at in seen:  # 0: an empty group
            continue
        seen.add(at)
        if not 16 <= at <= size - 8:
            raise FormatError(
                f"{path}: an Ogawa group at byte {at} lies outside the {size}-byte"
                f" file (truncated or corrupt); {_HINT}"
            )
        count = int(_u64(mm, np.array([at]))[0])
        entries += count
        if count > (size - at - 8) // 8 or entries > size // 8:
            raise FormatError(
                f"{path}: an Ogawa group at byte {at} lists {count} children,"
                f" more than fit in the file (corrupt); {_HINT}"
            )
        children = _u64(mm, at + 8 + 8 * np.arange(count))
        data = (children & _DATA) != 0
        blocks = (children[data] & ~_DATA).astype(np.int64)
        blocks = blocks[blocks != 0]  # 0: an empty block
        if np.any((blocks < 16) | (blocks > size - 8)):
            raise FormatError(
                f"{path}: an Ogawa data block lies outside the {size}-byte file"
                f" (truncated or corrupt); {_HINT}"
            )
        if np.any(_u64(mm, blocks) > (size - 8 - blocks).astype(np.uint64)):
            raise FormatError(
                f"{path}: an Ogawa data block runs past the end of the file"
                f" (truncated or corrupt); {_HINT}"
            )
        groups.extend(int(g) for g in children[~data])


def check_archive(path: Path) -> None:
    """FormatError unless ``path`` is an Ogawa Alembic archive whose structure lies in
    the file, checked without alembic3d, reading only headers and group tables."""
    with checking(path), open(path, "rb") as f:
        size = path.stat().st_size
        head = f.read(16)
        if head.startswith(HDF5_MAGIC):
            raise FormatError(
                f"{path}: an HDF5 Alembic archive (Alembic before 1.5); only"
                " Ogawa archives are read: export it again from a current"
                " application, or convert it with 'abcconvert -toOgawa'"
            )
        if len(head) < 16 or not head.startswith(OGAWA_MAGIC):
            raise FormatError(
                f"{path}: not an Alembic archive (no {OGAWA_MAGIC.decode()} header); {_HINT}"
            )
        with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mm:
            _check_ogawa(path, mm, size)


_READER = GuardedReader(
    "abc-curves", "abc-mesh", "Alembic", _HINT, lambda path: path.stat().st_size
)
# the chosen curves objects of a path (see :mod:`follicle.io.alembic_archive`)
read_curves = _READER.curves


def read_mesh(path: Path, animated: bool = False) -> dict:
    """The first mesh of ``path`` as polygons (see :mod:`follicle.io.alembic_archive`;
    ``animated``: with its points at every sample), read as :func:`read_curves` reads
    curves."""
    (part,) = _READER.meshes(path, animated)
    return part
