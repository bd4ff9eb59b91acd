"""The workload's tasks (:mod:`follicle.prebuild.workload`) run side by side, one process
each, so that compiling them takes as many cores as there are: numba compiles one
kernel at a time in a process, holding its compiler lock.

A task starts once the tasks it comes ``after`` have finished; each process writes what
it compiles into the cache, where the later tasks load it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Mapping
from pathlib import Path

from .workload import TASKS

__all__ = ["run_workload", "WorkloadError"]


class WorkloadError(RuntimeError):
    """A task of the workload failed: its name and the end of what it printed."""


def _start(name: str, logs: Path, env: Mapping[str, str]) -> tuple[subprocess.Popen, Path]:
    log = logs / f"{name}.log"
    with open(log, "wb") as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "follicle.prebuild", "task", name, str(logs / name)],
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=subprocess.STDOUT,
            env=dict(env),
        )
    return proc, log


def run_workload(
    env: Mapping[str, str],
    jobs: int | None = None,
    done: Callable[[str, int, int], None] | None = None,
) -> float:
    """Run every task of the workload in processes with environment ``env``, at most
    ``jobs`` at once (default: the CPUs there are). ``done(name, finished, total)`` is
    called as each task ends. Returns the seconds it took; WorkloadError when a task
    fails (the others are stopped)."""
    jobs = max(1, jobs or os.cpu_count() or 1)
    waiting = list(TASKS)
    finished: set[str] = set()
    running: dict[str, tuple[subprocess.Popen, Path]] = {}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="follicle-warm-") as tmp:
        logs = Path(tmp)
        try:
            while waiting or running:
                ready = [t for t in waiting if finished.issuperset(t.after)]
                while ready and len(running) < jobs:
                    task = ready.pop(0)
                    waiting.remove(task)
                    running[task.name] = _start(task.name, logs, env)
                if not running:  # pragma: no cover - a task after one that never runs
                    raise WorkloadError(f"tasks {[t.name for t in waiting]} wait on nothing")
                time.sleep(0.05)
                for name, (proc, log) in list(running.items()):
                    if proc.poll() is None:
                        continue
                    del running[name]
                    if proc.returncode != 0:
                        tail = log.read_text(errors="replace")[-3000:]
                        raise WorkloadError(
                            f"workload task {name!r} failed (exit {proc.returncode}):\n{tail}"
                        )
                    finished.add(name)
                    if done is not None:
                        done(name, len(finished), len(TASKS))
        finally:
            for proc, _ in running.values():
                proc.kill()
                proc.wait()
    return time.perf_counter() - start
