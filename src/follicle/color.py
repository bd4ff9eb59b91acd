"""RGB <-> HSV conversion and shortest-route hue interpolation (Šik 2012 §2.2.6).

Hair colour is given at the root and tip and interpolated in HSV, which keeps
saturation from dipping midway the way an RGB blend does. Hue is in degrees
[0, 360), saturation and value in [0, 1]. The scalar ``*1`` functions are numba
functions for kernels; the array functions broadcast over leading axes and run
the same scalar code in a kernel.
"""

from __future__ import annotations

import numpy as np

from .arrays import readonly
from .errors import InputError
from .kernels import kernel

__all__ = [
    "lab_from_linear",
    "rgb_to_hsv",
    "hsv_to_rgb",
    "rgb_to_hsv1",
    "hsv_to_rgb1",
    "hue_distance",
    "hue_distance1",
    "lerp_hsv",
    "lerp_hsv1",
]


@kernel(inline="always")
def _wrap_hue(h: float) -> float:
    # the hues met per vertex lie within a turn of [0, 360): there the result is exact
    # without the modulo (a library call that would be half of the colour's cost)
    if 0.0 <= h < 360.0:
        return h
    if 360.0 <= h < 720.0:
        return h - 360.0
    h = h % 360.0
    if h >= 360.0:  # a tiny negative h rounds up to exactly 360 after the modulo
        h -= 360.0
    return h


@kernel
def rgb_to_hsv1(r: float, g: float, b: float) -> tuple[float, float, float]:
    """One RGB colour to (hue degrees [0, 360), saturation, value); grey has hue 0, s 0."""
    mx = max(r, g, b)
    mn = min(r, g, b)
    d = mx - mn
    v = mx
    s = d / mx if mx > 0.0 else 0.0
    if d <= 0.0:
        return 0.0, s, v
    if mx == r:
        h = 60.0 * ((g - b) / d)
    elif mx == g:
        h = 60.0 * ((b - r) / d + 2.0)
    else:
        h = 60.0 * ((r - g) / d + 4.0)
    return _wrap_hue(h), s, v


@kernel(inline="always")
def hsv_to_rgb1(h: float, s: float, v: float) -> tuple[float, float, float]:
    """One HSV colour (hue in degrees, any value wrapped) to RGB."""
    hh = _wrap_hue(h) / 60.0
    i = int(np.floor(hh))
    f = hh - i
    p = v * (1.0 - s)
    q = v * (1.0 - s * f)
    t = v * (1.0 - s * (1.0 - f))
    if i == 0:
        return v, t, p
    if i == 1:
        return q, v, p
    if i == 2:
        return p, v, t
    if i == 3:
        return p, q, v
    if i == 4:
        return t, p, v
    return v, p, q


@kernel
def hue_distance1(h1: float, h2: float) -> float:
    """Šik 2012 §2.2.6: signed shortest step from hue h1 to h2 (cw positive, ccw negative)."""
    h1 = _wrap_hue(h1)
    h2 = _wrap_hue(h2)
    ccw = h1 - h2 if h1 >= h2 else 360.0 + h1 - h2
    cw = 360.0 + h2 - h1 if h1 >= h2 else h2 - h1
    return cw if cw <= ccw else -ccw


@kernel
def lerp_hsv1(
    h1: float, s1: float, v1: float, h2: float, s2: float, v2: float, t: float
) -> tuple[float, float, float]:
    """HSV blend at t: hue along the shortest route, wrapped to [0, 360); s, v linear."""
    h = _wrap_hue(h1 + t * hue_distance1(h1, h2))  # Šik 2012 §2.2.6, hue = hue1 + t * hue_dist
    return h, s1 + t * (s2 - s1), v1 + t * (v2 - v1)


# ------------------------------------------------------------------ array kernels
@kernel
def _rgb_to_hsv_kernel(c: np.ndarray) -> np.ndarray:
    out = np.empty_like(c)
    for i in range(c.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = rgb_to_hsv1(c[i, 0], c[i, 1], c[i, 2])
    return out


@kernel
def _hsv_to_rgb_kernel(c: np.ndarray) -> np.ndarray:
    out = np.empty_like(c)
    for i in range(c.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = hsv_to_rgb1(c[i, 0], c[i, 1], c[i, 2])
    return out


@kernel
def _hue_distance_kernel(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.empty_like(a)
    for i in range(a.shape[0]):
        out[i] = hue_distance1(a[i], b[i])
    return out


@kernel
def _lerp_hsv_kernel(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    out = np.empty_like(a)
    for i in range(a.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = lerp_hsv1(
            a[i, 0], a[i, 1], a[i, 2], b[i, 0], b[i, 1], b[i, 2], t[i]
        )
    return out


def _as_colors(c: object, name: str) -> np.ndarray:
    arr = np.asarray(c, dtype=np.float64)
    if arr.ndim < 1 or arr.shape[-1] != 3:
        raise InputError(f"{name}: expected an array of shape (..., 3), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: values must be finite (no NaN or inf)")
    return arr


def _as_finite(x: object, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: values must be finite (no NaN or inf)")
    return arr


def rgb_to_hsv(rgb: object) -> np.ndarray:
    """(..., 3) RGB to (..., 3) HSV float64: hue degrees [0, 360), s and v in [0, 1]."""
    arr = _as_colors(rgb, "rgb")
    flat = np.ascontiguousarray(arr.reshape(-1, 3))
    return _rgb_to_hsv_kernel(flat).reshape(arr.shape)


def hsv_to_rgb(hsv: object) -> np.ndarray:
    """(..., 3) HSV (hue degrees, wrapped) to (..., 3) RGB float64."""
    arr = _as_colors(hsv, "hsv")
    flat = np.ascontiguousarray(arr.reshape(-1, 3))
    return _hsv_to_rgb_kernel(flat).reshape(arr.shape)


def hue_distance(h1: object, h2: object) -> np.ndarray | float:
    """Šik 2012 §2.2.6 hue_dist: signed shortest hue step h1 -> h2 in degrees, in (-180, 180]."""
    a, b = np.broadcast_arrays(_as_finite(h1, "h1"), _as_finite(h2, "h2"))
    out = _hue_distance_kernel(np.ascontiguousarray(a).ravel(), np.ascontiguousarray(b).ravel())
    out = out.reshape(a.shape)
    return float(out) if out.ndim == 0 else out


def lerp_hsv(hsv1: object, hsv2: object, t: object) -> np.ndarray:
    """Interpolate HSV colours at t: shortest hue route, s and v linear; (..., 3) float64.

    t broadcasts against the colours' leading axes (t (n,) with colours (3,) gives
    (n, 3)); numpy style with a trailing length-1 axis (t[:, None]) means the same.
    """
    a = _as_colors(hsv1, "hsv1")
    b = _as_colors(hsv2, "hsv2")
    tt = _as_finite(t, "t")
    if tt.ndim == 0 or tt.shape[-1] != 1:
        tt = tt[..., None]
    try:
        shape = np.broadcast_shapes(a.shape, b.shape, tt.shape)
    except ValueError as exc:
        raise InputError(
            f"hsv1, hsv2, t: shapes {a.shape}, {b.shape} and {tt.shape[:-1]} do not broadcast"
        ) from exc
    a = np.ascontiguousarray(np.broadcast_to(a, shape)).reshape(-1, 3)
    b = np.ascontiguousarray(np.broadcast_to(b, shape)).reshape(-1, 3)
    tf = np.ascontiguousarray(np.broadcast_to(tt, shape[:-1] + (1,))).reshape(-1)
    return _lerp_hsv_kernel(readonly(a), readonly(b), readonly(tf)).reshape(shape)


# linear sRGB (Rec. 709 primaries) to CIE XYZ, D65 white (IEC 61966-2-1)
_XYZ_FROM_LINEAR = np.array(
    [
        [0.4124564, 0.3575761, 0.1804375],
        [0.2126729, 0.7151522, 0.0721750],
        [0.0193339, 0.1191920, 0.9503041],
    ]
)


def lab_from_linear(rgb: object) -> np.ndarray:
    """CIELAB (L*, a*, b*) of linear sRGB colours (..., 3), D65 white (CIE 15:2004):
    what colour differences (ΔE) are measured in."""
    t = np.asarray(rgb, np.float64) @ _XYZ_FROM_LINEAR.T / _XYZ_FROM_LINEAR.sum(axis=1)
    f = np.where(t > (6 / 29) ** 3, np.cbrt(t), t / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack(
        [116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])],
        axis=-1,
    )
