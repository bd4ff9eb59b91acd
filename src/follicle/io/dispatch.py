"""The format registry: which module reads or writes each file suffix, and ``save`` and
``load_curves``, which pick from it by a path's extension.

Each table maps a suffix to a ``"module:function"`` entry, imported on first use
(trimesh's loader tables are the model), so ``follicle.save("hair.npz", ...)`` loads
neither usd-core nor Alembic. One table per capability:

- :data:`WRITERS`, :data:`READERS`: hair curves. A writer is ``write(chunks:
  Iterator[HairCurves], path, **options) -> Path``: it takes the hair as a stream of
  chunks (:mod:`follicle.io.stream`) and writes atomically; a reader is ``read(path) ->
  HairCurves``.
- :data:`CACHE_WRITERS`: a simulation's frames as one animated curves object, USD's
  and Alembic's writers of one signature (``write(frames, path, fps=…, mesh=…,
  target=…, …) -> Path``; :func:`follicle.export.export_cache` drives them).
- :data:`MESH_WRITERS`, :data:`MESH_READERS`: a skin mesh. A writer is ``write(mesh,
  path, target) -> Path``: mesh files through trimesh, and USD or Alembic as a groom
  file with the skin and no hair; a reader is ``read(path, mpu) -> SkinMesh``, ``mpu``
  the metres per the file's unit: mesh files through trimesh, and the first mesh of a
  USD or Alembic file (:func:`follicle.load_mesh` checks the path and picks from it).
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..curves import HairCurves
from ..errors import FormatError
from ..units import Units, scale_curves, units_for
from ..validate import file_path
from .attributes import plausible_widths
from .stream import Curves, as_chunks
from .suffixes import MESH_FILE_SUFFIXES, SCENE_SUFFIXES, USD_SUFFIXES

if TYPE_CHECKING:
    from ..mesh.skin import SkinMesh

__all__ = [
    "save",
    "load_curves",
    "save_skin",
    "Registry",
    "WRITERS",
    "READERS",
    "CACHE_WRITERS",
    "MESH_WRITERS",
    "MESH_READERS",
]


class Registry(Mapping[str, Callable[..., Any]]):
    """``suffix → callable``, each imported from its ``"module:function"`` entry on first
    use and kept. A Mapping: ``suffix in table``, ``sorted(table)``, ``table[suffix]``."""

    def __init__(self, what: str, entries: Mapping[str, str]) -> None:
        self.what = what  # "write curves", "read curves", ...: for the error
        self.entries = dict(entries)
        self._loaded: dict[str, Callable[..., Any]] = {}

    def __getitem__(self, suffix: str) -> Callable[..., Any]:
        if suffix not in self._loaded:
            module, _, name = self.entries[suffix].partition(":")
            self._loaded[suffix] = getattr(importlib.import_module(module), name)
        return self._loaded[suffix]

    def __iter__(self) -> Iterator[str]:
        return iter(self.entries)

    def __len__(self) -> int:
        return len(self.entries)

    def suffix_of(self, path: str | os.PathLike[str]) -> str:
        """``path``'s suffix, lower case; FormatError naming ``path`` and the suffixes this
        table has (the native .npz first) when it has none for it."""
        suffix = Path(path).suffix.lower()
        if suffix not in self.entries:
            allowed = ", ".join(sorted(self.entries, key=lambda s: (s != ".npz", s)))
            shown = suffix or "no extension"
            raise FormatError(f"{path}: cannot {self.what} '{shown}' files; use {allowed}")
        return suffix

    def for_path(self, path: str | os.PathLike[str]) -> Callable[..., Any]:
        """The callable for ``path``'s suffix (:meth:`suffix_of`)."""
        return self[self.suffix_of(path)]


_USD = dict.fromkeys(USD_SUFFIXES, "follicle.io.usd:save_usd")
# hair formats; ".txt" is a Mitsuba 3 bsplinecurve file; ".pbrt" and ".rib" are written only
WRITERS = Registry(
    "write",
    {
        ".npz": "follicle.io.npz:save_npz",
        ".hair": "follicle.io.cyhair:save_cyhair",
        ".tfx": "follicle.io.tfx:save_tfx",
        ".obj": "follicle.io.obj:save_obj",
        ".pbrt": "follicle.io.pbrt:save_pbrt",
        ".txt": "follicle.io.mitsuba:save_mitsuba",
        **_USD,
        ".rib": "follicle.io.rib:save_rib",
        ".abc": "follicle.io.alembic:save_abc",
    },
)
READERS = Registry(
    "read",
    {
        ".npz": "follicle.io.npz:load_npz",
        ".hair": "follicle.io.cyhair:load_cyhair",
        ".tfx": "follicle.io.tfx:load_tfx",
        ".obj": "follicle.io.obj:load_obj",
        ".txt": "follicle.io.mitsuba:load_mitsuba",
        **dict.fromkeys(USD_SUFFIXES, "follicle.io.usd:load_usd"),
        ".abc": "follicle.io.alembic:load_abc",
    },
)
CACHE_WRITERS = Registry(
    "write a simulation cache as",
    {
        **dict.fromkeys(USD_SUFFIXES, "follicle.io.usd:save_usd_cache"),
        ".abc": "follicle.io.alembic:save_abc_cache",
    },
)
MESH_WRITERS = Registry(
    "write a mesh as",
    {
        **dict.fromkeys(MESH_FILE_SUFFIXES, "follicle.io.mesh_save:save_mesh"),
        **dict.fromkeys(SCENE_SUFFIXES, "follicle.io.dispatch:save_skin"),
    },
)
MESH_READERS = Registry(
    "read a mesh from",
    {
        **dict.fromkeys(MESH_FILE_SUFFIXES, "follicle.io.mesh_file:load_mesh_file"),
        ".abc": "follicle.io.alembic:load_abc_mesh",
        **dict.fromkeys(USD_SUFFIXES, "follicle.io.polymesh:load_usd_mesh"),
    },
)


def save(curves: Curves, path: str | os.PathLike[str], **options: object) -> Path:
    """Write ``curves`` (HairCurves, or an iterable of HairCurves chunks) to ``path`` in
    the format its extension names."""
    path = file_path(path, "save path")
    return WRITERS.for_path(path)(as_chunks(curves), path, **options)


def save_skin(mesh: SkinMesh, path: str | os.PathLike[str], target: str = "generic") -> Path:
    """``mesh`` alone as a USD or Alembic groom file: its ``/Groom/Skin`` (named, typed and
    scaled for ``target``) and no hair."""
    import numpy as np

    empty = HairCurves.from_array(np.zeros((0, 2, 3), np.float32))
    return save(empty, path, target=target, mesh=mesh)


def load_curves(path: str | os.PathLike[str], units: Units = "m") -> HairCurves:
    """Read hair curves from ``path`` in the format its extension names.

    ``units`` are the file's (``"m"``, ``"cm"``, ``"mm"``, ``"in"`` or metres per unit;
    :mod:`follicle.units`): points and widths are converted to metres. A format that
    declares its own unit (USD's metersPerUnit) is converted by its reader and takes
    no other ``units``. Widths that are not hair (a median over 5 mm: a tool's default
    radius, or the wrong unit) log a warning naming the file.
    """
    path = file_path(path, "load_curves path")
    reader = READERS.for_path(path)
    mpu = units_for(path, units)  # checked before the file is read
    curves = scale_curves(reader(path), mpu)
    plausible_widths(curves, path)  # in metres now, whatever the file's unit
    return curves
