"""Reading a USD stage's first Mesh as plain arrays, in a guarded child process.

:mod:`follicle.io.usd_guard` has this module run in the guarded reading server
(:mod:`follicle.io.guard_server`, entry :func:`read_request`), beside
:mod:`follicle.io.usd_stage`, whose composition check, array checks and world matrix
(transforms, metersPerUnit, a Z up axis) it shares. The first ``UsdGeomMesh`` in stage
order becomes ``{"where", "name", "points", "face_counts", "face_indices", "uv",
"uv_scope", "flip", "others"}`` for :func:`follicle.io.polymesh.skin_from_part`:
points in follicle's space (metres, +Y up), UVs from the first of the primvars
:data:`UV_NAMES` that holds two numbers a value (indexed ones flattened). Asked for a
skin animation (``animated``), it adds the mesh's world points at every time sample of
its points and of the transforms above it, ``times`` (K,) in seconds and ``frames``
(K, P, 3) (:mod:`follicle.io.skin_animation`).
"""

from __future__ import annotations

import numpy as np
from pxr import Sdf, Usd, UsdGeom

from .curve_space import to_world
from .guard_rules import MAX_ANIMATION_POINTS
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


def _sample_times(prim: Usd.Prim, points: Usd.Attribute) -> list[float]:
    """Every time code at which the prim's points or a transform above it is sampled."""
    times = set(points.GetTimeSamples())
    while prim and not prim.IsPseudoRoot():
        if prim.IsA(UsdGeom.Xformable):
            times.update(UsdGeom.Xformable(prim).GetTimeSamples())
        prim = prim.GetParent()
    return sorted(times)


def _animation(prim: Usd.Prim, mesh: UsdGeom.Mesh, count: int, where: str) -> dict:
    """The mesh's world points at each of its time samples: ``times`` (K,) seconds on
    the stage's clock (time code / timeCodesPerSecond) and ``frames`` (K, P, 3)."""
    stage = prim.GetStage()
    codes = _sample_times(prim, mesh.GetPointsAttr())
    if len(codes) < 2:
        raise Refused(
            f"{where}: its points and transforms have {len(codes)} time sample(s); a skin"
            " animation needs the mesh sampled at two times or more"
        )
    if len(codes) * count > MAX_ANIMATION_POINTS:
        raise Refused(
            f"{where}: {len(codes):,} samples of {count:,} points is more than"
            f" {MAX_ANIMATION_POINTS:,} points in all; export fewer frames"
        )
    rate = stage.GetTimeCodesPerSecond()
    if not (np.isfinite(rate) and rate > 0):
        raise Refused(f"{where}: timeCodesPerSecond is {rate}; it must be a number > 0")
    frames = np.empty((len(codes), count, 3))
    for k, code in enumerate(codes):
        time = Usd.TimeCode(code)
        points = _array(mesh.GetPointsAttr().Get(time), "points", where)
        if points is None or points.shape != (count, 3):
            shape = None if points is None else points.shape
            raise Refused(
                f"{where}: at time code {code:g} its points have shape {shape}, at the first"
                f" ({count}, 3); a skin animation keeps its points"
            )
        world = _world(prim, time, where)
        frames[k] = to_world(points.astype(np.float64), {}, world, where, "fix its xformOps")
    return {"times": np.asarray(codes, dtype=np.float64) / rate, "frames": frames}


def read_mesh(path: str, source: str, animated: bool = False) -> list[dict]:
    """The first Mesh prim of the file at ``path`` at its earliest time, as polygons with
    their UVs, and the paths of the meshes after it; messages name it ``source``. With
    ``animated``, also its points at every time sample (:func:`_animation`)."""
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
    if animated:
        part.update(_animation(prim, mesh, len(points), where))
    return [part]


def read_request(request: dict) -> list[dict]:
    """The reading server's entry (:mod:`follicle.io.guard_server`): :func:`read_mesh`."""
    with refusals(request["shown"]):
        return read_mesh(request["source"], request["shown"], request.get("animated", False))
