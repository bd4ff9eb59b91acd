"""``save`` and ``load_curves``: pick a reader or writer by file extension."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from ..curves import HairCurves
from ..errors import FormatError, InputError
from .npz import load_npz, save_npz

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


def save(curves: HairCurves, path: str | os.PathLike[str], **options: object) -> Path:
    """Write ``curves`` to ``path`` in the format its extension names."""
    if not isinstance(curves, HairCurves):
        raise InputError(f"save: expected HairCurves, got {type(curves).__name__}")
    return WRITERS[_suffix(path, WRITERS, "write")](curves, path, **options)


def load_curves(path: str | os.PathLike[str]) -> HairCurves:
    """Read hair curves from ``path`` in the format its extension names."""
    return READERS[_suffix(path, READERS, "read")](path)
