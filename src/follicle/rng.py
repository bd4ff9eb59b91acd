"""Deterministic random numbers: Halton sequences and counter-based streams.

Every random choice in follicle is a pure function of ``(seed, id, purpose, k)``:
the k-th number of the stream keyed by a user seed, an object id (hair, vertex,
guide) and a purpose (``purpose_id("kink")``). No generator state is carried, so
kernels can draw numbers in any order or in parallel chunks and get the same
values on every machine.
"""

from __future__ import annotations

import zlib

import numpy as np

from .errors import InputError
from .kernels import kernel
from .validate import whole

__all__ = [
    "halton",
    "halton_point",
    "mix64",
    "stream_key",
    "uniform",
    "uniforms",
    "purpose_id",
]

# splitmix64 constants (Steele, Lea & Flood 2014)
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
# distinct odd constants so seed, purpose and id enter the key differently
_K_PURPOSE = np.uint64(0xD1B54A32D192ED03)
_K_ID = np.uint64(0x8CB92BA72F3D8DD7)
_INV53 = 1.0 / 9007199254740992.0  # 2**-53


# --------------------------------------------------------------------------- Halton
def halton(index: object, base: int) -> np.ndarray:
    """Radical inverse of non-negative integer indices in ``base`` (van der Corput).

    The digits of the index are mirrored about the radix point: base 2 gives
    0, 0.5, 0.25, 0.75, ... for indices 0, 1, 2, 3. Low-discrepancy samples
    for scattering hair roots evenly.
    """
    base = whole(base, "base", 2)
    idx = np.asarray(index)
    if idx.size and not np.issubdtype(idx.dtype, np.integer):
        raise InputError(f"index: expected integers, got dtype {idx.dtype}")
    idx = idx.astype(np.int64)
    if np.any(idx < 0):
        raise InputError("index: expected non-negative integers")
    return _radical_inverse(idx.ravel(), int(base)).reshape(idx.shape)


@kernel(nogil=True)
def _radical_inverse1(i: int, base: int) -> float:
    inv = 1.0 / base
    f = inv
    r = 0.0
    while i > 0:
        r += (i % base) * f
        i //= base
        f *= inv
    return r


@kernel(nogil=True)
def _radical_inverse(idx: np.ndarray, base: int) -> np.ndarray:
    out = np.empty(idx.shape[0], dtype=np.float64)
    for n in range(idx.shape[0]):
        out[n] = _radical_inverse1(idx[n], base)
    return out


@kernel(nogil=True)
def halton_point(k: int, shift0: float, shift1: float) -> tuple[float, float]:
    """Halton point k in bases (2, 3), toroidally shifted (Cranley–Patterson) by a seed.

    The shift keeps the low discrepancy while letting a seed pick another point set.
    """
    x = _radical_inverse1(np.int64(k), 2) + shift0
    y = _radical_inverse1(np.int64(k), 3) + shift1
    return x - np.floor(x), y - np.floor(y)


# ------------------------------------------------------------ counter-based streams
@kernel(nogil=True)
def mix64(x: int | np.uint64) -> np.uint64:
    """splitmix64 finaliser: a bijective avalanche of 64 bits (uint64 -> uint64)."""
    z = np.uint64(x)
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@kernel(nogil=True)
def stream_key(seed: int, id: int, purpose: int) -> np.uint64:
    """Key of the stream for (seed, object id, purpose id); integers, wrapped to 64 bits."""
    h = mix64(np.uint64(seed) + _GOLDEN)
    h = mix64(h ^ (np.uint64(purpose) * _K_PURPOSE + _GOLDEN))
    return mix64(h ^ (np.uint64(id) * _K_ID + _GOLDEN))


@kernel(nogil=True)
def uniform(key: np.uint64, k: int) -> float:
    """The k-th number in [0, 1) of the stream ``key`` (splitmix64 at counter k, 53 bits)."""
    state = np.uint64(key) + (np.uint64(k) + np.uint64(1)) * _GOLDEN
    return np.float64(mix64(state) >> _S11) * _INV53


@kernel(nogil=True)
def _uniforms_kernel(
    seed: int, ids: np.ndarray, purpose: int, start: int, count: int
) -> np.ndarray:
    out = np.empty((ids.shape[0], count), dtype=np.float64)
    for n in range(ids.shape[0]):
        key = stream_key(seed, ids[n], purpose)
        for j in range(count):
            out[n, j] = uniform(key, start + j)
    return out


def purpose_id(name: str) -> int:
    """Stable 32-bit id of a purpose name (CRC-32 of its UTF-8), equal in every process."""
    if not isinstance(name, str):
        raise InputError(f"name: expected a str, got {type(name).__name__}")
    return zlib.crc32(name.encode("utf-8"))


def _as_uint64(value: object, name: str) -> np.uint64:
    return np.uint64(whole(value, name) & 0xFFFFFFFFFFFFFFFF)


def uniforms(seed: int, ids: object, purpose: int | str, count: int, start: int = 0) -> np.ndarray:
    """(len(ids), count) float64 in [0, 1): numbers start..start+count-1 of each id's stream.

    ``purpose`` is an int or a name (hashed with :func:`purpose_id`). Generating in
    chunks (of ids or of counters via ``start``) gives the same numbers as one call.
    """
    if isinstance(purpose, str):
        purpose = purpose_id(purpose)
    p = _as_uint64(purpose, "purpose")
    s = _as_uint64(seed, "seed")
    count, start = whole(count, "count", 0), whole(start, "start", 0)
    arr = np.asarray(ids)
    if arr.ndim != 1 or (arr.size and not np.issubdtype(arr.dtype, np.integer)):
        raise InputError(f"ids: expected a 1-D array of integers, got shape {arr.shape}")
    arr = arr.astype(np.int64).view(np.uint64)
    return _uniforms_kernel(s, arr, p, np.uint64(start), int(count))
