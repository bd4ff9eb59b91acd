"""save_mesh: a SkinMesh's rest pose, with its UVs, to a mesh file through trimesh.

The skin travels with the groom: `follicle export builtin:head -o head.obj` gives the
mesh a groom was grown on to the tool that opens the groom. OBJ, PLY, GLB / GLTF, STL
and OFF go through trimesh (UVs where the format has them: OBJ, PLY, GLB / GLTF); USD
and Alembic meshes are written beside the hair by those formats' own writers.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import cast

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
    out = Path(file_path(path, "save_mesh path"))
    import trimesh

    suffix = out.suffix.lower()
    if suffix not in MESH_WRITE_EXTENSIONS:
        raise FormatError(f"{out}: a mesh is written as {', '.join(MESH_WRITE_EXTENSIONS)}")
    visual = None
    if mesh.uvs is not None:
        visual = trimesh.visual.TextureVisuals(uv=np.asarray(mesh.uvs, dtype=np.float64))
    tm = trimesh.Trimesh(
        np.asarray(mesh.rest_vertices), np.asarray(mesh.faces), visual=visual, process=False
    )
    data: bytes
    if suffix == ".obj":  # UVs as vt lines, and no material file: the mesh has none
        # trimesh's OBJ exporter returns the text
        text = cast(
            str, tm.export(file_type="obj", write_texture=False, header="follicle skin mesh")
        )
        data = "\n".join(
            line for line in text.split("\n") if not line.startswith(("mtllib ", "usemtl "))
        ).encode()
    elif suffix == ".gltf":
        # trimesh's glTF exporter returns {file name: bytes}, the buffers as files of
        # their own unless embedded (base64 in the JSON): one self-contained file
        files = cast("dict[str, bytes]", tm.export(file_type="gltf", embed_buffers=True))
        data = files["model.gltf"]
    else:  # bytes, or text (OFF)
        exported = cast("bytes | str", tm.export(file_type=suffix[1:]))
        data = exported if isinstance(exported, bytes) else exported.encode()
    with atomic_path(out) as tmp:
        tmp.write_bytes(data)
    return out
