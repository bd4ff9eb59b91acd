"""Prebuilt kernels for a wheel: the workload compiled for named CPU levels into a folder
laid out as ``follicle/_kernels`` (:mod:`follicle.kernels.cache` reads it).

``python -m follicle.prebuild build [FOLDER]`` builds them (default: the package's own
``_kernels``, so a source tree runs as a wheel does); the wheel's build runs the same
into the wheel (``setup.py``), or copies a folder already built for the same sources,
numba, Python and levels.

Each level is compiled by the workload in processes with ``NUMBA_CPU_NAME`` set to it and
no extra features, so the code runs on every CPU of the level. The build machine runs
the code it compiles, so it must have the level's features itself. ``manifest.json``
records what the kernels were built with (a wheel's install reads them only for that
numba, Python and machine, and only while the sources are the ones built) and which
kernels the workload did not compile (none, or a test fails).
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import subprocess
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

__all__ = ["default_levels", "build", "is_fresh", "uncompiled"]

LEVELS_ENV = "FOLLICLE_KERNEL_LEVELS"  # comma-separated CPU levels to build, best first


def default_levels(machine: str | None = None) -> list[str]:
    """The CPU levels a wheel ships by default: ``x86-64-v3`` on x86-64 (AVX2 and FMA:
    within noise of this machine's own code, where ``generic``, SSE2 only, drew frames
    about 20 % slower), ``generic`` elsewhere; ``FOLLICLE_KERNEL_LEVELS`` overrides."""
    chosen = os.environ.get(LEVELS_ENV)
    if chosen:
        return [level.strip() for level in chosen.split(",") if level.strip()]
    machine = (machine or platform.machine()).lower()
    return ["x86-64-v3"] if machine in ("x86_64", "amd64") else ["generic"]


def _identity(package: Path, levels: Sequence[str]) -> dict[str, object]:
    import numba

    from ..kernels.cache import sources_digest

    return {
        "numba": numba.__version__,
        "python": f"{sys.version_info[0]}.{sys.version_info[1]}",
        "machine": platform.machine(),
        "levels": list(levels),
        "sources": sources_digest(package),
    }


def is_fresh(folder: Path, package: Path, levels: Sequence[str]) -> bool:
    """Whether ``folder`` holds kernels built for ``package``'s sources as they are now,
    this numba, Python and machine, and ``levels``, with none left out."""
    try:
        manifest = json.loads((folder / "manifest.json").read_text())
    except (OSError, ValueError):
        return False
    want = _identity(package, levels)
    return all(manifest.get(k) == v for k, v in want.items()) and not manifest.get("uncompiled")


def _check_level(level: str) -> None:
    import llvmlite.binding as ll

    from ..kernels.cache import LEVEL_FEATURES

    if level not in LEVEL_FEATURES:
        raise ValueError(f"unknown CPU level {level!r}: one of {sorted(LEVEL_FEATURES)}")
    have = {name for name, on in ll.get_host_cpu_features().items() if on}
    lacking = sorted(set(LEVEL_FEATURES[level]) - have)
    if lacking:
        raise ValueError(
            f"this machine cannot run the {level} kernels it would build (no {', '.join(lacking)})"
        )


def uncompiled(folder: Path, level: str) -> list[str]:
    """The kernels (module.name) that have no entry in ``folder``'s ``level``: kernels
    inlined into their callers (``inline="always"``) are not counted."""
    import importlib
    import pkgutil

    import follicle

    from ..kernels import KERNELS
    from ..kernels.cache import PACKAGE, _Impl

    for info in pkgutil.walk_packages(follicle.__path__, "follicle."):
        source = Path(PACKAGE, *info.name.split(".")[1:])
        text = source.with_suffix(".py") if not info.ispkg else source / "__init__.py"
        if text.is_file() and "@kernel" in text.read_text(encoding="utf-8"):
            importlib.import_module(info.name)
    missing = []
    for each in KERNELS:
        if each.inline:
            continue
        func = each.py_func
        where = Path(func.__code__.co_filename).resolve().parent.relative_to(PACKAGE)
        index = folder / level / where / f"{_Impl(func).filename_base}.nbi"
        if not index.is_file():
            missing.append(f"{func.__module__}.{func.__qualname__}")
    return missing


def build(
    folder: Path,
    package: Path,
    levels: Sequence[str] | None = None,
    jobs: int | None = None,
    say: Callable[[str], None] = print,
) -> dict[str, object]:
    """Compile the workload of the follicle package at ``package`` for each of ``levels``
    (default :func:`default_levels`) into ``folder``, replacing what it held; returns the
    manifest it wrote."""
    from .runner import run_workload

    levels = list(levels or default_levels())
    for level in levels:
        _check_level(level)
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    path = os.pathsep.join([str(package.parent), *filter(None, [os.environ.get("PYTHONPATH")])])
    missing: dict[str, list[str]] = {}
    for level in levels:
        env = {
            **os.environ,
            "PYTHONPATH": path,
            "NUMBA_CPU_NAME": level,
            "NUMBA_CPU_FEATURES": "",
            "FOLLICLE_KERNELS_BUILD": str(folder),
        }
        say(f"compiling follicle's kernels for {level} …")
        seconds = run_workload(env, jobs, lambda name, k, n: say(f"  {k}/{n} {name}"))
        say(f"  {level}: {seconds:.0f} s")
        left = subprocess.run(
            [sys.executable, "-m", "follicle.prebuild", "uncompiled", str(folder), level],
            env=env,
            check=True,
            capture_output=True,
            text=True,
        ).stdout.split()
        if left:
            missing[level] = left
            say(f"  not compiled by the workload: {', '.join(left)}")
    for lock in folder.rglob(".follicle-kernels.lock"):
        lock.unlink()  # the writers' lock: nothing to ship
    manifest = {**_identity(package, levels), "uncompiled": missing}
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")
    return manifest
