"""Interpolation groups: one group per colour of a texture painted on the skin (Šik 2012 §2.2.4).

A hair is interpolated only from guides of its own group, which is how a parting stays
a clean line instead of a blur between the guides combed left and those combed right,
and each group may have its own vertex count (short fur, long mane). The group of a
root is the colour of the nearest texel at its rest UV: groups are labels, so they are
never interpolated (§3.1.5).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import InputError
from ..mesh.texture import Texture, checked_uv
from ..validate import whole

__all__ = ["InterpolationGroups", "color_label", "mesh_groups"]


def color_label(rgb: np.ndarray) -> str:
    """'#rrggbb' of an 8-bit colour."""
    return "#" + "".join(f"{int(c):02x}" for c in rgb[:3])


class InterpolationGroups:
    """Group ids from a texture's colours; one group covering everything without one.

    Colours are quantised to 8 bits per RGB channel and numbered in order of first
    appearance, row by row from the top of the image, so the numbering is stable.
    ``vertices`` maps a colour label ('#rrggbb') to that group's vertex count.
    """

    def __init__(
        self, texture: Texture | None = None, vertices: Mapping[str, int] | None = None
    ) -> None:
        self.texture = texture
        self.colors: np.ndarray  # (G, 3) uint8, a group's colour
        self._ids: np.ndarray  # (H, W) int32, each texel's group
        if texture is None:
            self.colors = np.zeros((1, 3), dtype=np.uint8)
            self._ids = np.zeros((1, 1), dtype=np.int32)
        else:
            rgb = np.clip(np.rint(texture.data[:, :, :3] * 255.0), 0, 255).astype(np.uint8)
            if rgb.shape[2] == 1:
                rgb = np.repeat(rgb, 3, axis=2)
            packed = (rgb[:, :, 0].astype(np.int32) << 16) | (rgb[:, :, 1].astype(np.int32) << 8)
            packed |= rgb[:, :, 2]
            values, first, inverse = np.unique(
                packed.ravel(), return_index=True, return_inverse=True
            )
            order = np.argsort(first)  # first appearance, row-major
            rank = np.empty_like(order)
            rank[order] = np.arange(len(order))
            self._ids = rank[inverse].reshape(packed.shape).astype(np.int32)
            ordered = values[order]
            self.colors = np.stack(
                [(ordered >> 16) & 255, (ordered >> 8) & 255, ordered & 255], axis=1
            ).astype(np.uint8)
        self.vertices: dict[int, int] = {}
        known = {self.label(g): g for g in range(self.count)}
        for label, count in (vertices or {}).items():
            key = str(label).lower()
            if key not in known:
                raise InputError(
                    f"group_vertices: no interpolation group has colour {label!r}; the group"
                    f" texture's colours are {sorted(known)}"
                )
            name = f"group_vertices[{label!r}]"
            self.vertices[known[key]] = whole(count, name, 2, what="a whole number of vertices")

    @property
    def count(self) -> int:
        return len(self.colors)

    def label(self, group: int) -> str:
        """The group's colour as '#rrggbb' (for messages and scene keys)."""
        return color_label(self.colors[group])

    def vertex_count(self, group: int, default: int) -> int:
        """Vertices per hair of ``group``: its own setting, else ``default``."""
        return self.vertices.get(group, default)

    def group_of(self, uv: object) -> np.ndarray:
        """Group id (int32 (n,)) of the nearest texel at each rest UV."""
        uv = checked_uv(uv, "interpolation groups")
        if self.texture is None:
            return np.zeros(len(uv), dtype=np.int32)
        h, w = self._ids.shape
        col = np.floor(uv[:, 0] * w).astype(np.int64)
        row = np.floor((1.0 - uv[:, 1]) * h).astype(np.int64)
        if self.texture.wrap == "repeat":
            col, row = np.mod(col, w), np.mod(row, h)
        else:
            col, row = np.clip(col, 0, w - 1), np.clip(row, 0, h - 1)
        return self._ids[row, col]

    def __repr__(self) -> str:
        labels = ", ".join(self.label(g) for g in range(min(self.count, 8)))
        more = ", …" if self.count > 8 else ""
        return f"InterpolationGroups({self.count}: {labels}{more})"


def mesh_groups(mesh: object, vertices: Mapping[str, int] | None = None) -> InterpolationGroups:
    """The groups a mesh's built-in guides take unless told otherwise: its own parting
    texture (the built-in head's, split at its mid-plane) when it has one, else one group
    for everything. The one place this default lives, for the Python API, the scene and
    the viewer alike."""
    from ..mesh.head import PARTING_TEXTURE

    return InterpolationGroups(getattr(mesh, "textures", {}).get(PARTING_TEXTURE), vertices)
