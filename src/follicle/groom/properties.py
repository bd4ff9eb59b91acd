"""The textured groom properties of a GroomParams, read at hair roots (Šik 2012 §2.2.2).

Each "(map)" setting becomes a PropertyMap (value × texture(uv)). Read at a chunk of
roots, an untextured property stays one shared value, so the kernels see one row and
copy nothing; a textured one gives a value per hair. Fractions are clipped to [0, 1]
(an HDR texture can push value × texture above 1).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from ..mesh.property import PropertyMap
from ..mesh.texture import Texture
from ..scene import GroomParams

__all__ = ["SCALARS", "COLORS", "FRACTIONS", "GroomProperties"]

SCALARS = (
    "cut",
    "scale",
    "random_scale",
    "curl_radius",
    "curl_frequency",
    "clump_root",
    "clump_tip",
    "clump_noise",
    "frizz_root",
    "frizz_tip",
    "frizz_blend",
    "kink_root",
    "kink_tip",
    "root_width",
    "tip_width",
    "hue_variation",
    "saturation_variation",
    "value_variation",
    "mutant_fraction",
    "root_opacity",
    "tip_opacity",
    "strand_splay_root",
    "strand_splay_centre",
    "strand_splay_tip",
    "strand_twist",
    "strand_aspect",
    "strand_offset",
    "strand_randomize",
)
COLORS = ("root_color", "tip_color", "mutant_color")
FRACTIONS = frozenset(
    (
        "cut",
        "random_scale",
        "clump_root",
        "clump_tip",
        "clump_noise",
        "frizz_blend",
        "saturation_variation",
        "value_variation",
        "mutant_fraction",
        "root_opacity",
        "tip_opacity",
        "strand_randomize",
    )
)


class GroomProperties:
    """PropertyMaps for every textured setting of ``params``; ``at(uv)`` reads them."""

    def __init__(
        self,
        params: GroomParams,
        resolve_path: Callable[[str], str] = str,
        textures: Mapping[str, Texture] | None = None,
    ) -> None:
        self.maps = {
            name: PropertyMap.from_spec(
                getattr(params, name), kind, f"[groom].{name}", resolve_path, textures
            )
            for names, kind in ((SCALARS, "scalar"), (COLORS, "color"))
            for name in names
        }

    def at(self, uv: np.ndarray, names: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
        """Properties (all, or ``names``) at the roots ``uv`` (n, 2).

        float64 (n,)/(n, 3), or (1,)/(1, 3) when shared by every hair.
        """
        out = {}
        for name in self.maps if names is None else names:
            prop = self.maps[name]
            if prop.constant:
                value = np.asarray(prop.value, dtype=np.float64).reshape(1, -1)
                out[name] = value[:, 0] if prop.kind == "scalar" else value
            else:
                out[name] = prop.evaluate(uv)
            if name in FRACTIONS:
                out[name] = np.clip(out[name], 0.0, 1.0)
        return out
