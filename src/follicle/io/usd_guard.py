"""Opening a USD file that may be hostile: cheap container checks, then usd-core in a
child process under limits.

usd-core is C++ and trusts its input: a corrupt crate (``.usdc``) or package (``.usdz``)
can make it crash (segfault) or map gigabytes, and a few kilobytes of ``.usda`` that
reference each other many times over compose for ever. So :func:`read_stage`

1. checks the container in Python, reading little: a ``.usda`` starts with ``#usda``
   and is UTF-8; a crate starts with ``PXR-USDC`` and its table of contents and every
   section lie inside the file; a ``.usdz`` is a zip whose members are stored
   uncompressed, 64-byte aligned, the first one a USD layer (checked the same way);
2. reads it with usd-core in a child process (:mod:`follicle.io.usd_stage` for curves,
   :mod:`follicle.io.usd_mesh` for meshes, one usd-core thread) under the limits of a
   read of what the stage loads (:func:`stage_bytes`: the file and, in follicle's
   payloads layout, its part files), which turns a refusal, a crash, the memory limit
   or the time limit into one FormatError naming the file
   (:func:`follicle.io.guard.read_guarded`). Before composing anything the child
   counts the prims composition would make through references, payloads and
   sublayers (at most 100,000, repeats counted) and refuses cycles.
"""

from __future__ import annotations

import codecs
import os
import zipfile
from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..errors import FormatError
from .guard import GuardedReader, checking

__all__ = ["check_container", "read_stage", "read_meshes", "payloads_folder", "stage_bytes"]

CRATE_MAGIC = b"PXR-USDC"
_HINT = "is it a valid USD file?"


# ------------------------------------------------------------------ container checks
def _check_text(path: Path, data: bytes, size: int) -> None:
    """A text layer: ``#usda`` first, UTF-8 throughout (read in blocks)."""
    if not data.startswith(b"#usda"):
        raise FormatError(f"{path}: a .usda layer must start with '#usda 1.0'; {_HINT}")
    decoder = codecs.getincrementaldecoder("utf-8")()
    with open(path, "rb") as f:
        done = 0
        while block := f.read(1 << 20):
            try:
                decoder.decode(block, final=done + len(block) >= size)
            except UnicodeDecodeError as exc:
                raise FormatError(
                    f"{path}: byte {done + exc.start} is not UTF-8; a .usda layer"
                    " must be UTF-8 text (save it as UTF-8)"
                ) from None
            done += len(block)


def _check_crate(path: Path, f: BinaryIO, start: int, size: int) -> None:
    """A crate at ``start`` of ``size`` bytes of open file ``f``: magic, table of
    contents and sections within it."""
    f.seek(start)
    head = f.read(24)
    if len(head) < 24 or not head.startswith(CRATE_MAGIC):
        raise FormatError(f"{path}: not a USD crate (no {CRATE_MAGIC.decode()} header); {_HINT}")
    toc = int.from_bytes(head[16:24], "little", signed=True)
    if not 24 <= toc <= size - 8:
        raise FormatError(
            f"{path}: crate table of contents at byte {toc} lies outside the"
            f" {size}-byte file (truncated or corrupt); {_HINT}"
        )
    f.seek(start + toc)
    count = int.from_bytes(f.read(8), "little")
    if count > (size - toc - 8) // 32:
        raise FormatError(
            f"{path}: crate lists {count} sections, more than fit in the file (corrupt); {_HINT}"
        )
    table = np.frombuffer(
        f.read(32 * count), dtype=[("name", "S16"), ("at", "<i8"), ("size", "<i8")]
    )
    if len(table) < count or np.any(
        (table["at"] < 24) | (table["size"] < 0) | (table["at"] > size - table["size"])
    ):
        raise FormatError(
            f"{path}: a crate section lies outside the {size}-byte file"
            f" (truncated or corrupt); {_HINT}"
        )


def _check_usdz(path: Path, size: int) -> None:
    """A USDZ package: a zip of stored, 64-byte aligned members, the first a USD layer."""
    with open(path, "rb") as f:
        try:
            with zipfile.ZipFile(f) as z:
                members = z.infolist()
            starts = [_data_start(f, m) for m in members]
        except (zipfile.BadZipFile, OSError, ValueError, EOFError) as exc:
            raise FormatError(
                f"{path}: not a readable zip ({exc}); a .usdz is a zip package of USD layers"
            ) from None
        if not members or not members[0].filename.lower().endswith((".usd", ".usda", ".usdc")):
            raise FormatError(f"{path}: a .usdz package's first file must be a USD layer; {_HINT}")
        for member, start in zip(members, starts, strict=True):
            if member.compress_type != zipfile.ZIP_STORED or start % 64:
                raise FormatError(
                    f"{path}: {member.filename!r} is compressed or not 64-byte"
                    " aligned; USDZ stores files uncompressed (usdzip makes one)"
                )
            if start + member.file_size > size:
                raise FormatError(f"{path}: {member.filename!r} runs past the end of the package")
        f.seek(starts[0])
        if f.read(8) == CRATE_MAGIC:
            _check_crate(path, f, starts[0], members[0].file_size)
        elif members[0].filename.lower().endswith(".usdc"):
            raise FormatError(f"{path}: {members[0].filename!r} is not a USD crate; {_HINT}")


def _data_start(f: BinaryIO, member: zipfile.ZipInfo) -> int:
    """Where ``member``'s data begins: after its local header and that header's fields."""
    f.seek(member.header_offset)
    local = f.read(30)
    if len(local) < 30 or local[:4] != b"PK\x03\x04":
        raise ValueError(f"no local header for {member.filename!r}")
    name_len = int.from_bytes(local[26:28], "little")
    extra_len = int.from_bytes(local[28:30], "little")
    return member.header_offset + 30 + name_len + extra_len


def check_container(path: Path) -> None:
    """FormatError unless ``path`` looks like the USD its extension (or content) says,
    checked without usd-core, reading only headers (and a .usda's bytes, for UTF-8)."""
    with checking(path):
        size = path.stat().st_size
        suffix = path.suffix.lower()
        if suffix == ".usdz":
            _check_usdz(path, size)
            return
        with open(path, "rb") as f:
            head = f.read(8)
            if head == CRATE_MAGIC and suffix != ".usda":
                _check_crate(path, f, 0, size)
            elif suffix == ".usda" or suffix == ".usd" and head.startswith(b"#usda"):
                _check_text(path, head, size)
            else:
                text = " nor USD text (#usda)" if suffix == ".usd" else ""
                raise FormatError(
                    f"{path}: not a USD crate (no {CRATE_MAGIC.decode()} header){text}; {_HINT}"
                )


# ------------------------------------------------------------------ the child
def payloads_folder(path: str | os.PathLike[str]) -> Path:
    """The folder of ``path``'s part files in the payloads layout
    (:mod:`follicle.io.usd_payloads`), beside it: ``fox.usdc`` → ``fox.usdc.payloads``
    (the whole name, so ``fox.usda`` beside it keeps parts of its own)."""
    path = Path(path)
    return path.with_name(f"{path.name}.payloads")


def stage_bytes(path: Path) -> int:
    """The bytes of the layers the stage of ``path`` loads: the file, and the part
    files of its :func:`payloads_folder` when it has one (the root of a payloads
    layout is a few kilobytes; its parts are the hair)."""
    size = path.stat().st_size
    folder = payloads_folder(path)
    if folder.is_dir():
        size += sum(p.stat().st_size for p in folder.glob("*.usdc") if p.is_file())
    return size


_READER = GuardedReader("usd-curves", "usd-mesh", "usd-core", _HINT, stage_bytes)
# the chosen BasisCurves prims of a path (see the module and :mod:`follicle.io.usd_stage`)
read_stage = _READER.curves
# the Mesh prims of a path (see :mod:`follicle.io.usd_mesh`)
read_meshes = _READER.meshes
