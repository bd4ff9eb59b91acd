"""Colour encoding and PNG output.

The renderer lights and blends in linear RGB and encodes to 8-bit sRGB once, when the
resolved image is read back (:func:`encode_srgb8`); every colour a user passes
(hair, skin, lights, background) is linear RGB, like ``HairCurves.point_data["color"]``.
"""

from __future__ import annotations

import os

import numpy as np

from ..atomic import atomic_path
from ..errors import InputError
from ..kernels import kernel
from ..validate import file_path

__all__ = [
    "linear_to_srgb",
    "srgb_to_linear",
    "encode_srgb8",
    "half_bits",
    "srgb8_table",
    "save_png",
]


def linear_to_srgb(linear: object) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) on values clipped to [0, 1], float64."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_to_linear(srgb: object) -> np.ndarray:
    """Inverse of :func:`linear_to_srgb`, float64."""
    x = np.clip(np.asarray(srgb, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4))


def encode_srgb8(linear_rgba: object) -> np.ndarray:
    """Linear RGBA floats (..., 4) → uint8: sRGB-encoded colour, linear alpha (rounded).

    Half-float input (what the renderer reads back) goes through an exact lookup
    table indexed by the 16-bit patterns; other floats are converted directly.
    """
    arr = np.asarray(linear_rgba)
    if arr.shape[-1:] != (4,):
        raise InputError(f"encode_srgb8: expected (..., 4) RGBA, got shape {arr.shape}")
    if arr.dtype == np.float16:
        bits = np.ascontiguousarray(arr).view(np.uint16)
        return _encode_half(bits)
    arr = arr.astype(np.float64)
    out = np.empty(arr.shape, dtype=np.uint8)
    out[..., :3] = np.round(linear_to_srgb(arr[..., :3]) * 255.0).astype(np.uint8)
    out[..., 3] = np.round(np.clip(arr[..., 3], 0.0, 1.0) * 255.0).astype(np.uint8)
    return out


_LUTS: tuple[np.ndarray, np.ndarray] | None = None


def _half_luts() -> tuple[np.ndarray, np.ndarray]:
    """(colour, alpha) uint8 tables over all 65536 float16 bit patterns."""
    global _LUTS
    if _LUTS is None:
        values = np.arange(65536, dtype=np.uint32).astype(np.uint16).view(np.float16)
        values = np.nan_to_num(values.astype(np.float64), nan=0.0, posinf=1.0, neginf=0.0)
        colour = np.round(linear_to_srgb(values) * 255.0).astype(np.uint8)
        alpha = np.round(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)
        _LUTS = (colour, alpha)
    return _LUTS


def srgb8_table() -> np.ndarray:
    """sRGB 8-bit codes of every float16 bit pattern (65536,) uint8: with
    :func:`half_bits`, a kernel's way to encode as :func:`encode_srgb8` does."""
    return _half_luts()[0]


@kernel(inline="always")
def half_bits(bits):
    """The float16 bit pattern nearest (ties to even, as numpy's and the GPU's
    conversion) to the float32 whose bit pattern is ``bits`` (an integer)."""
    sign = (bits >> 16) & 0x8000
    exponent = (bits >> 23) & 0xFF
    mantissa = bits & 0x7FFFFF
    if exponent == 0xFF:  # inf, NaN
        return sign | 0x7C00 | (0x200 if mantissa else 0)
    e = exponent - 112  # rebiased: 127 - 15
    if e >= 31:
        return sign | 0x7C00
    if e <= 0:  # a float16 subnormal, or zero
        if e < -10:
            return sign
        mantissa |= 0x800000
        shift = 14 - e
        h = mantissa >> shift
        rest = mantissa & ((1 << shift) - 1)
        halfway = 1 << (shift - 1)
        if rest > halfway or (rest == halfway and (h & 1)):
            h += 1
        return sign | h
    h = sign | (e << 10) | (mantissa >> 13)
    rest = mantissa & 0x1FFF
    if rest > 0x1000 or (rest == 0x1000 and (h & 1)):
        h += 1  # a carry into the exponent is right, up to inf
    return h


def _encode_half(bits: np.ndarray) -> np.ndarray:
    colour, alpha = _half_luts()
    out = np.empty(bits.shape, dtype=np.uint8)
    out[..., :3] = colour[bits[..., :3]]
    out[..., 3] = alpha[bits[..., 3]]
    return out


def save_png(image: object, path: str | os.PathLike[str]) -> None:
    """Write an (H, W, 4) or (H, W, 3) uint8 sRGB image as PNG, atomically.

    Float images are taken as linear RGB(A) in [0, 1] and encoded to sRGB first.
    """
    path = file_path(path, "save_png path")
    from PIL import Image

    arr = np.asarray(image)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4) or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise InputError(f"save_png: expected an (H, W, 3|4) image, got shape {arr.shape}")
    if np.issubdtype(arr.dtype, np.floating):
        if not np.all(np.isfinite(arr)):
            raise InputError("save_png: the image contains NaN or inf")
        if arr.shape[2] == 3:
            arr = np.concatenate([arr, np.ones(arr.shape[:2] + (1,), arr.dtype)], axis=2)
        arr = encode_srgb8(arr)
    elif arr.dtype != np.uint8:
        raise InputError(f"save_png: expected uint8 or float pixels, got {arr.dtype}")
    mode = "RGBA" if arr.shape[2] == 4 else "RGB"
    with atomic_path(path) as tmp:
        Image.fromarray(np.ascontiguousarray(arr), mode).save(tmp, format="PNG")
