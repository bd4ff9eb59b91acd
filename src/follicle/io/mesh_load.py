"""load_mesh: a SkinMesh from a mesh file or a built-in name. The path, its extension
and its units are checked here; the reader is the extension's entry of
:data:`follicle.io.dispatch.MESH_READERS` (trimesh, or the USD and Alembic readers)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import FileAccessError, FormatError
from ..inputs import input_file, is_url
from ..mesh.bust import builtin_bust
from ..mesh.head import builtin_head
from ..mesh.skin import SkinMesh
from ..units import Units, units_for, warn_mesh_size
from ..validate import file_path
from .dispatch import MESH_READERS

__all__ = ["load_mesh", "MESH_EXTENSIONS", "BUILTIN_MESHES"]

MESH_EXTENSIONS = tuple(MESH_READERS)
BUILTIN_MESHES: dict[str, Callable[[], SkinMesh]] = {"head": builtin_head, "bust": builtin_bust}
_BUILTIN_PREFIX = "builtin:"


def load_mesh(path: str | os.PathLike[str], units: Units = "m") -> SkinMesh:
    """Load ``path`` (OBJ/PLY/GLB/GLTF/STL/OFF, Alembic, USD) or a built-in mesh
    (``"builtin:head"``, ``"builtin:bust"``) as a
    SkinMesh, a file through its extension's entry of
    :data:`follicle.io.dispatch.MESH_READERS`.

    The file is read with ``process=False`` (vertex order kept), triangulated, and
    its per-vertex UVs kept when present. Alembic (``.abc``) and USD (``.usd``,
    ``.usda``, ``.usdc``, ``.usdz``) files give their first mesh (a warning names any
    others), with transforms applied and faceVarying UVs split at seams, read in a
    guarded child process (:func:`follicle.io.alembic.load_abc_mesh`,
    :func:`follicle.io.polymesh.load_usd_mesh`; bad geometry in them is a FormatError,
    the file holding it). ``units`` are the file's (``"m"``, ``"cm"``,
    ``"mm"``, ``"in"`` or metres per unit; :mod:`follicle.units`): its vertices are
    converted to metres, and a size that suggests other units is logged as a warning.
    Unreadable files (and a FIFO, device or folder, refused before opening) raise
    FormatError; bad geometry (NaN vertices, a coordinate beyond
    ±:data:`~follicle.mesh.skin.MAX_COORDINATE` m, no faces, only zero-area faces) and
    units other than metres for a built-in mesh or a glTF or USD file (they declare
    their own) raise InputError.
    """
    path = file_path(path, "load_mesh path")
    mpu = units_for(path, units)
    text = os.fspath(path)
    if isinstance(text, str) and text.startswith(_BUILTIN_PREFIX):
        key = text[len(_BUILTIN_PREFIX) :]
        if key not in BUILTIN_MESHES:
            names = ", ".join(_BUILTIN_PREFIX + k for k in BUILTIN_MESHES)
            raise FormatError(f"unknown built-in mesh '{text}'; built-in meshes are: {names}")
        return BUILTIN_MESHES[key]()
    p = Path(text)
    ext = p.suffix.lower()
    if ext not in MESH_EXTENSIONS:
        raise FormatError(
            f"mesh file '{p}' has extension '{p.suffix}'; supported: {', '.join(MESH_EXTENSIONS)}"
            f" (or {', '.join(_BUILTIN_PREFIX + k for k in BUILTIN_MESHES)})"
        )
    if not is_url(text) and not os.path.lexists(p):
        raise FileAccessError(f"mesh file '{p}' does not exist; check the path")
    p = input_file(text, f"mesh file ({', '.join(MESH_EXTENSIONS)})")
    read: Callable[[Path, float], SkinMesh] = MESH_READERS[ext]
    return _plausible(read(p, mpu), units, p)


def _plausible(mesh: SkinMesh, units: Units, p: Path) -> SkinMesh:
    """``mesh``, with a warning when its size suggests other units."""
    lo, hi = mesh.bounds("rest")
    warn_mesh_size(float(np.linalg.norm(hi - lo)), units, str(p))
    return mesh
