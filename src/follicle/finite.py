"""A parallel finiteness scan: big arrays checked without a temporary boolean copy."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

__all__ = ["all_finite"]


@njit(cache=True, parallel=True)
def _count_bad(flat):
    bad = 0
    for i in prange(flat.shape[0]):
        if not math.isfinite(flat[i]):
            bad += 1
    return bad


def all_finite(arr: np.ndarray) -> bool:
    """True when no element of the float array ``arr`` is NaN or inf."""
    flat = arr.reshape(-1) if arr.flags.c_contiguous else np.ascontiguousarray(arr).reshape(-1)
    return _count_bad(flat) == 0
