"""Groom: grows every final hair from the guides, in the pipeline order of 000 §2.2.2.

roots (DensitySampler on the rest mesh) ► interpolate (root-local IDW) ► place on the current pose
► appearance (width, opacity, colour) ► HairCurves. Work is done in chunks of hair
ids; each hair depends only on (seed, id), so chunking never changes a byte.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np
from scipy.spatial import cKDTree

from ..curves import HairCurves
from ..errors import InputError
from ..mesh.displacement import displace
from ..mesh.head import SCALP_TEXTURE, parting_texture, scalp_texture
from ..mesh.sampling import DensitySampler
from ..mesh.skin import SkinMesh
from ..mesh.texture import Texture
from ..scene import GroomParams
from .appearance import hair_appearance
from .guides import Guides
from .interpolate import blend_guides, idw_weights

__all__ = ["Groom", "resolve_density"]

log = logging.getLogger("follicle")

CHUNK = 65536


BUILTIN_TEXTURES = {"builtin:scalp": scalp_texture, "builtin:parting": parting_texture}


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

    Hairs follow the guides' interpolation groups; each has ``params.vertices``
    vertices (default: the guides' count) unless its group sets its own.

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
        if isinstance(guides, HairCurves):
            guides = Guides(guides, mesh)
        self.guides = guides
        spec = density if density is not None else self.params.density
        self.sampler = DensitySampler(
            mesh, resolve_density(mesh, spec), refine=self.params.density_refine
        )
        self.displacement = displacement
        self.displacement_scale = displacement_scale
        groups = self.guides.groups
        default = self.params.vertices or self.guides.vertex_count
        self._vertices = np.array(
            [groups.vertex_count(g, default) for g in range(groups.count)], dtype=np.int64
        )
        self._trees: dict[int, tuple[cKDTree, np.ndarray]] = {}

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
        parts: list[tuple[np.ndarray, ...]] = []
        for start in range(0, max(count, 1), CHUNK):  # count 0: one empty chunk
            stop = min(start + CHUNK, count)
            tri, b = self.sampler.sample(stop - start, seed, "random", start)
            parts.append((tri, b, *self._chunk(tri, b, np.arange(start, stop), seed)))
            if progress is not None:
                progress(stop, count)
        tri, bary, root_uv, counts, points, *attrs = (
            np.concatenate([part[k] for part in parts]) for k in range(8)
        )
        return HairCurves(
            points,
            np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            point_data=dict(zip(("width", "opacity", "color"), attrs, strict=True)),
            curve_data={
                "hair_id": np.arange(count, dtype=np.int64),
                "root_uv": root_uv,
                "root_triangle": tri.astype(np.int64),
                "root_bary": bary,
            },
        )

    def _chunk(
        self, triangles: np.ndarray, bary: np.ndarray, ids: np.ndarray, seed: int
    ) -> tuple[np.ndarray, ...]:
        """Root UVs, vertex counts, points and per-vertex width, opacity, colour of hairs.

        Each hair takes guides of its own interpolation group only (000 §2.2.4) and
        that group's vertex count; the pieces are laid out in hair order.
        """
        p = self.params
        rest = self.mesh.evaluate(triangles, bary, pose="rest")
        group = self.guides.groups.group_of(rest.uv)
        if self.displacement is None:
            cur = self.mesh.evaluate(triangles, bary, pose="current")
        else:
            cur = displace(self.mesh, triangles, bary, self.displacement, self.displacement_scale)
        counts = self._vertices[group]
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        total = int(counts.sum())
        points = np.empty((total, 3), dtype=np.float32)
        width, opacity = np.empty(total, np.float32), np.empty(total, np.float32)
        color = np.empty((total, 3), np.float32)
        for g in np.unique(group):
            tree, members = self._group_guides(int(g))
            sel = np.flatnonzero(group == g)
            n = int(self._vertices[g])
            idx, w = idw_weights(tree, rest.position[sel], p.guide_samples)
            shapes = blend_guides(
                self.guides.local_shapes(n)[members], idx, w, cur.position[sel],
                cur.tangent[sel], cur.binormal[sel], cur.normal[sel], p.scale,
            )
            rows = (starts[sel][:, None] + np.arange(n)).ravel()
            points[rows] = shapes.reshape(-1, 3)
            look = hair_appearance(
                ids[sel], seed, n, p.root_color, p.tip_color, p.hue_variation,
                p.saturation_variation, p.value_variation, p.mutant_fraction, p.mutant_color,
                p.root_width, p.tip_width, p.root_opacity, p.tip_opacity,
            )
            width[rows], opacity[rows], color[rows] = look["width"], look["opacity"], look["color"]
        return rest.uv.astype(np.float32), counts, points, width, opacity, color

    def _group_guides(self, group: int) -> tuple[cKDTree, np.ndarray]:
        """A KD-tree over the rest roots of ``group``'s guides, and their indices."""
        if group not in self._trees:
            label = self.guides.groups.label(group)
            members = np.flatnonzero(self.guides.group == group)
            if len(members) == 0:
                raise InputError(
                    f"interpolation group {label} has hairs but no guides; add guides in"
                    " that colour's area or repaint the group texture"
                )
            if len(members) < self.params.guide_samples:
                log.warning(
                    "interpolation group %s has %d guide(s), fewer than guide_samples = %d:"
                    " its hairs blend all of them", label, len(members),
                    self.params.guide_samples,
                )
            self._trees[group] = (cKDTree(self.guides.root_positions[members]), members)
        return self._trees[group]

