"""What the docs build runs, and how: the conventions the executed parts of the site —
the tutorials (:mod:`docs_tutorials`) and the gallery (:mod:`docs_gallery`) — share,
so a reader's command, a failure and a skipped part read the same in both.

* A command is shown as a reader types it and run as written, but with *this* Python:
  ``follicle`` is the one beside ``sys.executable``, ``python`` and ``.venv/bin/python``
  are ``sys.executable`` (``argv``), and a child process finds this venv's tools first
  on its ``PATH`` (``child_env``).
* Every run happens in a fresh temporary folder (``in_fresh_folder``), how a reader
  runs it too; a failure raises :class:`RunError` naming the file and the command or
  cell, which the build hook turns into a ``PluginError`` (a failed strict build).
* Runs go side by side in one thread pool of ``FOLLICLE_DOCS_JOBS`` threads (default 2,
  each run a child process: the pool only waits), and ``FOLLICLE_DOCS_<PART>=0``
  (``TUTORIALS``, ``GALLERY``) builds a part's pages without running it (``skipped``);
  its pictures are then replaced by a note (``not_made``).
* ``mkdocs serve`` reruns only what changed: ``once`` keeps a run's result under the
  SHA-256 of the bytes it depends on.
"""

from __future__ import annotations

import hashlib
import os
import re
import shlex
import subprocess
import sys
import tempfile
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, TypeVar

__all__ = [
    "PICTURE",
    "RunError",
    "argv",
    "child_env",
    "in_fresh_folder",
    "in_pool",
    "not_made",
    "once",
    "skipped",
]

T = TypeVar("T")

# a Markdown picture, ``![alt](path.png)``: group 1 is the path
PICTURE = re.compile(r"!\[[^\]]*\]\(([^)\s]+\.(?:png|jpg|gif|svg))\)")

# the programs a shown command may start with, run as this Python's
_PYTHONS = ("python", "python3", ".venv/bin/python")


class RunError(RuntimeError):
    """A run of the docs build that failed: what ran (file, command or cell) and its
    output or traceback."""


def argv(command: str) -> list[str]:
    """``command`` (split as a shell would; no shell features) as run here: ``follicle``
    and ``python`` are this Python's."""
    args = shlex.split(command)
    if args[0] == "follicle":
        args[0] = str(Path(sys.executable).with_name("follicle"))
    elif args[0] in _PYTHONS:
        args[0] = sys.executable
    return args


def child_env() -> dict[str, str]:
    """The environment of a run's child process: this one's, with this Python's folder
    first on ``PATH`` (a script that calls ``follicle`` gets this install's)."""
    path = os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])
    return {**os.environ, "PATH": path}


def run_child(args: list[str], workdir: Path, timeout: float) -> subprocess.CompletedProcess:
    """``args`` run in ``workdir`` with :func:`child_env`, its output captured as text."""
    return subprocess.run(
        args, cwd=workdir, env=child_env(), capture_output=True, text=True, timeout=timeout
    )


def skipped(part: str) -> bool:
    """Whether ``FOLLICLE_DOCS_<PART>=0`` asks to build ``part``'s pages without running
    it."""
    return os.environ.get(f"FOLLICLE_DOCS_{part.upper()}") == "0"


def in_pool(tasks: Sequence[Callable[[], T]]) -> list[T]:
    """Each task's result, in order, run ``FOLLICLE_DOCS_JOBS`` (default 2) at a time;
    the first to raise is raised (after the others finished)."""
    with ThreadPoolExecutor(int(os.environ.get("FOLLICLE_DOCS_JOBS", "2"))) as pool:
        return list(pool.map(lambda task: task(), tasks))


def in_fresh_folder(prefix: str, run: Callable[[Path], T]) -> T:
    """``run(folder)`` in a new empty temporary folder, removed after."""
    with tempfile.TemporaryDirectory(prefix=prefix) as work:
        return run(Path(work))


# what a run depended on (SHA-256) -> its result: `mkdocs serve` reruns only a change
_DONE: dict[str, Any] = {}


def once(depends: Sequence[bytes], run: Callable[[], T]) -> T:
    """``run()``'s result, computed once per build process for the same ``depends``
    bytes (the files the run reads)."""
    digest = hashlib.sha256()
    for part in depends:
        digest.update(hashlib.sha256(part).digest())
    key = digest.hexdigest()
    if key not in _DONE:
        _DONE[key] = run()
    return _DONE[key]


def not_made(name: str, by: str) -> str:
    """The note a page shows for picture ``name`` when the part that makes it is
    skipped."""
    return f"*(picture `{name}`: made when {by} run)*"
