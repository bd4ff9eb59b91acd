"""The file suffixes that more than one format module names, in one place (imports
nothing, so a reader, a writer and the registry in :mod:`follicle.io.dispatch` share
them without importing each other)."""

from __future__ import annotations

__all__ = ["USD_SUFFIXES", "MESH_FILE_SUFFIXES", "SCENE_SUFFIXES"]

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")  # ".usd" is written as crate
MESH_FILE_SUFFIXES = (".obj", ".ply", ".glb", ".gltf", ".stl", ".off")  # through trimesh
SCENE_SUFFIXES = (".abc", *USD_SUFFIXES)  # groom files: hair, guides and the skin mesh
