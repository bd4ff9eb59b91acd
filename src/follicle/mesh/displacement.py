"""Hair roots on a displaced skin: positions and frames after scalar displacement mapping.

A displacement texture adds render-time detail by moving every skin point along its
normal by ``D(u, v)``. Hair must grow from that displaced surface and lean with its
slopes, so (Šik 2012 §2.2.3 "Mesh displacement") each root's standard position and frame
are recomputed: ``P' = P + D·N`` and ``N' = ∂P'/∂u × ∂P'/∂v`` with the chain rule
``∂P'/∂u = ∂P/∂u + (∂D/∂u)·N + D·∂N/∂u`` (likewise for v), as for bump-mapped shading
normals. ``∂D`` is a forward difference of one texel.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..frames import root_frames
from ..validate import number
from .skin import SkinMesh, SurfacePoints
from .texture import Texture

__all__ = ["displace"]

# below this |∂P'/∂u × ∂P'/∂v| relative to |∂P'/∂u|·|∂P'/∂v| the displaced normal is undefined
_PARALLEL = 1e-9


def displace(
    mesh: SkinMesh,
    triangles: object,
    bary: object,
    texture: Texture,
    scale: float = 1.0,
    pose: str = "current",
) -> SurfacePoints:
    """Root positions and frames at (triangle, barycentric) samples of the displaced mesh.

    ``D = scale ×`` the texture's first channel (bilinear) at the sample's UV. Normals
    keep the side of the undisplaced ones (mirrored UVs flip ``∂P'/∂u × ∂P'/∂v``);
    where the face has no UV derivatives or the displaced surface is pinched, the
    undisplaced normal is kept and only the position moves. UVs are not changed.
    The groom never displaces the rest pose (Šik 2012 §2.2.3), but any pose works here.
    """
    if not isinstance(texture, Texture):
        raise InputError(
            f"displacement texture must be a Texture, got {type(texture).__name__};"
            " wrap the image array in Texture(...)"
        )
    if mesh.uvs is None:
        raise InputError(
            f"mesh '{mesh.name}' has no UVs, so displacement texture '{texture.name}' cannot"
            " be mapped; use a mesh with texture coordinates"
        )
    factor = number(scale, f"displacement texture '{texture.name}' scale")

    base = mesh.evaluate(triangles, bary, pose)
    tri = np.asarray(triangles).astype(np.int64)
    b = np.asarray(bary, dtype=np.float64)
    n, uv = base.normal, base.uv

    # D and its one-texel forward differences, sampled in one call
    du, dv = 1.0 / texture.width, 1.0 / texture.height
    probes = np.concatenate([uv, uv + (du, 0.0), uv + (0.0, dv)])
    values = texture.sample(probes)
    d0, d_u, d_v = np.split(factor * (values if values.ndim == 1 else values[:, 0]), 3)
    dd_du, dd_dv = (d_u - d0) / du, (d_v - d0) / dv

    dpdu, dpdv, ok = mesh.face_uv_derivatives(pose)
    dndu, dndv = _normal_uv_derivatives(mesh, tri, b, n, pose)
    # the undisplaced slopes follow the smooth normal, not the flat face, so D = 0
    # gives back N and roots do not jump at triangle edges
    dpdu_d = _tangential(dpdu[tri], n) + dd_du[:, None] * n + d0[:, None] * dndu
    dpdv_d = _tangential(dpdv[tri], n) + dd_dv[:, None] * n + d0[:, None] * dndv
    cross = np.cross(dpdu_d, dpdv_d)
    length = np.linalg.norm(cross, axis=1)
    limit = _PARALLEL * np.linalg.norm(dpdu_d, axis=1) * np.linalg.norm(dpdv_d, axis=1)
    defined = ok[tri] & (length > limit)
    new_n = np.where(defined[:, None], cross / np.where(defined, length, 1.0)[:, None], n)
    new_n = np.where(np.sum(new_n * n, axis=1, keepdims=True) < 0.0, -new_n, new_n)

    normal, tangent, binormal = root_frames(new_n, base.tangent)
    return SurfacePoints(base.position + d0[:, None] * n, normal, tangent, binormal, uv)


def _tangential(vectors: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The part of each vector orthogonal to its unit normal."""
    return vectors - np.sum(vectors * normal, axis=1, keepdims=True) * normal


def _normal_uv_derivatives(
    mesh: SkinMesh, tri: np.ndarray, bary: np.ndarray, normal: np.ndarray, pose: str
) -> tuple[np.ndarray, np.ndarray]:
    """∂N/∂u, ∂N/∂v (n, 3) of the unit interpolated normal at the samples.

    The blended vertex normal Ñ is linear on each face (``SkinMesh.face_normal_uv_derivatives``);
    N = Ñ/|Ñ| then gives ∂N = (∂Ñ − N(N·∂Ñ)) / |Ñ|. Zero where the face's UVs are
    degenerate.
    """
    vn = mesh.vertex_normals(pose)
    raw_du, raw_dv, _ = mesh.face_normal_uv_derivatives(pose)
    f = mesh.faces[tri]
    w = np.stack([bary[:, 0], bary[:, 1], 1.0 - bary[:, 0] - bary[:, 1]], axis=1)
    size = np.linalg.norm(np.sum(vn[f] * w[:, :, None], axis=1), axis=1, keepdims=True)
    inv_size = np.where(size > 0, 1.0 / np.where(size > 0, size, 1.0), 0.0)
    du, dv = (_tangential(g[tri], normal) * inv_size for g in (raw_du, raw_dv))
    return du, dv
