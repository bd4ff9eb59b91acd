"""Input paths checked before anything reads them: a regular file, or one clear refusal.

A FIFO would block a reader forever, a device (``/dev/zero``) would feed it without end
and a folder cannot be parsed, so every reader, the scene loader and the mesh and
texture loaders take their path through :func:`input_file` first.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from .errors import FormatError

__all__ = ["input_file"]


def input_file(path: str | os.PathLike[str], what: str = "file") -> Path:
    """``path`` if it names a regular file (symbolic links followed), else FormatError
    naming it and saying what it is instead; ``what`` says what was expected."""
    p = Path(path)
    try:
        mode = p.stat().st_mode
    except FileNotFoundError:
        raise FormatError(f"{p}: no such file") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the path
        reason = getattr(exc, "strerror", None) or exc
        raise FormatError(f"{p!s:.200}: cannot be read ({reason}); give a {what}") from None
    if stat.S_ISDIR(mode):
        raise FormatError(f"{p}: is a folder, not a file; give a {what}")
    if not stat.S_ISREG(mode):
        kind = (
            "a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
        )
        raise FormatError(f"{p}: is {kind}, not a regular file; give a {what}")
    return p
