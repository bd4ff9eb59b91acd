"""Timing helpers shared by the benchmark scripts: best-of-N, a same-run yardstick, and
`follicle` commands timed in a fresh process each with their outputs compared."""

from __future__ import annotations

import filecmp
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

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


def follicle(folder: Path, *args: str) -> float:
    """Seconds of one `follicle ARGS…` run in ``folder`` in a fresh process, as a user
    runs it (start-up, and a cluster's, included)."""
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "follicle.cli", *args],
        cwd=folder,
        check=True,
        stdout=subprocess.DEVNULL,
    )
    return time.perf_counter() - start


def same_output(a: Path, b: Path) -> bool:
    """Whether two outputs (files, or folders of them, compared all the way down) hold
    the same bytes."""
    if a.is_file():
        return b.is_file() and filecmp.cmp(a, b, shallow=False)
    names = sorted(p.name for p in a.iterdir())
    if not b.is_dir() or names != sorted(p.name for p in b.iterdir()):
        return False
    return all(same_output(a / n, b / n) for n in names)


def runs(times: list[float]) -> str:
    """Each run's seconds, for the report."""
    return ", ".join(f"{t:.2f}" for t in times)
