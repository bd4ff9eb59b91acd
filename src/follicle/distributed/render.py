"""A simulation cache's frames rendered on a Dask cluster, byte for byte as one process
renders them.

:func:`render_cache` and :func:`render_video` split a cache's frames into
runs of ``frames_per_task`` (default :func:`default_frames_per_task`: four tasks per
worker, so a worker that finishes early takes another and the job ends within about a
quarter of a worker's share). The client computes the sequence's one camera
(:func:`follicle.pipeline.sequence_camera`: framed on the whole cache, frame 0's hair
included) and passes it with the cache's path and the scene's TOML text, never the
arrays: each worker reads the cache itself (once per process), builds the groom once
per process and draws its frames through :func:`follicle.pipeline.draw_frames`, as the
single-process render does, so each image is the same bytes. For a folder, each worker
writes its frames' PNGs; for an MP4, tasks return their images and the client hands
them to the encoder in frame order as they arrive, with at most
:data:`~follicle.distributed.cluster.AHEAD` tasks per worker thread run ahead of it.


**Files.** Every path a worker is given is absolute, and every worker must reach it: the
cache, the output folder (a local disk for ``local:N``, a shared one for a cluster). A
worker writes an output into a hidden job folder beside it (created by the client)
and renames it into place, so an output is whole or absent. The job folder goes when
the job ends, fails or is stopped (SIGINT/SIGTERM: local workers are stopped first),
and with it any output not yet renamed; a task still running on a remote worker then
finds the folder gone and writes nothing. Finished outputs stay, as in one process.
"""

from __future__ import annotations

import functools
import math
import os
import socket
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..atomic import deliver, pending_folders
from ..errors import InputError
from ..inputs import base_folder
from ..io.sim_cache import SimCache, load_cache
from ..pipeline import (
    cache_scene,
    check_cache_skin,
    check_frames,
    draw_frames,
    frame_name,
    groom_scene,
    sequence_camera,
)
from ..progress import Progress
from ..render import Camera, save_png
from ..render.video import Mp4Writer
from ..scene import Scene, scene_from_toml, scene_to_toml
from ..validate import whole
from .cluster import (
    AHEAD,
    DaskClient,
    cluster,
    streamed,
    submit_all,
    task_setup,
    worker_groom,
    workers_of,
)

__all__ = ["TASKS_PER_WORKER", "default_frames_per_task", "render_cache", "render_video"]


TASKS_PER_WORKER = 4  # the frames of a render shared into this many tasks per worker
_CACHES: dict[tuple[str, int, int], SimCache] = {}  # per worker process: the cache it read


def default_frames_per_task(frames: int, workers: int) -> int:
    """Frames per task when none is given: ``frames`` shared into
    :data:`TASKS_PER_WORKER` tasks per worker, at least one frame each. Each task pays
    for a renderer and its first frame's set-up, so fewer, longer tasks cost less; a
    few per worker keep the workers busy to the end when some are slower."""
    return max(1, math.ceil(frames / (TASKS_PER_WORKER * max(1, workers))))


def render_cache(
    cache: SimCache,
    out_dir: str | os.PathLike[str],
    scheduler: str,
    scene: Scene | None = None,
    frames: range | None = None,
    frames_per_task: int | None = None,
    progress: Progress | None = None,
) -> list[Path]:
    """:func:`follicle.pipeline.render_cache` on the Dask cluster ``scheduler`` (see
    :func:`follicle.distributed.cluster.connect`): frames of ``cache`` (read by
    :func:`~follicle.io.sim_cache.load_cache` from a file every worker reaches) to
    ``out_dir/frame_0000.png``, …, each worker writing its own frames' PNGs, the same
    bytes as one process writes. Returns the paths in frame order; ``progress(done,
    total)`` counts frames as tasks finish."""
    from distributed import as_completed

    job = _FramesJob(cache, scene, frames, frames_per_task)
    out = Path(out_dir)
    folder = out.resolve()
    with pending_folders([folder]) as pending, cluster(scheduler) as client:  # workers stop first
        calls = [(*call, str(folder), pending[folder]) for call in job.calls(client)]
        done = 0
        for future in as_completed(submit_all(client, _render_task, calls, "render")):
            done += future.result()
            if progress is not None:
                progress(done, len(job.frames))
    return [out / frame_name(cache, f) for f in job.frames]


def render_video(
    cache: SimCache,
    path: str | os.PathLike[str],
    scheduler: str,
    scene: Scene | None = None,
    frames: range | None = None,
    frames_per_task: int | None = None,
    progress: Progress | None = None,
) -> Path:
    """Frames of ``cache`` rendered on the Dask cluster ``scheduler`` and encoded here, in
    frame order as they arrive, as the H.264 MP4 ``path`` at the cache's fps (see
    :func:`render_cache` for the rest): the video `follicle render CACHE -o path.mp4`
    makes in one process. Returns ``path``; ``progress(done, total)`` counts frames
    encoded."""
    job = _FramesJob(cache, scene, frames, frames_per_task)
    done = 0
    with Mp4Writer(path, cache.fps) as video:  # path, fps and ffmpeg checked first
        with cluster(scheduler) as client:
            calls = job.calls(client)
            ahead = AHEAD * workers_of(client)
            for images in streamed(client, _video_task, calls, "video", ahead):
                for image in images:
                    video.write(image)
                done += len(images)
                if progress is not None:
                    progress(done, len(job.frames))
    return video.path


class _FramesJob:
    """What the client works out once for a render on a cluster: the frames checked, the
    cache's file as workers read it, the scene as TOML, and the sequence's camera."""

    def __init__(
        self,
        cache: SimCache,
        scene: Scene | None,
        frames: range | None,
        frames_per_task: int | None,
    ) -> None:
        self.frames = check_frames(cache, frames)
        self.per_task = whole(frames_per_task, "frames_per_task", 1, allow_none=True)
        source = Path(cache.source)
        if not source.is_file():
            raise InputError(
                f"{cache.source}: a render on a cluster needs the cache's file, which every"
                " worker reads; load the cache from one (load_cache)"
            )
        self.source = str(source.resolve())
        scene = cache_scene(cache) if scene is None else scene
        self.text, self.base_dir = scene_to_toml(scene, comments=False), str(scene.base_dir)
        groom = groom_scene(scene)
        check_cache_skin(cache, groom.mesh)
        self.camera = sequence_camera(cache, groom, scene.render)

    def calls(self, client: DaskClient) -> list[tuple]:
        """One task's arguments per run of frames, sized for ``client``'s workers."""
        first, stop = self.frames.start, self.frames.stop
        per = self.per_task or default_frames_per_task(len(self.frames), workers_of(client))
        return [
            (self.source, self.text, self.base_dir, a, min(a + per, stop), self.camera)
            for a in range(first, stop, per)
        ]


def _worker_cache(path: str) -> SimCache:
    """The cache at ``path``, read once per worker process (again when the file changes);
    InputError naming it when this worker cannot read it."""
    try:
        st = os.stat(path)
        key = (path, st.st_mtime_ns, st.st_size)
        if key not in _CACHES:
            _CACHES.clear()  # one cache at a time
            _CACHES[key] = load_cache(path)
        return _CACHES[key]
    except (OSError, InputError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise InputError(
            f"{path}: a Dask worker on {socket.gethostname()} cannot read this simulation"
            f" cache ({why}); every worker must reach it at this path (a shared disk)"
        ) from None


def _drawn(
    source: str, text: str, base_dir: str, start: int, stop: int, camera: Camera
) -> tuple[SimCache, Iterator[tuple[int, np.ndarray]]]:
    """A worker's frames ``start`` … ``stop − 1`` of the cache at ``source``, drawn as the
    single-process render draws them: (the cache, (frame, image) as drawn)."""
    task_setup()
    cache = _worker_cache(source)
    scene = scene_from_toml(text, "scene", base_folder(base_dir))
    groom = worker_groom(text, base_dir)  # per worker process, shared with distributed grow
    return cache, draw_frames(cache, groom, scene.render, range(start, stop), camera)


def _render_task(
    source: str,
    text: str,
    base_dir: str,
    start: int,
    stop: int,
    camera: Camera,
    folder: str,
    pending: str,
) -> int:
    """A worker's task: its frames' PNGs written into ``folder`` (through the job's
    ``pending`` folder); returns how many."""
    cache, drawn = _drawn(source, text, base_dir, start, stop, camera)
    for f, image in drawn:
        deliver(pending, Path(folder) / frame_name(cache, f), functools.partial(save_png, image))
    return stop - start


def _video_task(
    source: str, text: str, base_dir: str, start: int, stop: int, camera: Camera
) -> np.ndarray:
    """A worker's task: its frames' images, (frames, H, W, 4) uint8 sRGB."""
    _, drawn = _drawn(source, text, base_dir, start, stop, camera)
    return np.stack([image for _, image in drawn])
