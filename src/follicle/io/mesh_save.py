"""save_mesh: a SkinMesh's rest pose, with its UVs, to a mesh file through trimesh.

The skin travels with the groom: `follicle export builtin:head -o head.obj` gives the
mesh a groom was grown on to the tool that opens the groom. OBJ, PLY, GLB / GLTF, STL
and OFF go through trimesh (UVs where the format has them: OBJ, PLY, GLB / GLTF); USD
and Alembic meshes are written beside the hair by those formats' own writers.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..errors import FormatError
from ..mesh.skin import SkinMesh
from ..validate import file_path
from .suffixes import MESH_FILE_SUFFIXES

__all__ = ["save_mesh", "MESH_WRITE_EXTENSIONS"]

MESH_WRITE_EXTENSIONS = MESH_FILE_SUFFIXES


def save_mesh(mesh: SkinMesh, path: str | os.PathLike[str], target: str = "generic") -> Path:
    """Write ``mesh``'s rest vertices, triangles and per-vertex UVs to ``path``,
    atomically, in the format its extension names; the same mesh gives the same bytes.
    ``target`` is the signature of :data:`follicle.io.dispatch.MESH_WRITERS`: a mesh
    file carries no tool's names, so every target gets the same file."""
    path = file_path(path, "save_mesh path")
    import trimesh

    target = Path(path)
    suffix = target.suffix.lower()
    if suffix not in MESH_WRITE_EXTENSIONS:
        raise FormatError(f"{target}: a mesh is written as {', '.join(MESH_WRITE_EXTENSIONS)}")
    visual = None
    if mesh.uvs is not None:
        visual = trimesh.visual.TextureVisuals(uv=np.asarray(mesh.uvs, dtype=np.float64))
    tm = trimesh.Trimesh(
        np.asarray(mesh.rest_vertices), np.asarray(mesh.faces), visual=visual, process=False
    )
    if suffix == ".obj":  # UVs as vt lines, and no material file: the mesh has none
        text = tm.export(file_type="obj", write_texture=False, header="follicle skin mesh")
        data = "\n".join(
            line for line in text.split("\n") if not line.startswith(("mtllib ", "usemtl "))
        ).encode()
    else:
        data = tm.export(file_type=suffix[1:])
    with atomic_path(target) as tmp:
        tmp.write_bytes(data if isinstance(data, bytes) else data.encode())
    return target
