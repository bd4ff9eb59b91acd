"""load_mesh_file: a mesh file (OBJ, PLY, GLB / GLTF, STL, OFF) read through trimesh as
a SkinMesh, the entry of :data:`follicle.io.dispatch.MESH_READERS` for those suffixes
(:func:`follicle.load_mesh` checks the path first; :mod:`follicle.io.mesh_save` writes
them)."""

from __future__ import annotations

from pathlib import Path
from typing import cast

import numpy as np

from ..errors import FollicleError, FormatError, InputError
from ..mesh.skin import SkinMesh

__all__ = ["load_mesh_file"]


def load_mesh_file(path: Path, mpu: float = 1.0) -> SkinMesh:
    """The mesh of ``path`` with its vertices times ``mpu`` (metres per the file's unit):
    read with ``process=False`` (vertex order kept), polygons fanned into triangles,
    per-vertex UVs kept when present. FormatError for a file trimesh cannot read or that
    holds no triangle mesh; InputError for points without faces and geometry a SkinMesh
    refuses, naming the file."""
    import trimesh

    try:
        loaded = trimesh.load(str(path), force="mesh", process=False)
    except FollicleError:
        raise
    except Exception as exc:  # trimesh raises many kinds on garbled input
        raise FormatError(
            f"mesh file '{path}' cannot be read ({type(exc).__name__}: {exc})"
        ) from exc
    if isinstance(loaded, trimesh.Scene) or not hasattr(loaded, "faces"):
        raise FormatError(f"mesh file '{path}' holds no triangle mesh")
    # a geometry with faces is a Trimesh (hasattr narrows to the faces alone)
    vertices = np.asarray(cast("trimesh.Trimesh", loaded).vertices, dtype=np.float64)
    if len(vertices) == 0:
        if _is_point_cloud(path):
            raise InputError(
                f"{path}: mesh '{path.stem}' has no faces (only points); give triangles"
            )
        raise FormatError(
            f"mesh file '{path}' holds no mesh (no triangles); is it empty or garbled?"
        )
    faces = np.asarray(loaded.faces)
    if faces.ndim == 2 and faces.shape[1] > 3:  # polygons: fan-triangulate
        faces = np.concatenate([faces[:, [0, k, k + 1]] for k in range(1, faces.shape[1] - 1)])
    uvs = _uvs(loaded, len(vertices))
    try:
        return SkinMesh(
            vertices * mpu, faces.reshape(-1, 3) if faces.size else faces, uvs, name=path.stem
        )
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from exc


def _is_point_cloud(path: Path) -> bool:
    """True when the file holds vertices but no faces (trimesh then drops the vertices)."""
    import trimesh

    try:
        loaded = trimesh.load(str(path), process=False)
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
