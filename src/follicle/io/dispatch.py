"""``save`` and ``load_curves``: pick a reader or writer by file extension.

A writer is ``write(chunks: Iterator[HairCurves], path, **options) -> Path``: it takes
the hair as a stream of chunks (see :mod:`follicle.io.stream`) and writes atomically.
A reader is ``read(path) -> HairCurves``.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from ..curves import HairCurves
from ..errors import FormatError
from .npz import load_npz, save_npz
from .stream import Curves, as_chunks

__all__ = ["save", "load_curves", "WRITERS", "READERS"]

WRITERS: dict[str, Callable[..., Path]] = {".npz": save_npz}
READERS: dict[str, Callable[..., HairCurves]] = {".npz": load_npz}


def _suffix(path: str | os.PathLike[str], table: dict, verb: str) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in table:
        allowed = ", ".join(sorted(table))
        shown = suffix or "no extension"
        raise FormatError(f"{path}: cannot {verb} '{shown}' files; use {allowed}")
    return suffix


def save(curves: Curves, path: str | os.PathLike[str], **options: object) -> Path:
    """Write ``curves`` (HairCurves, or an iterable of HairCurves chunks) to ``path`` in
    the format its extension names."""
    writer = WRITERS[_suffix(path, WRITERS, "write")]
    return writer(as_chunks(curves), path, **options)


def load_curves(path: str | os.PathLike[str]) -> HairCurves:
    """Read hair curves from ``path`` in the format its extension names."""
    return READERS[_suffix(path, READERS, "read")](path)
