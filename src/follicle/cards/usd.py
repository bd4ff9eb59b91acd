"""The cards as USD: a mesh per level of detail under /Cards (``LOD0``, ``LOD1`` ...),
Y up in metres, each bound to one UsdPreviewSurface material whose diffuse colour and
opacity (alpha-masked by ``opacityThreshold``, the glTF file's ``alphaCutoff``) read the
atlas's colour PNG; the atlas's maps are written beside the stage as
``NAME_color.png``, ``NAME_depth.png``, ``NAME_attribute.png`` and ``NAME_tangent.png``
(their paths relative to it), each atomically (UsdPreviewSurface specification,
Pixar 2019: UsdUVTexture, UsdPrimvarReader_float2).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..atomic import atomic_path
from .gltf import LodMesh

if TYPE_CHECKING:
    from pxr import UsdShade

__all__ = ["write_maps", "write_usd"]


def _texture(stage, material, name: str, file: str, st) -> UsdShade.Shader:
    """A UsdUVTexture of ``file`` read at the primvar ``st`` (sRGB for the colour)."""
    from pxr import Sdf, UsdShade

    tex = UsdShade.Shader.Define(stage, material.GetPath().AppendChild(name))
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(file)
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(st)
    tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("clamp")
    tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB")
    return tex


def write_maps(path: Path, images: dict[str, bytes]) -> None:
    """The PNG ``images`` beside ``path``, each as ``STEM_NAME.png``, atomically."""
    for name, png in images.items():
        with atomic_path(path.with_name(f"{path.stem}_{name}.png")) as tmp:
            tmp.write_bytes(png)


def write_usd(
    path: Path, lods: list[LodMesh], images: dict[str, bytes], alpha_cutoff: float
) -> None:
    """Write ``lods`` to the USD file ``path`` and ``images`` (PNG bytes by map name, the
    first the colour with coverage as alpha) beside it."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

    write_maps(path, images)
    with atomic_path(path) as tmp:
        args = {"format": "usdc"} if path.suffix.lower() == ".usd" else {}
        stage = Usd.Stage.Open(Sdf.Layer.CreateNew(str(tmp), args))
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        root = UsdGeom.Xform.Define(stage, "/Cards")
        stage.SetDefaultPrim(root.GetPrim())
        material = UsdShade.Material.Define(stage, "/Cards/Looks/hair_cards")
        reader = UsdShade.Shader.Define(stage, "/Cards/Looks/hair_cards/st")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
        st = reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)
        color = _texture(stage, material, "color", f"./{path.stem}_color.png", st)
        surface = UsdShade.Shader.Define(stage, "/Cards/Looks/hair_cards/surface")
        surface.CreateIdAttr("UsdPreviewSurface")
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
            color.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        )
        surface.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(
            color.CreateOutput("a", Sdf.ValueTypeNames.Float)
        )
        surface.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(alpha_cutoff)
        surface.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.6)
        material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
        for lod, mesh in enumerate(lods):
            prim = UsdGeom.Mesh.Define(stage, f"/Cards/LOD{lod}")
            prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(mesh.positions))
            prim.CreateFaceVertexCountsAttr(
                Vt.IntArray.FromNumpy(np.full(len(mesh.indices), 3, np.int32))
            )
            prim.CreateFaceVertexIndicesAttr(
                Vt.IntArray.FromNumpy(mesh.indices.reshape(-1).astype(np.int32))
            )
            prim.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(mesh.normals))
            prim.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
            prim.CreateDoubleSidedAttr(True)
            prim.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
            lo, hi = mesh.positions.min(axis=0), mesh.positions.max(axis=0)
            prim.CreateExtentAttr([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))])
            # USD's st has v up from the bottom; glTF's from the top
            st_values = np.column_stack([mesh.uvs[:, 0], 1.0 - mesh.uvs[:, 1]]).astype(np.float32)
            UsdGeom.PrimvarsAPI(prim).CreatePrimvar(
                "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex
            ).Set(Vt.Vec2fArray.FromNumpy(st_values))
            UsdShade.MaterialBindingAPI.Apply(prim.GetPrim()).Bind(material)
            if lod:
                prim.CreateVisibilityAttr(UsdGeom.Tokens.invisible)
        stage.GetRootLayer().Save()
