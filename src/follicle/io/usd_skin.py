"""The skin a groom grew on, written into its USD file beside the hair.

:func:`follicle.io.usd.save_usd` and :func:`~follicle.io.usd.save_usd_cache` take a
``mesh=`` so the skin opens next to the hair in Blender, Houdini or usdview: a
``UsdGeomMesh`` of the SkinMesh's rest pose (points, triangles as
``faceVertexCounts`` / ``faceVertexIndices``, per-vertex UVs as ``primvars:st``
texCoord2f, ``extent``, ``subdivisionScheme = "none"``: the triangles are the surface
the hair was grown on, not a cage; ``orientation = "rightHanded"``). An animation's
head motion is an ``Xform`` above it whose ``xformOp:transform`` is sampled per frame; a
deforming skin has its ``points`` and ``extent`` sampled per frame (:func:`set_points`).
"""

from __future__ import annotations

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from ..errors import InputError
from ..mesh.skin import SkinMesh

__all__ = ["define_skin", "define_head", "set_head", "set_points"]


def define_skin(stage: Usd.Stage, path: str, mesh: object) -> None:
    """``mesh`` (a SkinMesh) at rest as a UsdGeomMesh at ``path``."""
    if not isinstance(mesh, SkinMesh):
        raise InputError(
            f"mesh: expected a SkinMesh (the skin to write beside the hair), got"
            f" {type(mesh).__name__}"
        )
    points = np.asarray(mesh.rest_vertices, dtype=np.float32)
    skin = UsdGeom.Mesh.Define(stage, path)
    skin.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    skin.CreateExtentAttr(_extent(points))
    skin.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(mesh.face_count, 3, np.int32)))
    skin.CreateFaceVertexIndicesAttr(
        Vt.IntArray.FromNumpy(np.ascontiguousarray(mesh.faces, dtype=np.int32).reshape(-1))
    )
    skin.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    skin.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    if mesh.uvs is not None:
        st = UsdGeom.PrimvarsAPI(skin).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
        )
        st.Set(Vt.Vec2fArray.FromNumpy(np.asarray(mesh.uvs, dtype=np.float32)))


def _extent(points: np.ndarray) -> Vt.Vec3fArray:
    lo, hi = points.min(axis=0), points.max(axis=0)
    return Vt.Vec3fArray([Gf.Vec3f(*lo.tolist()), Gf.Vec3f(*hi.tolist())])


def set_points(skin: UsdGeom.Mesh, points: np.ndarray, time: Usd.TimeCode) -> None:
    """Sample the skin's ``points`` (V, 3) float32 and ``extent`` at ``time``: a deforming
    skin (:mod:`follicle.io.skin_animation`)."""
    skin.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(points), time)
    skin.GetExtentAttr().Set(_extent(points), time)


def define_head(stage: Usd.Stage, path: str) -> UsdGeom.XformOp:
    """An Xform at ``path`` for the skin to sit under; its ``xformOp:transform``, to
    sample with :func:`set_head`."""
    return UsdGeom.Xform.Define(stage, path).AddTransformOp()


def set_head(op: UsdGeom.XformOp, matrix: np.ndarray, time: Usd.TimeCode) -> None:
    """Sample ``op`` at ``time`` with ``matrix`` (column vectors; USD's act on rows)."""
    op.Set(Gf.Matrix4d(matrix.T.tolist()), time)
