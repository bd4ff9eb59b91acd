"""Groom: grows every final hair from the guides, in the pipeline order of 000 §2.2.2.

roots (DensitySampler on the rest mesh) ► interpolate (root-local IDW) ► place on the current pose
► appearance (width, opacity, colour) ► HairCurves. Work is done in chunks of hair
ids; each hair depends only on (seed, id), so chunking never changes a byte.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..mesh.displacement import displace
from ..mesh.head import SCALP_TEXTURE, scalp_texture
from ..mesh.sampling import DensitySampler
from ..mesh.skin import SkinMesh
from ..mesh.texture import Texture
from ..scene import GroomParams
from .appearance import root_to_tip
from .guides import Guides
from .interpolate import blend_guides, idw_weights

__all__ = ["Groom", "resolve_density"]

CHUNK = 65536


BUILTIN_TEXTURES = {"builtin:scalp": scalp_texture}


def resolve_density(
    mesh: SkinMesh, spec: str | float | Texture | None, resolve_path: Callable[[str], str] = str
) -> Texture | float | None:
    """A density setting made concrete: ``builtin:scalp``, an image path, a number or None.

    None picks the mesh's own scalp map when it has one (the built-in head), else
    uniform density.
    """
    if spec is None:
        return mesh.textures.get(SCALP_TEXTURE)
    if isinstance(spec, str):
        return load_texture(spec, resolve_path)
    return spec


def load_texture(spec: str, resolve_path: Callable[[str], str] = str) -> Texture:
    """A texture from ``builtin:NAME`` or an image path (resolved against the scene)."""
    if spec.startswith("builtin:"):
        if spec not in BUILTIN_TEXTURES:
            raise InputError(
                f"unknown built-in texture {spec!r}; choose one of {sorted(BUILTIN_TEXTURES)}"
            )
        return BUILTIN_TEXTURES[spec]()
    return Texture.load(resolve_path(spec))


class Groom:
    """Grows hair on ``mesh`` from ``guides`` with ``params`` (defaults when None).

    ``density`` overrides ``params.density`` (a Texture, number, path or None). With a
    ``displacement`` texture, roots on the current pose sit on the displaced skin
    (000 §2.2.3); interpolation still uses the undisplaced rest pose.
    """

    def __init__(
        self,
        mesh: SkinMesh,
        guides: Guides | HairCurves,
        params: GroomParams | None = None,
        density: Texture | float | str | None = None,
        displacement: Texture | None = None,
        displacement_scale: float = 1.0,
    ) -> None:
        self.mesh = mesh
        self.params = params if params is not None else GroomParams()
        wanted = self.params.vertices
        if isinstance(guides, HairCurves):
            guides = Guides(guides, mesh, wanted)
        elif wanted is not None and guides.vertex_count != wanted:
            guides = Guides(guides.curves, mesh, wanted)
        self.guides = guides
        spec = density if density is not None else self.params.density
        self.sampler = DensitySampler(
            mesh, resolve_density(mesh, spec), refine=self.params.density_refine
        )
        self.displacement = displacement
        self.displacement_scale = displacement_scale

    def grow(
        self,
        count: int | None = None,
        seed: int | None = None,
        progress: Callable[[int, int], None] | None = None,
    ) -> HairCurves:
        """Grow ``count`` hairs (default params.count) on the mesh's current pose."""
        p = self.params
        count = p.count if count is None else count
        seed = p.seed if seed is None else seed
        if count < 0:
            raise InputError(f"count: must be ≥ 0, got {count}")
        n = self.guides.vertex_count
        points = np.empty((count, n, 3), dtype=np.float32)
        triangles = np.empty(count, dtype=np.int32)
        bary = np.empty((count, 2), dtype=np.float32)
        root_uv = np.empty((count, 2), dtype=np.float32)
        for start in range(0, count, CHUNK):
            stop = min(start + CHUNK, count)
            tri, b = self.sampler.sample(stop - start, seed, "random", start)
            points[start:stop], root_uv[start:stop] = self._shapes(tri, b)
            triangles[start:stop], bary[start:stop] = tri, b
            if progress is not None:
                progress(stop, count)
        attrs = root_to_tip(
            count, n, p.root_width, p.tip_width, p.root_color, p.tip_color,
            p.root_opacity, p.tip_opacity,
        )
        return HairCurves.from_array(
            points,
            point_data=attrs,
            curve_data={
                "hair_id": np.arange(count, dtype=np.int64),
                "root_uv": root_uv,
                "root_triangle": triangles.astype(np.int64),
                "root_bary": bary,
            },
        )

    def _shapes(self, triangles: np.ndarray, bary: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Hair vertices (n, N, 3) on the current pose and root UVs (n, 2) of these roots."""
        rest = self.mesh.evaluate(triangles, bary, pose="rest")
        idx, w = idw_weights(self.guides.root_positions, rest.position, self.params.guide_samples)
        if self.displacement is None:
            cur = self.mesh.evaluate(triangles, bary, pose="current")
        else:
            cur = displace(self.mesh, triangles, bary, self.displacement, self.displacement_scale)
        shapes = blend_guides(
            self.guides.local, idx, w, cur.position, cur.tangent, cur.binormal, cur.normal,
            self.params.scale,
        )
        return shapes, rest.uv
