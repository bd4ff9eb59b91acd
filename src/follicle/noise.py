"""Perlin noise and the vector noise3D used by Frizz and Kink (000 §2.2.5).

``perlin`` is Ken Perlin's improved noise (2002): quintic fade, gradients on the 12
cube-edge directions picked by a hashed lattice corner. The permutation table is
fixed (generated once from a constant seed with integer arithmetic), so the same
input gives the same value on every run and machine. ``perlin`` and ``noise3`` are
numba functions and can be called from other kernels.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .errors import InputError

__all__ = ["perlin", "noise3", "perlin_array", "noise3_array"]


def _make_permutation(seed: int = 0x5EED_F011) -> np.ndarray:
    """Fisher-Yates shuffle of 0..255 driven by a splitmix64 sequence (pure Python ints)."""
    mask = (1 << 64) - 1
    state = seed
    perm = list(range(256))
    for i in range(255, 0, -1):
        state = (state + 0x9E3779B97F4A7C15) & mask
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & mask
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
        z ^= z >> 31
        j = z % (i + 1)
        perm[i], perm[j] = perm[j], perm[i]
    return np.array(perm + perm, dtype=np.int64)  # doubled: no wrap-around indexing


_PERM = _make_permutation()

# 000 §2.2.5: noise3D(x) = [noise(a_i + m_i x)]; fixed distinct, non-lattice offsets a_i
# decorrelate the three components; equal scales m_i keep the user's frequency meaning
# the same for every component.
_A = np.array(
    [[12.31, 41.73, 7.19], [-23.57, 5.91, 31.13], [3.77, -17.29, -29.41]], dtype=np.float64
)
_M = np.array([1.0, 1.0, 1.0], dtype=np.float64)


@njit(cache=True, inline="always")
def _fade(t):
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@njit(cache=True, inline="always")
def _lerp(t, a, b):
    return a + t * (b - a)


# improved noise: the 12 edge directions of a cube (4 repeated to fill 16 hash values),
# as coefficient tables so the gradient needs no data-dependent branch
_GX = np.array([1, -1, 1, -1, 1, -1, 1, -1, 0, 0, 0, 0, 1, 0, -1, 0], dtype=np.float64)
_GY = np.array([1, 1, -1, -1, 0, 0, 0, 0, 1, -1, 1, -1, 1, -1, 1, -1], dtype=np.float64)
_GZ = np.array([0, 0, 0, 0, 1, 1, -1, -1, 1, 1, -1, -1, 0, 1, 0, -1], dtype=np.float64)


@njit(cache=True, inline="always")
def _grad(h, x, y, z):
    h = h & 15
    return _GX[h] * x + _GY[h] * y + _GZ[h] * z


@njit(cache=True, inline="always")
def perlin(x: float, y: float, z: float) -> float:
    """Improved Perlin noise at (x, y, z): smooth, about [-1, 1], zero on the integer lattice."""
    p = _PERM
    fx = np.floor(x)
    fy = np.floor(y)
    fz = np.floor(z)
    xi = int(fx) & 255
    yi = int(fy) & 255
    zi = int(fz) & 255
    x -= fx
    y -= fy
    z -= fz
    u = _fade(x)
    v = _fade(y)
    w = _fade(z)
    a = p[xi] + yi
    aa = p[a] + zi
    ab = p[a + 1] + zi
    b = p[xi + 1] + yi
    ba = p[b] + zi
    bb = p[b + 1] + zi
    return _lerp(
        w,
        _lerp(
            v,
            _lerp(u, _grad(p[aa], x, y, z), _grad(p[ba], x - 1.0, y, z)),
            _lerp(u, _grad(p[ab], x, y - 1.0, z), _grad(p[bb], x - 1.0, y - 1.0, z)),
        ),
        _lerp(
            v,
            _lerp(u, _grad(p[aa + 1], x, y, z - 1.0), _grad(p[ba + 1], x - 1.0, y, z - 1.0)),
            _lerp(
                u,
                _grad(p[ab + 1], x, y - 1.0, z - 1.0),
                _grad(p[bb + 1], x - 1.0, y - 1.0, z - 1.0),
            ),
        ),
    )


@njit(cache=True)
def _clamp1(v):
    return min(1.0, max(-1.0, v))


@njit(cache=True)
def noise3(x: float, y: float, z: float) -> tuple[float, float, float]:
    """000 §2.2.5 noise3D: three decorrelated Perlin values, each clamped to [-1, 1]."""
    a = _A
    m = _M
    n0 = perlin(a[0, 0] + m[0] * x, a[0, 1] + m[0] * y, a[0, 2] + m[0] * z)
    n1 = perlin(a[1, 0] + m[1] * x, a[1, 1] + m[1] * y, a[1, 2] + m[1] * z)
    n2 = perlin(a[2, 0] + m[2] * x, a[2, 1] + m[2] * y, a[2, 2] + m[2] * z)
    return _clamp1(n0), _clamp1(n1), _clamp1(n2)


@njit(cache=True)
def _perlin_kernel(p):
    out = np.empty(p.shape[0], dtype=np.float64)
    for i in range(p.shape[0]):
        out[i] = perlin(p[i, 0], p[i, 1], p[i, 2])
    return out


@njit(cache=True)
def _noise3_kernel(p):
    out = np.empty((p.shape[0], 3), dtype=np.float64)
    for i in range(p.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = noise3(p[i, 0], p[i, 1], p[i, 2])
    return out


def _as_positions(p: object) -> np.ndarray:
    arr = np.asarray(p, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InputError(f"p: expected an array of shape (n, 3), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("p: positions must be finite (no NaN or inf)")
    return np.ascontiguousarray(arr)


def perlin_array(p: object) -> np.ndarray:
    """``perlin`` at each row of an (n, 3) array; returns (n,) float64."""
    return _perlin_kernel(_as_positions(p))


def noise3_array(p: object) -> np.ndarray:
    """``noise3`` at each row of an (n, 3) array; returns (n, 3) float64 in [-1, 1]."""
    return _noise3_kernel(_as_positions(p))
