"""PropertyMap: a groom property as a global value, or value × texture(uv).

Every textured groom setting (density, length, scale, colour, ...) follows one rule: the
value read at a root's UV is the property's global value times the texture sampled there,
so a texture only modulates and the scene keeps one number (or colour) to tune.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from numbers import Real

import numpy as np

from ..errors import FormatError, InputError
from ..validate import number
from .texture import WRAP_MODES, Texture, checked_uv

__all__ = ["PropertyMap", "PROPERTY_KINDS"]

PROPERTY_KINDS = ("scalar", "color")
_TABLE_KEYS = ("value", "texture", "wrap")


def _value(value: object, kind: str, field: str) -> float | tuple[float, float, float]:
    """A checked scalar, or an RGB triple (a single number is broadcast to all three)."""
    if kind == "scalar" or isinstance(value, (Real, bool)):
        v = number(value, field)
        return v if kind == "scalar" else (v, v, v)
    if not isinstance(value, (list, tuple, np.ndarray)) or np.ndim(value) == 0:
        raise InputError(f"{field}: expected a number or an [r, g, b] list (got {value!r})")
    if len(value) != 3:
        raise InputError(f"{field}: an [r, g, b] colour needs 3 numbers (got {len(value)})")
    r, g, b = (number(c, f"{field}[{i}]") for i, c in enumerate(value))
    return (r, g, b)


class PropertyMap:
    """value, or value × texture(uv): one channel ("scalar") or RGB ("color").

    A scalar uses the texture's first channel. A colour broadcasts a 1-channel texture to
    RGB and uses the first 3 channels of a 3+ channel one (alpha is dropped); 2-channel
    (grey + alpha) textures are refused as ambiguous.
    """

    __slots__ = ("value", "texture", "kind", "name")

    def __init__(
        self,
        value: object,
        texture: Texture | None = None,
        kind: str = "scalar",
        name: str = "property",
    ) -> None:
        if kind not in PROPERTY_KINDS:
            raise InputError(f"{name}: kind={kind!r}; use one of {list(PROPERTY_KINDS)}")
        self.value = _value(value, kind, name)
        if texture is not None and not isinstance(texture, Texture):
            raise InputError(
                f"{name}: texture must be a Texture or None (got {type(texture).__name__})"
            )
        if texture is not None and kind == "color" and texture.channels == 2:
            raise InputError(
                f"{name}: colour texture '{texture.name}' has 2 channels (got grey + alpha);"
                " use a greyscale, RGB or RGBA image"
            )
        self.texture = texture
        self.kind = kind
        self.name = name

    @property
    def channels(self) -> int:
        """1 for a scalar, 3 for a colour."""
        return 1 if self.kind == "scalar" else 3

    @property
    def constant(self) -> bool:
        """True when there is no texture: the value is the same everywhere."""
        return self.texture is None

    def __repr__(self) -> str:
        tex = "" if self.texture is None else f", texture={self.texture!r}"
        return f"PropertyMap({self.name!r}, {self.kind}, value={self.value!r}{tex})"

    def evaluate(self, uv: object) -> np.ndarray:
        """float64 (n,) for a scalar or (n, 3) for a colour at the (n, 2) ``uv``."""
        uv = checked_uv(uv, self.name)
        value = np.asarray(self.value, dtype=np.float64)
        n = uv.shape[0]
        if self.texture is None:
            return np.full((n,) if self.kind == "scalar" else (n, 3), value)
        sampled = self.texture.sample(uv)  # (n,) for one channel, else (n, C)
        if self.kind == "scalar":
            return value * (sampled if sampled.ndim == 1 else sampled[:, 0])
        if sampled.ndim == 1:
            return sampled[:, None] * value
        return sampled[:, :3] * value

    @classmethod
    def from_spec(
        cls,
        spec: object,
        kind: str = "scalar",
        name: str = "property",
        resolve_path: Callable[[str], str] = str,
        textures: Mapping[str, Texture] | None = None,
    ) -> PropertyMap:
        """A PropertyMap from a scene setting.

        ``spec`` is a number, an ``[r, g, b]`` list (colours), a texture string (value 1)
        or a table ``{value = ..., texture = "...", wrap = "repeat" | "clamp"}`` with value
        defaulting to 1. A texture string naming a key of ``textures`` uses that texture;
        any other string is an image path, passed through ``resolve_path`` and loaded.
        """
        if isinstance(spec, str):
            spec = {"texture": spec}
        if not isinstance(spec, Mapping):
            return cls(spec, kind=kind, name=name)
        unknown = sorted(str(k) for k in spec if k not in _TABLE_KEYS)
        if unknown:
            raise InputError(
                f"{name}: unknown key(s) {unknown} (got keys {sorted(map(str, spec))});"
                f" use {list(_TABLE_KEYS)}"
            )
        value = spec.get("value", 1.0)
        source = spec.get("texture")
        wrap = spec.get("wrap")
        if source is None:
            if wrap is not None:
                raise InputError(f"{name}.wrap: given without a texture (got {wrap!r})")
            return cls(value, kind=kind, name=name)
        if not isinstance(source, str) or not source:
            raise InputError(
                f"{name}.texture: expected a texture name or an image path (got {source!r})"
            )
        if wrap is not None and wrap not in WRAP_MODES:
            raise InputError(f"{name}.wrap: got {wrap!r}; use one of {list(WRAP_MODES)}")
        return cls(value, _texture(source, wrap, name, resolve_path, textures), kind, name)


def _texture(
    source: str,
    wrap: str | None,
    name: str,
    resolve_path: Callable[[str], str],
    textures: Mapping[str, Texture] | None,
) -> Texture:
    """A named texture (re-wrapped if ``wrap`` asks for another mode), or a loaded file."""
    if textures is not None and source in textures:
        tex = textures[source]
        if wrap is None or wrap == tex.wrap:
            return tex
        return Texture(tex.data, wrap=wrap, name=tex.name)
    try:
        return Texture.load(resolve_path(source), wrap=wrap or "repeat")
    except FormatError as exc:
        known = f" (known texture names: {sorted(textures)})" if textures else ""
        raise FormatError(f"{name}.texture: {exc}{known}") from exc
