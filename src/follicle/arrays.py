"""Checks and conversions of array inputs shared by every stage.

Read-only copies, finiteness scans without a boolean temporary, (N, 3) point sets, and
rigid 4×4 transforms: each error names the argument and what it must be. Also
:func:`budget_runs`, the cut of a sequence into runs under a budget.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import DTypeLike

from .errors import InputError
from .kernels import kernel, prange

__all__ = [
    "as_array",
    "frozen",
    "readonly",
    "all_finite",
    "as_points",
    "point_bounds",
    "rigid",
    "rigid_fit",
    "empty_touched",
    "budget_runs",
    "FMA",
]

RIGID_TOLERANCE = 1e-6  # a rigid transform's rotation satisfies |RᵀR − I| ≤ this
PAGE = 4096  # bytes per memory page (the smallest on the platforms we run on)
# numba fastmath flags of the hot simulation kernels: a·b + c may become one fused
# multiply-add (rounded once; 15 % off the volume update). No other reordering, so a
# kernel still gives the same bytes on the same machine with any thread count.
FMA = {"contract"}


def as_array(
    value: object, name: str, dtype: DTypeLike | None = None, numbers: bool = True
) -> np.ndarray:
    """``value`` as a NumPy array (of ``dtype`` when given; no copy when it already is
    one), or InputError naming the argument ``name`` when NumPy cannot make one of it
    (lists of different lengths) or, with ``numbers``, when it does not hold real numbers
    (text, a dict, None, complex numbers, other objects): what a public function's
    array argument goes through, rather than NumPy's own ValueError or TypeError."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:
        why = "lists of different lengths" if "inhomogeneous" in str(exc) else str(exc)[:80]
        raise InputError(f"{name}: expected an array of numbers ({why})") from None
    if numbers and arr.dtype.kind not in "biuf":
        text = repr(value)
        shown = text if len(text) <= 60 else text[:57] + "..."
        raise InputError(f"{name}: expected an array of numbers, got {shown}")
    return arr if dtype is None else arr.astype(dtype, copy=False)


def frozen(arr: np.ndarray) -> np.ndarray:
    """``arr`` C-contiguous and read-only (a copy only when it was not contiguous)."""
    arr = np.ascontiguousarray(arr)
    arr.setflags(write=False)
    return arr


@kernel(parallel=True, nogil=True)
def _count_bad(flat: np.ndarray) -> int:
    bad = 0
    for i in prange(flat.shape[0]):
        if not math.isfinite(flat[i]):
            bad += 1
    return bad


def readonly(arr: object, dtype: DTypeLike | None = None) -> np.ndarray:
    """``arr`` as a C-contiguous read-only view (a copy only when it is not contiguous or
    not of ``dtype``), the caller's array unchanged: what a kernel only reads, passed in
    one layout and one flag whatever the caller holds, so that numba compiles the kernel
    once (it types read-only and writable, contiguous and strided arrays apart)."""
    out = np.ascontiguousarray(arr, dtype=dtype).view()
    out.flags.writeable = False
    return out


SCAN_IN_PARALLEL = 1 << 20  # elements from which all_finite scans on every core


def all_finite(arr: np.ndarray) -> bool:
    """True when no element of the float array ``arr`` is NaN or inf: numpy for an array
    under :data:`SCAN_IN_PARALLEL` elements (no numba to load for a small file), a
    parallel scan for a larger one (no temporary as large as the array)."""
    if arr.size < SCAN_IN_PARALLEL:
        return bool(np.isfinite(arr).all())
    return _count_bad(readonly(arr).reshape(-1)) == 0


@kernel(parallel=True, nogil=True)
def _touch(flat: np.ndarray, step: int) -> None:
    for i in prange((flat.shape[0] + step - 1) // step):
        flat[i * step] = 0


def empty_touched(shape: tuple[int, ...], dtype: DTypeLike) -> np.ndarray:
    """``np.empty(shape, dtype)`` with every memory page written once, on all threads.

    Faulting hundreds of MiB in at once costs a fraction of what the same faults cost
    scattered through the kernels that later fill the array while their temporaries
    come and go (0.05 s against 0.4 s for the 725 MiB of a million 16-vertex hairs).
    """
    out = np.empty(shape, dtype)
    if out.nbytes:
        _touch(out.reshape(-1).view(np.uint8), PAGE)
    return out


@kernel(nogil=True)
def _point_bounds(pts: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
    for i in range(pts.shape[0]):
        for k in range(3):
            v = pts[i, k]
            lo[k] = min(lo[k], v)
            hi[k] = max(hi[k], v)


def point_bounds(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis min and max ((3,), (3,)) float64 of (N ≥ 1, 3) points in one pass: numpy's
    ``min(axis=0)`` on an (N, 3) array took 40 ms per 1.6 M points, this takes 3. NaN is
    skipped (callers check finiteness)."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    _point_bounds(np.ascontiguousarray(pts), lo, hi)
    return lo, hi


def as_points(name: str, array: object, allow_empty: bool = True) -> np.ndarray:
    """``array`` as a C-contiguous float64 (N, 3) array of finite values, or InputError."""
    try:
        arr = np.ascontiguousarray(array, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected an (N, 3) array of numbers ({exc})") from None
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InputError(f"{name}: expected shape (N, 3), got {arr.shape}")
    if arr.shape[0] == 0 and not allow_empty:
        raise InputError(f"{name}: needs at least one point, got shape {arr.shape}")
    # A finite sum proves every value finite (cheap); an infinite or NaN one may be an overflow.
    if not np.isfinite(arr.sum()) and not np.isfinite(arr).all():
        bad = int(np.flatnonzero(~np.isfinite(arr).all(axis=1))[0])
        raise InputError(f"{name}: row {bad} is not finite: {arr[bad].tolist()}")
    return arr


def rigid(
    transform: object, name: str = "transform", hint: str = ""
) -> tuple[np.ndarray, np.ndarray]:
    """(the matrix, its inverse), both read-only float64 (4, 4), for a finite rigid motion.

    Scaling and shear are refused; ``hint`` is added to that message (what to do instead).
    """
    m = np.asarray(transform, dtype=np.float64)
    if m.shape != (4, 4) or not np.isfinite(m).all():
        raise InputError(f"{name}: expected a finite 4×4 matrix, got shape {m.shape}")
    if np.abs(m[3] - (0.0, 0.0, 0.0, 1.0)).max() > RIGID_TOLERANCE:
        raise InputError(f"{name}: the last row must be (0, 0, 0, 1), got {m[3].tolist()}")
    rot = m[:3, :3]
    err = float(np.abs(rot.T @ rot - np.eye(3)).max())
    if err > RIGID_TOLERANCE:
        raise InputError(
            f"{name}: not rigid (|RᵀR − I| = {err:.3g} > {RIGID_TOLERANCE:g}); scaling and"
            f" shear are not supported{hint}"
        )
    inverse = np.eye(4)
    inverse[:3, :3] = rot.T
    inverse[:3, 3] = -rot.T @ m[:3, 3]
    world = m.copy()
    world[3] = (0.0, 0.0, 0.0, 1.0)
    return frozen(world), frozen(inverse)


def rigid_fit(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, float]:
    """The rigid 4×4 transform T (a proper rotation and a translation) that moves the
    points ``source`` (V, 3) closest to ``target`` in least squares (Kabsch: the SVD of
    their cross-covariance), and the largest distance left between T·source and target."""
    a0, b0 = source.mean(axis=0), target.mean(axis=0)
    u, _, vt = np.linalg.svd((source - a0).T @ (target - b0))
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    fit = np.eye(4)
    fit[:3, :3], fit[:3, 3] = r, b0 - r @ a0
    off = float(np.sqrt(np.max(np.sum((source @ r.T + fit[:3, 3] - target) ** 2, axis=1))))
    return fit, off


def budget_runs(costs: np.ndarray, budget: int) -> list[tuple[int, int]]:
    """Runs [a, b) of consecutive items whose ``costs`` sum to at most ``budget`` each,
    in order and covering every item; an item that alone costs more is a run of its
    own. What bounds a batch of work (a shape's segments, a query's candidates)
    without cutting an item."""
    ends = np.cumsum(costs, dtype=np.int64)
    runs, a, done = [], 0, 0
    while a < len(ends):
        b = max(int(np.searchsorted(ends, done + budget, side="right")), a + 1)
        runs.append((a, b))
        a, done = b, int(ends[b - 1])
    return runs
