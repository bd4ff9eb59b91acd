"""Model: what a simulation of guide strands keeps fixed (rest shape, masses, bindings).

Strands are (S, N, 3), root first, every strand resampled by arc length to N
vertices. The rest shape is kept in each root's frame (x tangent, y binormal, z
normal), so the skinned rest pose on any skin pose is root + frame · local: the
target of global shape matching and the place :meth:`Simulator.reset` puts hair.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..groom.guides import Guides, resample_arclength
from ..mesh.skin import SkinMesh
from ..validate import whole

__all__ = ["Model"]


@dataclass(frozen=True)
class Model:
    """Static strand data; arrays are float32 unless noted."""

    rest_local: np.ndarray  # (S, N, 3) rest shape in root frames, vertex 0 at the origin
    rest_length: np.ndarray  # (S, N − 1) segment rest lengths
    inv_mass: np.ndarray  # (S, N) 0 for the pinned root
    bend_rest: np.ndarray  # (S, N) rest distance of each vertex from the static point
    static_local: np.ndarray  # (S, 3) the static point: one segment below the root
    root_direction: np.ndarray  # (S, 3) unit direction of the first rest segment, local
    triangles: np.ndarray | None  # (S,) int64 root triangle on the mesh, None without one
    bary: np.ndarray | None  # (S, 2) float64
    rest_roots: np.ndarray  # (S, 3) float64 roots on the rest pose
    rest_frames: np.ndarray  # (S, 3, 3) float64 rows tangent, binormal, normal

    @property
    def strands(self) -> int:
        return self.rest_local.shape[0]

    @property
    def vertices(self) -> int:
        return self.rest_local.shape[1]

    @classmethod
    def build(
        cls, guides: Guides | HairCurves, mesh: SkinMesh | None, vertices: int | None = None
    ) -> Model:
        """The model of ``guides`` (bound to ``mesh`` when given) with N = ``vertices``."""
        if isinstance(guides, HairCurves) and mesh is not None:
            guides = Guides(guides, mesh)
        tri: np.ndarray | None  # the roots' binding: only guides on a mesh have one
        bary: np.ndarray | None
        if isinstance(guides, Guides):
            n = vertices or guides.vertex_count
            _check_vertices(n)
            local = guides.local_shapes(n).astype(np.float32)
            frame = np.stack([guides.tangents, guides.binormals, guides.normals], axis=1)
            roots = guides.root_positions.astype(np.float64)
            tri, bary = guides.triangles.astype(np.int64), guides.bary.astype(np.float64)
        elif isinstance(guides, HairCurves):
            if guides.curve_count == 0:
                raise InputError("guides: need at least one guide curve")
            n = vertices or int(guides.counts.max())
            _check_vertices(n)
            shapes = resample_arclength(guides, n)
            roots = shapes[:, 0].copy()
            local = (shapes - roots[:, None]).astype(np.float32)
            frame = np.broadcast_to(np.eye(3), (len(roots), 3, 3)).copy()
            tri = bary = None
        else:
            raise InputError(f"guides: expected Guides or HairCurves, got {type(guides).__name__}")
        seg = np.linalg.norm(np.diff(local.astype(np.float64), axis=1), axis=2)
        if not (seg.sum(axis=1) > 0).all():
            bad = int(np.argmin(seg.sum(axis=1)))
            raise InputError(f"guides: strand {bad} has zero length; remove it or give it a shape")
        first = local[:, 1].astype(np.float64)
        norm = np.linalg.norm(first, axis=1, keepdims=True)
        direction = np.where(norm > 1e-12, first / np.maximum(norm, 1e-300), [0.0, 0.0, 1.0])
        static = -direction * seg[:, :1]
        bend = np.linalg.norm(local.astype(np.float64) - static[:, None], axis=2)
        inv_mass = np.ones(local.shape[:2], dtype=np.float32)
        inv_mass[:, 0] = 0.0
        return cls(
            local,
            seg.astype(np.float32),
            inv_mass,
            bend.astype(np.float32),
            static.astype(np.float32),
            direction.astype(np.float32),
            tri,
            bary,
            roots,
            np.ascontiguousarray(frame, dtype=np.float64),
        )


def _check_vertices(n: int) -> None:
    whole(n, "[sim].vertices", 2, 1024)
