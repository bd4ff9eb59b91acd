"""The viewer's groom inputs made again in the background: a change of a key the rest
pose comes from (``[groom].settle``, the ``[sim]`` dynamics that settle the guides, the
density or groups) reads and settles the guides as ``follicle render`` does
(:func:`follicle.pipeline.groom_inputs`, which reuses what the change left valid), on a
worker thread, so the window keeps drawing — a settle of the default groom takes
seconds. The hand strokes made so far are replayed on the new guides
(:func:`follicle.editing.editor.replay`), so a groom edited by hand keeps its edits.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence

from ..editing.editor import GuideEditor, replay
from ..errors import FollicleError
from ..pipeline import GroomInputs, groom_inputs
from ..scene import Scene

__all__ = ["Settling"]


class _Cancelled(Exception):
    """Raised in the settle's progress callback to end a superseded job early."""


class Settling:
    """:func:`~follicle.pipeline.groom_inputs` of ``scene`` (``reuse``: the inputs in use)
    on a worker thread, then the stroke ``log`` replayed on a
    :class:`~follicle.GuideEditor` of its guides (None when the log is empty).
    :attr:`share` is how much of the settle is done; :meth:`result` the outcome."""

    def __init__(
        self, scene: Scene, reuse: GroomInputs, log: Sequence[Mapping[str, object]]
    ) -> None:
        self.scene = scene
        self.log = list(log)
        self.share = 0.0
        self._reuse = reuse
        self._cancel = threading.Event()
        self._result: tuple[GroomInputs, GuideEditor | None] | None = None
        self._error: FollicleError | None = None
        self._thread = threading.Thread(target=self._run, name="follicle-settle", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            inputs = groom_inputs(self.scene, self._reuse, self._progress)
            editor = None
            if self.log:
                editor = GuideEditor(inputs.guides)
                replay(editor, {"strokes": self.log}, "the viewer's strokes")
            self._result = (inputs, editor)
        except _Cancelled:
            pass
        except FollicleError as exc:  # shown in the viewer's status line
            self._error = exc

    def _progress(self, done: int, total: int) -> None:
        if self._cancel.is_set():
            raise _Cancelled
        self.share = done / total

    @property
    def finished(self) -> bool:
        return not self._thread.is_alive()

    def join(self, timeout: float | None = None) -> bool:
        """Wait for the worker (at most ``timeout`` s); whether it has finished."""
        self._thread.join(timeout)
        return self.finished

    def cancel(self) -> None:
        """End the job at its next progress report; its result is dropped."""
        self._cancel.set()

    def result(self) -> tuple[GroomInputs, GuideEditor | None] | None:
        """The inputs and the replayed editor once finished (None: cancelled); the
        FollicleError the job met, raised here."""
        if self._error is not None:
            raise self._error
        return None if self._cancel.is_set() else self._result
