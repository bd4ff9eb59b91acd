"""Guides: artist-made guide curves bound to the skin mesh.

Each guide keeps the triangle and barycentric coordinates of its root on the rest
mesh, the rest root frame there, and its vertices relative to the root in that frame
(000 §2.2.4 "Interpolation details"): interpolating in root-local frames keeps the
hair shape when the mesh deforms and stops guides on the far side of a thin part from
bleeding through. Guides are resampled by arc length to a common vertex count.
"""

from __future__ import annotations

import os

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..mesh.skin import SkinMesh

__all__ = ["Guides", "load_guides", "resample_arclength"]


def resample_arclength(curves: HairCurves, vertices: int) -> np.ndarray:
    """Every curve resampled to ``vertices`` points evenly spaced by arc length, (C, n, 3)."""
    if vertices < 2:
        raise InputError(f"vertices: need at least 2 per curve, got {vertices}")
    out = np.empty((curves.curve_count, vertices, 3), dtype=np.float64)
    s_new = np.linspace(0.0, 1.0, vertices)
    for i in range(curves.curve_count):
        pts = curves.curve(i).astype(np.float64)
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        if s[-1] <= 0:
            raise InputError(f"guide {i} has zero length; remove it or give it a shape")
        s /= s[-1]
        for axis in range(3):
            out[i, :, axis] = np.interp(s_new, s, pts[:, axis])
    return out


class Guides:
    """Guide curves bound to ``mesh``'s rest pose.

    Roots come from ``curve_data['root_triangle']``/``['root_bary']`` when present,
    else from the closest point of the rest mesh to each guide's first vertex.
    """

    def __init__(self, curves: HairCurves, mesh: SkinMesh, vertices: int | None = None) -> None:
        if curves.curve_count == 0:
            raise InputError("guides: need at least one guide curve")
        self.curves = curves
        self.mesh = mesh
        n = vertices if vertices is not None else int(curves.counts.max())
        if "root_triangle" in curves.curve_data and "root_bary" in curves.curve_data:
            self.triangles = curves.curve_data["root_triangle"].astype(np.int64)
            self.bary = curves.curve_data["root_bary"].astype(np.float64)
            if self.triangles.min() < 0 or self.triangles.max() >= len(mesh.faces):
                raise InputError(
                    f"guides: root_triangle refers to triangles outside mesh '{mesh.name}'"
                    f" ({len(mesh.faces)} faces); were the guides made for another mesh?"
                )
        else:
            roots = curves.points[curves.offsets[:-1]]
            self.triangles, self.bary, _ = mesh.closest_points(roots, pose="rest")
        shape = resample_arclength(curves, n)
        frame = mesh.evaluate(self.triangles, self.bary, pose="rest")
        self.root_positions = frame.position
        self.normals, self.tangents, self.binormals = frame.normal, frame.tangent, frame.binormal
        rel = shape - shape[:, :1, :]
        # root-local coordinates: x along the tangent, y the binormal, z the normal
        self.local = np.stack(
            [
                np.einsum("snk,sk->sn", rel, self.tangents),
                np.einsum("snk,sk->sn", rel, self.binormals),
                np.einsum("snk,sk->sn", rel, self.normals),
            ],
            axis=-1,
        ).astype(np.float32)

    @property
    def count(self) -> int:
        return self.local.shape[0]

    @property
    def vertex_count(self) -> int:
        return self.local.shape[1]

    def __repr__(self) -> str:
        return f"Guides({self.count} guides × {self.vertex_count} vertices on '{self.mesh.name}')"


def load_guides(
    source: str | os.PathLike[str] | HairCurves, mesh: SkinMesh, vertices: int | None = None
) -> Guides:
    """Guides from ``builtin:long|short|curly``, a curves file, or HairCurves, bound to ``mesh``."""
    from ..io.dispatch import load_curves
    from .builtin_guides import builtin_guides

    if isinstance(source, HairCurves):
        curves = source
    elif str(source).startswith("builtin:"):
        curves = builtin_guides(str(source).split(":", 1)[1], mesh)
    else:
        curves = load_curves(source)
    return Guides(curves, mesh, vertices)
