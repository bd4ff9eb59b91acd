"""Write files atomically: to a temporary name beside the target, then rename.

The temporary names in use are kept in a registry, so that a process stopped by a
signal (the CLI's SIGINT / SIGTERM handler) can remove them before it exits, even when
the signal lands inside compiled code where no exception can unwind.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "temporary_folder", "remove_pending"]

_PENDING: set[Path] = set()  # temporary outputs not yet renamed onto their targets


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On any exception the temporary file is removed, so a failed write never
    leaves a half-written output behind; an OSError without a file name gets ``path``'s.
    The parent folder is created.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(
        prefix=f".{target.name}.", suffix=".tmp" + target.suffix, dir=target.parent
    )
    os.close(fd)
    tmp_path = Path(tmp)
    _PENDING.add(tmp_path)
    os.chmod(tmp_path, 0o666 & ~_umask())  # mkstemp makes 0600; outputs get the usual mode
    try:
        yield tmp_path
        os.replace(tmp_path, target)
    except OSError as exc:
        if exc.filename is not None:
            raise
        # a write that failed (full disk, file-size limit) names the output it was for
        raise type(exc)(exc.errno, exc.strerror or str(exc), str(target)) from None
    finally:
        _PENDING.discard(tmp_path)
        if tmp_path.exists():
            tmp_path.unlink()


@contextlib.contextmanager
def temporary_folder(path: str | os.PathLike[str], what: str) -> Iterator[Path]:
    """Yield a new hidden folder beside ``path`` (``.NAME.WHAT-…``) for the pieces of
    its output (a distributed grow's parts); it is removed on leaving, and by
    :func:`remove_pending` when a signal ends the process first."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    folder = Path(tempfile.mkdtemp(prefix=f".{target.name}.{what}-", dir=target.parent))
    _PENDING.add(folder)
    try:
        yield folder
    finally:
        _PENDING.discard(folder)
        shutil.rmtree(folder, ignore_errors=True)


def remove_pending() -> None:
    """Remove every temporary output still being written, file or folder (for a signal
    handler that is about to end the process)."""
    for tmp in list(_PENDING):
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
            continue
        with contextlib.suppress(OSError):
            tmp.unlink()
