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
from ..units import Units, scale_curves, units_for
from ..validate import file_path
from .alembic import load_abc, save_abc
from .attributes import plausible_widths
from .cyhair import load_cyhair, save_cyhair
from .mitsuba import load_mitsuba, save_mitsuba
from .npz import load_npz, save_npz
from .obj import load_obj, save_obj
from .pbrt import save_pbrt
from .rib import save_rib
from .stream import Curves, as_chunks
from .tfx import load_tfx, save_tfx
from .usd import SUFFIXES as USD_SUFFIXES
from .usd import load_usd, save_usd

__all__ = ["save", "load_curves", "WRITERS", "READERS"]

WRITERS: dict[str, Callable[..., Path]] = {".npz": save_npz}
READERS: dict[str, Callable[..., HairCurves]] = {".npz": load_npz}
# hair formats; ".txt" is a Mitsuba 3 bsplinecurve file, ".pbrt" is written only
WRITERS.update(
    {
        ".hair": save_cyhair,
        ".tfx": save_tfx,
        ".obj": save_obj,
        ".pbrt": save_pbrt,
        ".txt": save_mitsuba,
    }
)
READERS.update({".hair": load_cyhair, ".tfx": load_tfx, ".obj": load_obj, ".txt": load_mitsuba})
# USD (".usd" is crate, like ".usdc") and RenderMan RIB (written only)
WRITERS.update({**dict.fromkeys(USD_SUFFIXES, save_usd), ".rib": save_rib})
READERS.update(dict.fromkeys(USD_SUFFIXES, load_usd))
# Alembic (Ogawa archives)
WRITERS[".abc"] = save_abc
READERS[".abc"] = load_abc


def _suffix(path: str | os.PathLike[str], table: dict, verb: str) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in table:
        allowed = ", ".join(sorted(table, key=lambda s: (s != ".npz", s)))  # native first
        shown = suffix or "no extension"
        raise FormatError(f"{path}: cannot {verb} '{shown}' files; use {allowed}")
    return suffix


def save(curves: Curves, path: str | os.PathLike[str], **options: object) -> Path:
    """Write ``curves`` (HairCurves, or an iterable of HairCurves chunks) to ``path`` in
    the format its extension names."""
    path = file_path(path, "save path")
    writer = WRITERS[_suffix(path, WRITERS, "write")]
    return writer(as_chunks(curves), path, **options)


def load_curves(path: str | os.PathLike[str], units: Units = "m") -> HairCurves:
    """Read hair curves from ``path`` in the format its extension names.

    ``units`` are the file's (``"m"``, ``"cm"``, ``"mm"``, ``"in"`` or metres per unit;
    :mod:`follicle.units`): points and widths are converted to metres. A format that
    declares its own unit (USD's metersPerUnit) is converted by its reader and takes
    no other ``units``. Widths that are not hair (a median over 5 mm: a tool's default
    radius, or the wrong unit) log a warning naming the file.
    """
    path = file_path(path, "load_curves path")
    reader = READERS[_suffix(path, READERS, "read")]
    mpu = units_for(path, units)  # checked before the file is read
    curves = scale_curves(reader(path), mpu)
    plausible_widths(curves, path)  # in metres now, whatever the file's unit
    return curves
