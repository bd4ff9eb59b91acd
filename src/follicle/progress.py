"""How a long library call reports what it does: a ``progress(done, total)`` callback
for one step, and a :class:`Stage` for a job of several named steps (grow, then
render), which the caller shows as it likes. The CLI shows each stage as a bar with
its label on a terminal and logs its time; Python callers get :func:`quietly` unless
they pass their own."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from typing import Protocol

__all__ = ["Progress", "Stage", "quietly"]

Progress = Callable[[int, int], None]


class Stage(Protocol):
    """``stage(label)``: a context around one step of a job (``"growing hair"``), giving
    the step's progress callback."""

    def __call__(self, label: str) -> AbstractContextManager[Progress]: ...


def _ignore(done: int, total: int) -> None:
    """A progress callback that shows nothing."""


@contextlib.contextmanager
def quietly(label: str) -> Iterator[Progress]:
    """The :class:`Stage` that shows nothing: the default of every job's ``run``."""
    yield _ignore
