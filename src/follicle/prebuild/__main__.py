"""``python -m follicle.prebuild``: build the prebuilt kernels, and the pieces the build and
``follicle warm`` run in processes of their own.

- ``build [FOLDER] [--levels L1,L2] [--jobs N] [--reuse BUILT]``: compile the workload
  for CPU levels into FOLDER (default: this package's ``_kernels``),
  :func:`follicle.prebuild.build.build`; or copy BUILT there when it holds the kernels
  of these very sources, numba, Python and levels (what a wheel's build does with the
  source tree's ``_kernels``);
- ``warm [--jobs N]``: compile the workload for this machine into numba's cache (what
  ``follicle warm`` runs), printing ``tasks N``, then ``K/N NAME`` as each task ends;
- ``task NAME FOLDER``: run one task of the workload in FOLDER;
- ``uncompiled FOLDER LEVEL``: print the kernels FOLDER's LEVEL lacks.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m follicle.prebuild")
    commands = parser.add_subparsers(dest="command", required=True)
    build = commands.add_parser("build", help="compile the kernels a wheel ships")
    build.add_argument("folder", nargs="?", default=None)
    build.add_argument("--levels", default=None, help="CPU levels, best first (x86-64-v3,generic)")
    build.add_argument("--jobs", type=int, default=None, help="processes at once (default: CPUs)")
    build.add_argument("--reuse", default=None, help="a folder of kernels to copy when fresh")
    warm = commands.add_parser("warm", help="compile the kernels for this machine")
    warm.add_argument("--jobs", type=int, default=None, help="processes at once (default: CPUs)")
    task = commands.add_parser("task", help="run one task of the workload")
    task.add_argument("name")
    task.add_argument("folder")
    left = commands.add_parser("uncompiled", help="kernels a built folder lacks")
    left.add_argument("folder")
    left.add_argument("level")
    args = parser.parse_args(argv)

    if args.command == "warm":
        import os

        from .runner import run_workload
        from .workload import TASKS

        print(f"tasks {len(TASKS)}", flush=True)
        run_workload(os.environ, args.jobs, lambda n, k, t: print(f"{k}/{t} {n}", flush=True))
        return 0
    if args.command == "task":
        from .workload import run_task

        run_task(args.name, Path(args.folder))
        return 0
    if args.command == "uncompiled":
        from .build import uncompiled

        print("\n".join(uncompiled(Path(args.folder), args.level)))
        return 0
    import shutil

    from ..kernels.cache import PACKAGE, SHIPPED
    from .build import build as build_kernels
    from .build import default_levels, is_fresh

    levels = args.levels.split(",") if args.levels else default_levels()
    folder = Path(args.folder or SHIPPED)
    if args.reuse and is_fresh(Path(args.reuse), PACKAGE, levels):
        shutil.rmtree(folder, ignore_errors=True)
        shutil.copytree(args.reuse, folder, ignore=shutil.ignore_patterns(".*"))
        print(f"kernels for {', '.join(levels)} copied from {args.reuse}")
        return 0
    manifest = build_kernels(folder, PACKAGE, levels, args.jobs)
    return 1 if manifest["uncompiled"] else 0


if __name__ == "__main__":
    sys.exit(main())
