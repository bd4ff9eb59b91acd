"""Perlin noise and the vector noise3D used by Frizz and Kink (Šik 2012 §2.2.5).

``perlin`` is Ken Perlin's improved noise (2002): quintic fade, gradients on the 12
cube-edge directions picked by a hashed lattice corner. The permutation table is
fixed (generated once from a constant seed with integer arithmetic), so the same
input gives the same value on every run and machine. ``perlin`` and ``noise3`` are
numba functions and can be called from other kernels.
"""

from __future__ import annotations

import numpy as np

from .errors import InputError
from .kernels import kernel

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

# Šik 2012 §2.2.5: noise3D(x) = [noise(a_i + m_i x)], with m_i = 1 (the user's frequency
# means the same for every component) and a_i = _SHIFT + _CELLS[i]: one fractional shift
# shared by the three, so they share x's lattice cell position and fade weights (one
# floor, one fade for all three: a fifth of the cost), and distinct whole-cell offsets,
# so they hash different lattice corners and are decorrelated. The shift keeps the
# lattice (where Perlin noise is 0) off the origin: noise3D(0) is not the zero vector.
_SHIFT = np.array([0.31, 0.73, 0.19], dtype=np.float64)
_CELLS = np.array([[12, 41, 7], [-24, 5, 31], [3, -18, -30]], dtype=np.int64)


@kernel(inline="always")
def _fade(t: float) -> float:
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@kernel(inline="always")
def _lerp(t: float, a: float, b: float) -> float:
    return a + t * (b - a)


# improved noise: the 12 edge directions of a cube (4 repeated to fill 16 hash values),
# as coefficient tables so the gradient needs no data-dependent branch
_GX = np.array([1, -1, 1, -1, 1, -1, 1, -1, 0, 0, 0, 0, 1, 0, -1, 0], dtype=np.float64)
_GY = np.array([1, 1, -1, -1, 0, 0, 0, 0, 1, -1, 1, -1, 1, -1, 1, -1], dtype=np.float64)
_GZ = np.array([0, 0, 0, 0, 1, 1, -1, -1, 1, 1, -1, -1, 0, 1, 0, -1], dtype=np.float64)


@kernel(inline="always")
def _grad(h: int, x: float, y: float, z: float) -> float:
    h = h & 15
    return _GX[h] * x + _GY[h] * y + _GZ[h] * z


@kernel(inline="always")
def _corners(
    p: np.ndarray,
    xi: int,
    yi: int,
    zi: int,
    x: float,
    y: float,
    z: float,
    u: float,
    v: float,
    w: float,
) -> float:
    """Perlin's blend of the 8 corner gradients of lattice cell (xi, yi, zi) (each in
    0..255) at fractional position (x, y, z) with fade weights (u, v, w)."""
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


@kernel(inline="always")
def perlin(x: float, y: float, z: float) -> float:
    """Improved Perlin noise at (x, y, z): smooth, about [-1, 1], zero on the integer lattice."""
    fx = np.floor(x)
    fy = np.floor(y)
    fz = np.floor(z)
    x -= fx
    y -= fy
    z -= fz
    return _corners(
        _PERM, int(fx) & 255, int(fy) & 255, int(fz) & 255, x, y, z, _fade(x), _fade(y), _fade(z)
    )


@kernel(inline="always")
def _clamp1(v: float) -> float:
    return min(1.0, max(-1.0, v))


@kernel(inline="always")
def noise3(x: float, y: float, z: float) -> tuple[float, float, float]:
    """Šik 2012 §2.2.5 noise3D: three decorrelated Perlin values, each clamped to [-1, 1]."""
    x += _SHIFT[0]
    y += _SHIFT[1]
    z += _SHIFT[2]
    fx = np.floor(x)
    fy = np.floor(y)
    fz = np.floor(z)
    ix = int(fx)
    iy = int(fy)
    iz = int(fz)
    x -= fx
    y -= fy
    z -= fz
    u = _fade(x)
    v = _fade(y)
    w = _fade(z)
    c = _CELLS
    p = _PERM
    n0 = _corners(
        p, (ix + c[0, 0]) & 255, (iy + c[0, 1]) & 255, (iz + c[0, 2]) & 255, x, y, z, u, v, w
    )
    n1 = _corners(
        p, (ix + c[1, 0]) & 255, (iy + c[1, 1]) & 255, (iz + c[1, 2]) & 255, x, y, z, u, v, w
    )
    n2 = _corners(
        p, (ix + c[2, 0]) & 255, (iy + c[2, 1]) & 255, (iz + c[2, 2]) & 255, x, y, z, u, v, w
    )
    return _clamp1(n0), _clamp1(n1), _clamp1(n2)


@kernel(nogil=True)
def _perlin_kernel(p: np.ndarray) -> np.ndarray:
    out = np.empty(p.shape[0], dtype=np.float64)
    for i in range(p.shape[0]):
        out[i] = perlin(p[i, 0], p[i, 1], p[i, 2])
    return out


@kernel(nogil=True)
def _noise3_kernel(p: np.ndarray) -> np.ndarray:
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
