"""Texture: an image sampled bilinearly at UV coordinates (density, colour, length maps).

UV origin is bottom-left as in OBJ/USD: ``v = 0`` is the LAST image row and ``v = 1``
the first; texel ``(row i, column j)`` has its centre at ``u = (j + 0.5) / W``,
``v = 1 - (i + 0.5) / H``.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np

from ..arrays import as_array
from ..errors import FileAccessError, FollicleError, FormatError, InputError
from ..inputs import input_file, is_url
from ..kernels import kernel
from ..validate import file_path

if TYPE_CHECKING:
    from PIL import Image, TiffImagePlugin

__all__ = ["Texture", "WRAP_MODES", "MAX_TEXTURE_PIXELS"]

WRAP_MODES = ("repeat", "clamp")
# 8192 × 8192: the float32 copy of an RGBA texture that size is 1 GiB. Checked on the
# header before any pixel is decoded; below pillow's own decompression-bomb warning
# (89.5 M pixels), so an image this allows never trips pillow's checks.
MAX_TEXTURE_SIDE = 8192
MAX_TEXTURE_PIXELS = MAX_TEXTURE_SIDE * MAX_TEXTURE_SIDE

_FORMATS = ("PNG", "JPEG", "TIFF")
# pillow modes that keep TIFF samples wider than 8 bits: unsigned 16-bit grey, 32-bit float
_WIDE_TIFF_MODES = ("I;16", "I;16B", "I;16L", "I;16N", "F")
_SUPPORTED = (
    "supported are PNG, JPEG and TIFF with 8-bit grey, grey + alpha, RGB, RGBA or palette"
    " pixels, 16-bit greyscale (PNG, TIFF) and 32-bit float greyscale (TIFF)"
)
_CONVERT = (
    "save it as 8-bit (grey, RGB, RGBA), 16-bit greyscale PNG/TIFF, or 32-bit float"
    " single-channel TIFF (one file per channel)"
)


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
        arr = as_array(data, f"texture {name!r}: data")
        given = arr.shape
        if arr.ndim == 2:
            arr = arr[:, :, None]
        if arr.ndim != 3 or arr.shape[0] < 1 or arr.shape[1] < 1 or arr.shape[2] < 1:
            raise InputError(
                f"texture '{name}': expected an (H, W) or (H, W, C) array with H, W, C >= 1,"
                f" got shape {given}"
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
        """Read a PNG, JPEG or TIFF through pillow at its full bit depth.

        8-bit images (grey, grey + alpha, RGB, RGBA, palette) and 16-bit greyscale
        (PNG, TIFF) scale to [0, 1]; 32-bit float greyscale TIFF keeps its values (HDR,
        negative). Layouts pillow would narrow or misread (16-bit colour, signed or
        32-bit integers, multi-channel float) raise FormatError instead of loading, and
        so does an image of more than :data:`MAX_TEXTURE_PIXELS` pixels (read from its
        header, before decoding), a truncated one, or a FIFO, device or folder.
        """
        path = file_path(path, "Texture.load path")
        from PIL import Image

        p = Path(path)
        if not is_url(path) and not os.path.lexists(p):
            raise FileAccessError(
                f"texture file '{p}' does not exist or is not a file; check the path"
            )
        p = input_file(path, "PNG, JPEG or TIFF image file")
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", Image.DecompressionBombWarning)
                with Image.open(p, formats=_FORMATS) as img:
                    _check_size(img.size, p)
                    _check_layout(img, p)
                    img.load()
                    arr = _image_array(img, p)
        except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
            raise FormatError(f"texture file '{p}': {str(exc).rstrip('.')}; {_TOO_LARGE}") from exc
        except FollicleError:
            raise
        except Exception as exc:  # pillow raises many kinds on garbled or truncated files
            raise FormatError(
                f"texture file '{p}' cannot be read as an image (got: {exc}); {_SUPPORTED}"
            ) from exc
        if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
            raise FormatError(f"texture file '{p}' has NaN or inf pixels; replace them by numbers")
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
        uv = checked_uv(uv, f"texture '{self.name}'")
        out = _sample_kernel(self.data, self.wrap == "repeat", uv)
        return out[:, 0] if self.channels == 1 else out


def checked_uv(uv: object, what: str) -> np.ndarray:
    """``uv`` as a finite float64 (n, 2) array, or an InputError naming ``what``."""
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise InputError(f"{what}: uv must have shape (n, 2), got {uv.shape}")
    if not np.all(np.isfinite(uv)):
        raise InputError(f"{what}: uv contains NaN or inf")
    return uv


@kernel(inline="always")
def _wrap(i: int, n: int, repeat: bool) -> int:
    if repeat:
        return i % n  # Python semantics in numba: never negative
    return min(max(i, 0), n - 1)


@kernel(nogil=True)
def bilinear(data: np.ndarray, repeat: bool, u: float, v: float, c: int) -> float:
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


@kernel(nogil=True)
def _sample_kernel(data: np.ndarray, repeat: bool, uv: np.ndarray) -> np.ndarray:
    out = np.empty((uv.shape[0], data.shape[2]), dtype=np.float64)
    for n in range(uv.shape[0]):
        for c in range(data.shape[2]):
            out[n, c] = bilinear(data, repeat, uv[n, 0], uv[n, 1], c)
    return out


_TOO_LARGE = (
    f"textures may have at most {MAX_TEXTURE_PIXELS:,} pixels ({MAX_TEXTURE_SIDE} ×"
    f" {MAX_TEXTURE_SIDE}); downscale it"
)


def _check_size(size: tuple[int, int], path: Path) -> None:
    """FormatError unless a ``(width, height)`` from an image header fits the limit."""
    width, height = size
    if width * height > MAX_TEXTURE_PIXELS:
        raise FormatError(f"texture file '{path}' is {width} × {height} pixels; {_TOO_LARGE}")


def _check_layout(img: Image.Image, path: Path) -> None:
    """Refuse PNG/TIFF sample layouts that pillow opens but narrows to 8 bits or misreads."""
    if img.format == "PNG":
        with open(path, "rb") as f:
            header = f.read(26)  # signature, then IHDR: ..., bit depth, colour type
        depth, colour = header[24], header[25]
        if depth == 16 and colour != 0:
            kind = {2: "RGB", 4: "grey + alpha", 6: "RGBA"}.get(colour, f"colour type {colour}")
            raise FormatError(
                f"texture file '{path}': 16-bit {kind} PNG is read by pillow as 8 bits (got"
                f" bit depth 16, colour type {colour}); {_CONVERT}"
            )
    elif img.format == "TIFF":
        tags = cast("TiffImagePlugin.TiffImageFile", img).tag_v2  # what opens as "TIFF"
        bits = tuple(tags.get(258, (1,)))
        sample_format = tuple(tags.get(339, (1,)))
        if 2 in sample_format:
            problem = "signed integer samples"
        elif max(bits) > 8 and img.mode not in _WIDE_TIFF_MODES:
            problem = f"{max(bits)}-bit samples in {len(bits)} channel(s)"
        elif max(bits) > 8 and tags.get(262) == 0:
            problem = f"{max(bits)}-bit samples with photometric MinIsWhite"
        else:
            return
        raise FormatError(
            f"texture file '{path}': pillow cannot read TIFF {problem} faithfully (got"
            f" bits {bits}, sample format {sample_format}, pillow mode {img.mode});"
            f" {_CONVERT}"
        )


def _image_array(img: Image.Image, path: Path) -> np.ndarray:
    """Pixels of a checked pillow image as uint8/uint16/float32, keeping the bit depth."""
    mode = img.mode
    if mode in ("I;16", "I;16B", "I;16L", "I;16N"):
        return np.asarray(img, dtype=np.uint16)
    if mode == "I":  # 16-bit greyscale PNG in some pillow versions (TIFF "I" is refused)
        arr = np.asarray(img)
        if arr.size and (arr.min() < 0 or arr.max() > 65535):
            raise FormatError(
                f"texture file '{path}': integer pixels outside 0..65535 (got"
                f" {arr.min()}..{arr.max()}); {_CONVERT}"
            )
        return arr.astype(np.uint16)
    if mode == "F":
        return np.asarray(img, dtype=np.float32)
    if mode in ("1", "L", "LA", "RGB", "RGBA"):
        return np.asarray(img.convert("L" if mode == "1" else mode), dtype=np.uint8)
    alpha = "A" in img.getbands() or "transparency" in img.info
    converted = img.convert("RGBA" if alpha else "RGB")
    return np.asarray(converted, dtype=np.uint8)
