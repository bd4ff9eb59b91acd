"""load_mesh: a SkinMesh from a mesh file (through trimesh, or the USD and Alembic readers)
or a built-in name."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import cast

import numpy as np

from ..errors import FileAccessError, FollicleError, FormatError, InputError
from ..inputs import input_file, is_url
from ..mesh.head import builtin_head
from ..mesh.skin import SkinMesh
from ..units import Units, units_for, warn_mesh_size
from ..validate import file_path
from .suffixes import MESH_FILE_SUFFIXES, SCENE_SUFFIXES

__all__ = ["load_mesh", "MESH_EXTENSIONS", "BUILTIN_MESHES"]

MESH_EXTENSIONS = (*MESH_FILE_SUFFIXES, *SCENE_SUFFIXES)
BUILTIN_MESHES: dict[str, Callable[[], SkinMesh]] = {"head": builtin_head}
_BUILTIN_PREFIX = "builtin:"


def load_mesh(path: str | os.PathLike[str], units: Units = "m") -> SkinMesh:
    """Load ``path`` (OBJ/PLY/GLB/GLTF/STL/OFF, Alembic, USD) or ``"builtin:head"`` as a
    SkinMesh.

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
    if ext in SCENE_SUFFIXES:
        return _plausible(_scene_mesh(p, ext, mpu), units, p)

    import trimesh

    try:
        loaded = trimesh.load(str(p), force="mesh", process=False)
    except FollicleError:
        raise
    except Exception as exc:  # trimesh raises many kinds on garbled input
        raise FormatError(f"mesh file '{p}' cannot be read ({type(exc).__name__}: {exc})") from exc
    if isinstance(loaded, trimesh.Scene) or not hasattr(loaded, "faces"):
        raise FormatError(f"mesh file '{p}' holds no triangle mesh")
    # a geometry with faces is a Trimesh (hasattr narrows to the faces alone)
    vertices = np.asarray(cast("trimesh.Trimesh", loaded).vertices, dtype=np.float64)
    if len(vertices) == 0:
        if _is_point_cloud(p):
            raise InputError(f"{p}: mesh '{p.stem}' has no faces (only points); give triangles")
        raise FormatError(f"mesh file '{p}' holds no mesh (no triangles); is it empty or garbled?")
    faces = np.asarray(loaded.faces)
    if faces.ndim == 2 and faces.shape[1] > 3:  # polygons: fan-triangulate
        faces = np.concatenate([faces[:, [0, k, k + 1]] for k in range(1, faces.shape[1] - 1)])
    uvs = _uvs(loaded, len(vertices))
    try:
        mesh = SkinMesh(
            vertices * mpu, faces.reshape(-1, 3) if faces.size else faces, uvs, name=p.stem
        )
    except InputError as exc:
        raise InputError(f"{p}: {exc}") from exc
    return _plausible(mesh, units, p)


def _plausible(mesh: SkinMesh, units: Units, p: Path) -> SkinMesh:
    """``mesh``, with a warning when its size suggests other units."""
    lo, hi = mesh.bounds("rest")
    warn_mesh_size(float(np.linalg.norm(hi - lo)), units, str(p))
    return mesh


def _scene_mesh(p: Path, ext: str, mpu: float) -> SkinMesh:
    """The first mesh of an Alembic or USD file (USD converts its own units; Alembic's
    carry none, so ``mpu`` scales them)."""
    if ext != ".abc":
        from .polymesh import load_usd_mesh

        return load_usd_mesh(p)
    from .alembic import load_abc_mesh

    mesh = load_abc_mesh(p)
    if mpu == 1.0:
        return mesh
    try:
        return SkinMesh(mesh.rest_vertices * mpu, mesh.faces, mesh.uvs, name=mesh.name)
    except InputError as exc:
        raise InputError(f"{p}: {exc}") from exc


def _is_point_cloud(p: Path) -> bool:
    """True when the file holds vertices but no faces (trimesh then drops the vertices)."""
    import trimesh

    try:
        loaded = trimesh.load(str(p), process=False)
    except Exception:
        return False
    return isinstance(loaded, trimesh.PointCloud) and len(loaded.vertices) > 0


def _uvs(mesh: object, count: int) -> np.ndarray | None:
    """Per-vertex UVs from trimesh's TextureVisuals, or None."""
    uv = getattr(getattr(mesh, "visual", None), "uv", None)
    if uv is None:
        return None
    uv = np.asarray(uv, dtype=np.float64)
    if uv.ndim != 2 or uv.shape[0] != count or uv.shape[1] < 2:
        return None
    return uv[:, :2]
