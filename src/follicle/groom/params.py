"""Per-hair parameters as the groom kernels take them: validated, C-contiguous float64.

Every property reaches a kernel as one value per hair (Šik's global × texture(uv),
evaluated at the roots) or one value for all. Both arrive C-contiguous with n rows or
one shared row, so nothing is copied per hair and each kernel has one signature to
compile; kernels read hair i's value at ``row(a, i)``.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..kernels import kernel

__all__ = ["per_hair", "curve_parameter", "row"]


@kernel(inline="always")
def row(a, i):
    """Row of hair ``i`` in a per-hair array with n rows or one shared row."""
    return np.int64(i) if a.shape[0] != 1 else np.int64(0)  # one int type under prange


def per_hair(
    value: object,
    n: int,
    name: str,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    vector: bool = False,
) -> np.ndarray:
    """``value`` for ``n`` hairs as float64 (n,), or (n, 3) with ``vector``; finite, in range.

    A single number (or 3-vector) becomes one shared row, (1,) or (1, 3); a shared row
    passes as it is. ``lo``/``hi`` bound the
    values (``lo_open``: strictly above ``lo``); errors name ``name``.
    """
    if isinstance(value, (bool, np.bool_)):
        raise InputError(f"{name}: expected numbers, got {value!r}")
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected numbers, got {value!r}") from exc
    one = (3,) if vector else ()
    if arr.shape == one:
        arr = arr.reshape((1, *one))
    elif arr.shape != (n, *one) and arr.shape != (1, *one):
        want = f"shape (3,) or ({n}, 3)" if vector else f"a number or shape ({n},)"
        raise InputError(f"{name}: expected {want}, got shape {arr.shape}")
    _check_range(arr, name, lo, hi, lo_open)
    return np.ascontiguousarray(arr)


def curve_parameter(t: object, n: int, vertices: int) -> np.ndarray:
    """Curve parameters t of each vertex as (1, N) (shared by all hairs) or (n, N).

    None gives the original parametrisation i / (N − 1) (Šik 2012 §2.2.8: a cut hair keeps it).
    """
    if t is None:
        return np.linspace(0.0, 1.0, vertices)[None]
    try:
        arr = np.asarray(t, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"t: expected numbers, got {t!r}") from exc
    if arr.shape == (vertices,):
        arr = arr[None]
    elif arr.shape != (n, vertices) and arr.shape != (1, vertices):
        raise InputError(
            f"t: expected shape ({vertices},) or ({n}, {vertices}), got shape {arr.shape}"
        )
    if not np.isfinite(arr).all() or ((arr < 0.0) | (arr > 1.0)).any():
        raise InputError("t: curve parameters must lie in [0, 1] (finite)")
    return np.ascontiguousarray(arr)


def _check_range(
    arr: np.ndarray, name: str, lo: float | None, hi: float | None, lo_open: bool
) -> None:
    if not np.isfinite(arr).all():
        raise InputError(f"{name}: values must be finite (no NaN or inf)")
    if lo is not None:
        low = arr <= lo if lo_open else arr < lo
        if low.any():
            raise InputError(
                f"{name}: values must be {'>' if lo_open else '>='} {lo:g},"
                f" got {float(arr[low].flat[0])!r}"
            )
    if hi is not None and (arr > hi).any():
        bad = float(arr[arr > hi].flat[0])
        raise InputError(f"{name}: values must be <= {hi:g}, got {bad!r}")
