"""The textured groom properties of a GroomParams, read at hair roots (Šik 2012 §2.2.2).

Each "(map)" setting becomes a PropertyMap (value × texture(uv)). Read at a chunk of
roots, an untextured property stays one shared value, so the kernels see one row and
copy nothing; a textured one gives a value per hair. Fractions are clipped to [0, 1]
(an HDR texture can push value × texture above 1).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from ..errors import InputError
from ..mesh.property import PropertyMap
from ..mesh.texture import Texture
from .settings import GroomParams, PropertyTag

__all__ = ["SCALARS", "COLORS", "FRACTIONS", "GroomProperties"]

# the textured settings, from the tags GroomParams' schema gives them, in its order
_TAGS = {
    name: tag
    for name, field in GroomParams.model_fields.items()
    for tag in field.metadata
    if isinstance(tag, PropertyTag)
}
SCALARS = tuple(name for name, tag in _TAGS.items() if not tag.color)
COLORS = tuple(name for name, tag in _TAGS.items() if tag.color)
FRACTIONS = frozenset(name for name, tag in _TAGS.items() if tag.fraction)
LOWS = {name: tag.low for name, tag in _TAGS.items() if tag.low is not None}


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
                _check_low(name, prop, out[name])
            if name in FRACTIONS:
                out[name] = np.clip(out[name], 0.0, 1.0)
        return out


def _check_low(name: str, prop: PropertyMap, values: np.ndarray) -> None:
    """InputError when value × texture falls below the property's least value somewhere
    (a float texture with negative texels under a length or an amplitude), naming the
    key, the texture and the fix: a texture cannot make a hair's length negative."""
    low = LOWS.get(name)
    if low is None or values.size == 0:
        return
    least = float(values.min())
    if least < low:
        texture = getattr(prop.texture, "name", "its texture")
        raise InputError(
            f"[groom].{name}: value × texture '{texture}' is {least:g} at some roots, below"
            f" the least it may be ({low:g}); mend the texture (its texels scale the value)"
        )
