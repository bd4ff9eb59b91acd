"""Write files atomically: to a temporary name beside the target, then rename.

The temporary names in use are kept in a registry, so that a process stopped by a
signal (the CLI's SIGINT / SIGTERM handler) can remove them before it exits, even when
the signal lands inside compiled code where no exception can unwind.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import tempfile
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from .errors import InputError
from .validate import file_path

__all__ = ["atomic_path", "temporary_folder", "pending_folders", "deliver", "remove_pending"]

_PENDING: set[Path] = set()  # temporary outputs not yet renamed onto their targets
_REMOVE_TRIES = 50  # removals of a pending folder another process still writes into


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
    path = file_path(path, "output path")
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


@contextlib.contextmanager
def pending_folders(folders: Sequence[Path]) -> Iterator[dict[Path, str]]:
    """For each of ``folders`` (absolute; made if need be) a job's pending folder in it,
    where the job's processes (Dask workers, or this one) write outputs before renaming
    them into place (:func:`deliver`). They go on leaving, or on a signal, and so do the
    ``folders`` this made if nothing was written into them (the job refused, say, by a
    scheduler that does not answer)."""
    made = [folder for folder in folders if not folder.exists()]
    try:
        with contextlib.ExitStack() as stack:
            yield {
                folder: str(stack.enter_context(temporary_folder(folder / "follicle", "pending")))
                for folder in folders
            }
    finally:
        for folder in made:
            with contextlib.suppress(OSError):  # not empty: outputs were written
                folder.rmdir()


def deliver(pending: str, target: Path, write: Callable[[Path], object]) -> None:
    """``write(path)`` an output (a file or a folder) into a job's ``pending`` folder,
    then rename it onto ``target``, so the output is whole or absent. A folder that is
    already there was delivered by a retried or speculative twin of this task, the same
    bytes: it is kept and this copy dropped. InputError, writing nothing, when this
    process does not see the pending folder: it is on a disk this (worker) machine does
    not share, or the job was stopped and removed it."""
    folder = Path(pending)
    if not folder.is_dir():
        raise InputError(
            f"{target.parent}: a process on {socket.gethostname()} cannot reach this output"
            " folder (or the job was stopped); every Dask worker must reach it at this path"
            " (a shared disk)"
        )
    tmp = folder / f"{uuid.uuid4().hex}.{target.name}"
    write(tmp)
    try:
        os.replace(tmp, target)
    except OSError:
        if not (tmp.is_dir() and target.is_dir()):
            raise
        shutil.rmtree(tmp, ignore_errors=True)  # the first delivery stays


def remove_pending() -> None:
    """Remove every temporary output still being written, file or folder (for a signal
    handler that is about to end the process)."""
    for tmp in list(_PENDING):
        if tmp.is_dir():
            # a process still writing into it (ffmpeg opening its file) may add an entry
            # while the tree goes, and the folder stays: again, until it is gone
            for _ in range(_REMOVE_TRIES):
                shutil.rmtree(tmp, ignore_errors=True)
                if not tmp.exists():
                    break
                time.sleep(0.02)
            continue
        with contextlib.suppress(OSError):
            tmp.unlink()
