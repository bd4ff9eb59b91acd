"""Scenes simulated on a Dask cluster, one per task, byte for byte as one process
simulates them.

:func:`simulate_scenes` runs one task per scene: the worker simulates it
(:func:`follicle.pipeline.timed_simulation`) and writes its cache, the same bytes as
`follicle simulate` of that scene writes.

**Files.** The scenes' files and the output folders must be reached by every worker at
the paths given (a shared disk for a cluster); each cache is written into the job's
hidden folder and renamed into place, as :mod:`follicle.distributed.render` writes its
frames.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from ..atomic import deliver, pending_folders
from ..errors import InputError
from ..inputs import base_folder
from ..io.sim_cache import SimCache, write_cache
from ..pipeline import (
    SimRun,
    timed_simulation,
)
from ..progress import Progress
from ..scene import Scene, scene_from_toml, scene_to_toml
from ..validate import positive, whole
from .cluster import (
    cluster,
    in_order,
    submit_all,
    task_setup,
)

__all__ = ["simulate_scenes"]


TASKS_PER_WORKER = 4  # the frames of a render shared into this many tasks per worker
_CACHES: dict[tuple[str, int, int], SimCache] = {}  # per worker process: the cache it read


def simulate_scenes(
    scenes: Sequence[Scene],
    outs: Sequence[str | os.PathLike[str]],
    scheduler: str,
    frames: int = 48,
    fps: float = 24.0,
    progress: Progress | None = None,
) -> list[SimRun]:
    """Simulate each of ``scenes`` (:func:`follicle.pipeline.simulate_scene`) as one task
    on the Dask cluster ``scheduler``, ``frames`` frames at ``fps``, and write its cache
    to the matching entry of ``outs`` (.npz, each its own, in folders every worker
    reaches): the same bytes as one process writes. Returns each scene's
    :class:`~follicle.pipeline.SimRun`, in order; ``progress(done, total)`` counts
    scenes."""
    frames, fps = whole(frames, "frames", 1), positive(fps, "fps")
    targets = [Path(out).resolve() for out in outs]
    if len(targets) != len(scenes) or len(set(targets)) != len(targets):
        raise InputError(
            f"outs: expected one cache file per scene, each its own ({len(scenes)} scenes,"
            f" {len(set(targets))} distinct files)"
        )
    for target in targets:
        if target.suffix.lower() != ".npz":
            raise InputError(f"{target}: a simulation cache must end in .npz")
    texts = [scene_to_toml(scene, comments=False) for scene in scenes]  # fails now if at all
    runs = []
    folders = list(dict.fromkeys(target.parent for target in targets))
    with pending_folders(folders) as pending, cluster(scheduler) as client:  # workers stop first
        calls = [
            (text, str(scene.base_dir), frames, fps, str(target), pending[target.parent])
            for text, scene, target in zip(texts, scenes, targets, strict=True)
        ]
        for run in in_order(submit_all(client, _simulate_task, calls, "simulate")):
            runs.append(run)
            if progress is not None:
                progress(len(runs), len(calls))
    return runs


def _simulate_task(
    text: str, base_dir: str, frames: int, fps: float, target: str, pending: str
) -> SimRun:
    """A worker's task: the scene ``text`` simulated and its cache written to ``target``
    (through the job's ``pending`` folder)."""
    task_setup()
    cache, run = timed_simulation(
        scene_from_toml(text, "scene", base_folder(base_dir)), frames, fps
    )
    deliver(pending, Path(target), lambda p: write_cache(cache, p))
    return run
