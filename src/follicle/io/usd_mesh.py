"""Reading a USD stage's first Mesh as plain arrays, in a guarded child process.

:mod:`follicle.io.usd_guard` has this module run in the guarded reading server
(:mod:`follicle.io.guard_server`, entry :func:`read_request`), beside
:mod:`follicle.io.usd_stage`, whose composition check, array checks and world matrix
(transforms, metersPerUnit, a Z up axis) it shares. The first ``UsdGeomMesh`` in stage
order becomes ``{"where", "name", "points", "face_counts", "face_indices", "uv",
"uv_scope", "flip", "others"}`` for :func:`follicle.io.polymesh.skin_from_part`:
points in follicle's space (metres, +Y up), UVs from the first of the primvars
:data:`UV_NAMES` that holds two numbers a value (indexed ones flattened).
"""

from __future__ import annotations

import numpy as np
from pxr import Sdf, Usd, UsdGeom

from .curve_space import to_world
from .usd_stage import Refused, _array, _Composition, _world, prepare, refusals

__all__ = ["read_request", "prepare", "UV_NAMES"]

UV_NAMES = ("st", "UVMap", "uv")  # USD's convention, Blender's and Houdini's, in that order
_SCOPE = {
    UsdGeom.Tokens.vertex: "vertex",
    UsdGeom.Tokens.varying: "vertex",
    UsdGeom.Tokens.faceVarying: "faceVarying",
    UsdGeom.Tokens.uniform: "uniform",
    UsdGeom.Tokens.constant: "constant",
}


def _uv(mesh: UsdGeom.Mesh, time: Usd.TimeCode, where: str) -> tuple[np.ndarray, str] | None:
    """(values, scope) of the mesh's UV primvar, or None."""
    api = UsdGeom.PrimvarsAPI(mesh)
    for name in UV_NAMES:
        if not api.HasPrimvar(name):
            continue
        primvar = api.GetPrimvar(name)
        values = _array(primvar.ComputeFlattened(time), name, where)
        if values is not None and values.ndim == 2 and values.shape[1] == 2:
            interpolation = primvar.GetInterpolation()
            return values, _SCOPE.get(interpolation, str(interpolation))
    return None


def read_mesh(path: str, source: str) -> list[dict]:
    """The first Mesh prim of the file at ``path`` at its earliest time, as polygons with
    their UVs, and the paths of the meshes after it; messages name it ``source``."""
    root = Sdf.Layer.FindOrOpen(path)
    if root is None:
        raise Refused(f"{source}: usd-core could not open it; is it a valid USD file?")
    _Composition(source).layer(root)
    stage = Usd.Stage.Open(root, Usd.Stage.LoadAll)
    meshes = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    if not meshes:
        raise Refused(f"{source}: no Mesh prims; is this a mesh file?")
    prim, time = meshes[0], Usd.TimeCode.EarliestTime()
    mesh, where = UsdGeom.Mesh(prim), f"{source}: {prim.GetPath()}"
    points = _array(mesh.GetPointsAttr().Get(time), "points", where)
    counts = _array(mesh.GetFaceVertexCountsAttr().Get(time), "faceVertexCounts", where)
    indices = _array(mesh.GetFaceVertexIndicesAttr().Get(time), "faceVertexIndices", where)
    if points is None or counts is None or indices is None:
        raise Refused(f"{where}: no points, faceVertexCounts or faceVertexIndices")
    if points.ndim != 2 or points.shape[1] != 3:
        raise Refused(f"{where}: points must be point3f[] (x, y, z each), got shape {points.shape}")
    world = _world(prim, time, where)
    left = mesh.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded
    part = {
        "where": where,
        "name": prim.GetName(),
        "points": to_world(points.astype(np.float64), {}, world, where, "fix its xformOps"),
        "face_counts": counts.reshape(-1),
        "face_indices": indices.reshape(-1),
        # clockwise polygons, or a mirroring transform, turn the other way
        "flip": left != bool(np.linalg.det(world[:3, :3]) < 0),
        "others": [str(p.GetPath()) for p in meshes[1:]],
    }
    uv = _uv(mesh, time, where)
    if uv is not None:
        part["uv"], part["uv_scope"] = uv
    return [part]


def read_request(request: dict) -> list[dict]:
    """The reading server's entry (:mod:`follicle.io.guard_server`): :func:`read_mesh`."""
    with refusals(request["shown"]):
        return read_mesh(request["source"], request["shown"])
