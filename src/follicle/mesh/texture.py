"""Texture: an image sampled bilinearly at UV coordinates (density, colour, length maps).

UV origin is bottom-left as in OBJ/USD: ``v = 0`` is the LAST image row and ``v = 1``
the first; texel ``(row i, column j)`` has its centre at ``u = (j + 0.5) / W``,
``v = 1 - (i + 0.5) / H``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from numba import njit

from ..errors import FormatError, InputError

__all__ = ["Texture", "WRAP_MODES"]

WRAP_MODES = ("repeat", "clamp")


def _to_float(data: np.ndarray, name: str) -> np.ndarray:
    """Integer images scale to [0, 1] (uint8 / 255, uint16 / 65535); floats stay as is."""
    if data.dtype == np.uint8:
        return data.astype(np.float32) / np.float32(255.0)
    if data.dtype == np.uint16:
        return data.astype(np.float32) / np.float32(65535.0)
    if data.dtype == np.bool_:
        return data.astype(np.float32)
    if np.issubdtype(data.dtype, np.integer) or np.issubdtype(data.dtype, np.floating):
        return data.astype(np.float32)
    raise InputError(f"texture '{name}': data of dtype {data.dtype} is not numeric")


class Texture:
    """An (H, W, C) float32 image with bilinear sampling at UVs.

    ``Texture(data, wrap="repeat", name="texture")`` takes an (H, W) or (H, W, C)
    array: uint8 is divided by 255, uint16 by 65535, floats are kept in any range.
    ``wrap`` is ``"repeat"`` (tile) or ``"clamp"`` (edge texels extend outwards).
    """

    __slots__ = ("data", "wrap", "name")

    def __init__(self, data: object, wrap: str = "repeat", name: str = "texture") -> None:
        arr = np.asarray(data)
        if arr.ndim == 2:
            arr = arr[:, :, None]
        if arr.ndim != 3 or arr.shape[0] < 1 or arr.shape[1] < 1 or arr.shape[2] < 1:
            raise InputError(
                f"texture '{name}': expected an (H, W) or (H, W, C) array with H, W, C >= 1,"
                f" got shape {np.shape(data)}"
            )
        out = np.ascontiguousarray(_to_float(arr, name))
        if not np.all(np.isfinite(out)):
            raise InputError(f"texture '{name}': contains NaN or inf; replace them by numbers")
        if wrap not in WRAP_MODES:
            raise InputError(f"texture '{name}': wrap={wrap!r}; use one of {list(WRAP_MODES)}")
        out.setflags(write=False)
        self.data: np.ndarray = out
        self.wrap = wrap
        self.name = name

    # ------------------------------------------------------------------ loading
    @classmethod
    def load(cls, path: str | os.PathLike[str], wrap: str = "repeat") -> Texture:
        """Read a PNG/JPEG/TIFF (8 or 16 bit, greyscale or colour) through pillow."""
        from PIL import Image, UnidentifiedImageError

        p = Path(path)
        if not p.is_file():
            raise FormatError(f"texture file '{p}' does not exist; check the path")
        try:
            with Image.open(p) as img:
                img.load()
                arr = _image_array(img)
        except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
            raise FormatError(
                f"texture file '{p}' cannot be read as an image ({exc}); use PNG, JPEG or TIFF"
            ) from exc
        return cls(arr, wrap=wrap, name=p.stem)

    # ------------------------------------------------------------------ views
    @property
    def height(self) -> int:
        return int(self.data.shape[0])

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def channels(self) -> int:
        return int(self.data.shape[2])

    @property
    def shape(self) -> tuple[int, int, int]:
        return (self.height, self.width, self.channels)

    def __repr__(self) -> str:
        return (
            f"Texture('{self.name}', {self.width}x{self.height}, {self.channels} channel(s),"
            f" wrap='{self.wrap}')"
        )

    # ------------------------------------------------------------------ sampling
    def sample(self, uv: object) -> np.ndarray:
        """Bilinear values at ``uv`` (n, 2): float64 (n,) for one channel, else (n, C)."""
        uv = np.asarray(uv, dtype=np.float64)
        if uv.ndim != 2 or uv.shape[1] != 2:
            raise InputError(f"texture '{self.name}': uv must have shape (n, 2), got {uv.shape}")
        if not np.all(np.isfinite(uv)):
            raise InputError(f"texture '{self.name}': uv contains NaN or inf")
        out = _sample_kernel(self.data, self.wrap == "repeat", np.ascontiguousarray(uv))
        return out[:, 0] if self.channels == 1 else out


@njit(cache=True, inline="always")
def _wrap(i, n, repeat):
    if repeat:
        return i % n  # Python semantics in numba: never negative
    return min(max(i, 0), n - 1)


@njit(cache=True)
def bilinear(data, repeat, u, v, c):
    """Channel ``c`` of (H, W, C) ``data`` at (u, v), bilinear; for use inside kernels."""
    h, w = data.shape[0], data.shape[1]
    x = u * w - 0.5  # continuous column, texel centres at integers
    y = (1.0 - v) * h - 0.5  # continuous row from the top
    x0 = np.floor(x)
    y0 = np.floor(y)
    fx = x - x0
    fy = y - y0
    i0, j0 = int(y0), int(x0)
    r0, r1 = _wrap(i0, h, repeat), _wrap(i0 + 1, h, repeat)
    c0, c1 = _wrap(j0, w, repeat), _wrap(j0 + 1, w, repeat)
    top = data[r0, c0, c] * (1.0 - fx) + data[r0, c1, c] * fx
    bottom = data[r1, c0, c] * (1.0 - fx) + data[r1, c1, c] * fx
    return top * (1.0 - fy) + bottom * fy


@njit(cache=True)
def _sample_kernel(data, repeat, uv):
    out = np.empty((uv.shape[0], data.shape[2]), dtype=np.float64)
    for n in range(uv.shape[0]):
        for c in range(data.shape[2]):
            out[n, c] = bilinear(data, repeat, uv[n, 0], uv[n, 1], c)
    return out


def _image_array(img: object) -> np.ndarray:
    """Pixels of a pillow image as uint8/uint16/float32, keeping the bit depth."""
    mode = img.mode
    if mode in ("I;16", "I;16B", "I;16L"):
        return np.asarray(img, dtype=np.uint16)
    if mode == "I":
        arr = np.asarray(img)
        # 16-bit PNGs arrive as 32-bit ints; anything larger is an unsupported depth
        if arr.size and (arr.min() < 0 or arr.max() > 65535):
            raise ValueError("32-bit integer pixels are not supported")
        return arr.astype(np.uint16)
    if mode == "F":
        return np.asarray(img, dtype=np.float32)
    if mode in ("1", "L", "LA", "RGB", "RGBA"):
        return np.asarray(img.convert("L" if mode == "1" else mode), dtype=np.uint8)
    alpha = "A" in img.getbands() or "transparency" in img.info
    converted = img.convert("RGBA" if alpha else "RGB")
    return np.asarray(converted, dtype=np.uint8)
