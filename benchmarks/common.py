"""Timing helpers shared by the benchmark scripts: best-of-N and a same-run yardstick."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np


def best_of(fn: Callable[[], object], repeat: int = 3) -> float:
    """The fastest of ``repeat`` runs of ``fn``, in seconds (least disturbed by neighbours)."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def yardstick() -> float:
    """A fixed numpy workload (sorting 4 M floats): the machine's speed right now."""
    data = np.random.default_rng(0).random(4_000_000)
    return best_of(lambda: np.sort(data), repeat=5)
