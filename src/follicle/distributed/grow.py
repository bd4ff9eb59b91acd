"""Growing on a Dask cluster, byte for byte as one process grows.

Every hair is a pure function of the scene, its seed and its id, so a groom of any size
splits into ranges of hair ids that any worker can grow alone. :func:`grow` sends one
Dask task per range of ``chunk`` ids to the cluster (``"local:N"``: a LocalCluster of N
worker processes on this machine; or a scheduler's address); each worker builds the
groom once from the scene's TOML text (kept per process), grows its range and writes it
as a part (:func:`write_part`: a folder of .npy files, renamed into place whole) in a
folder every worker must reach: in memory (``/dev/shm``) for a local cluster, beside the
output for a remote one, which needs a shared disk. Tasks are keyed by their range, so
a retried or speculative task writes the same part under the same name and can neither
corrupt nor duplicate one.

The client writes the one output file while the workers grow (:func:`streamed`): it
takes the parts in id order as they come (:func:`read_part`), cuts them into
the writer's own chunks (:data:`follicle.groom.generator.CHUNK`) and streams them
through the writer a single-process grow uses, so the file is the same, byte for byte,
for any number of workers and any ``chunk``. Only ``AHEAD`` tasks per worker thread run
ahead of the writing, so the parts held at once stay bounded whatever the groom's size,
and each part is removed once written. Local workers get their share of the cores for
numba (:func:`task_setup`). The parts folder is removed when the
file is written or the grow fails (and on SIGINT/SIGTERM); the output is atomic.

The cluster's plumbing is :mod:`follicle.distributed.cluster`.
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Iterable, Iterator
from pathlib import Path

from ..atomic import temporary_folder
from ..curves import HairCurves
from ..errors import ConfigError
from ..groom.generator import CHUNK, Groom
from ..io.targets import writer_extras
from ..progress import Progress
from ..scene import Scene, scene_to_toml
from ..threads import threads_for
from ..validate import whole
from .cluster import (
    AHEAD,
    cluster,
    on_worker,
    parts_folder,
    read_part,
    streamed,
    submit_all,
    task_setup,
    worker_groom,
    workers_of,
    write_part,
)

__all__ = ["grow", "part_ranges", "target_chunk", "LAYOUTS"]

LAYOUTS = ("file", "payloads")  # how a grow's USD is laid out: one file, or a root and parts


def target_chunk(groom: Groom, chunk: HairCurves, target: str) -> HairCurves:
    """``chunk`` as the ``target`` tool reads it: for one that reads the binding (Unreal)
    each hair also carries the three guides it blends most and their weights; for one
    that reads interpolation groups (Unreal, Unity) the group it grew in
    (:func:`follicle.io.animation.with_groups`)."""
    from ..io.animation import with_groups
    from ..io.targets import TARGETS

    tool = TARGETS[target]
    chunk = with_groups(chunk, groom.guides, tool)
    if "closest_guides" not in tool.curve_names:
        return chunk
    index, weight = groom.guide_binding(chunk.curve_data["hair_id"])
    return HairCurves(
        chunk.points,
        chunk.offsets,
        chunk.point_data,
        {**chunk.curve_data, "closest_guides": index, "guide_weights": weight},
    )


def _grow_part(
    text: str, base_dir: str, start: int, count: int, target: str, path: str, usd: bool = False
) -> int:
    """A worker's task: hairs ``start`` … ``start + count − 1`` written as the part
    ``path`` (:func:`write_part`; with ``usd``, the USD part file of a payloads layout,
    :func:`follicle.io.usd_payloads.save_usd_part`); returns their point count."""
    task_setup()
    with on_worker():
        groom = worker_groom(text, base_dir)
        part = target_chunk(groom, groom.generate(count, start), target)
        if usd:
            from ..io.usd_payloads import save_usd_part

            save_usd_part(part, path, target=target)
        else:
            write_part(part, path)
    return part.point_count


def _rechunked(parts: Iterable[HairCurves], size: int) -> Iterator[HairCurves]:
    """``parts`` (HairCurves) in order, as chunks of ``size`` hairs (the last shorter)."""

    held: list[HairCurves] = []
    count = 0
    for part in parts:
        held.append(part)
        count += part.curve_count
        while count >= size:
            whole_ = HairCurves.concatenate(held) if len(held) > 1 else held[0]
            if whole_.curve_count == size:
                yield whole_
                held, count = [], 0
                break
            yield whole_[:size]
            rest = whole_[size:]
            held, count = ([rest] if rest.curve_count else []), rest.curve_count
    if held:
        yield HairCurves.concatenate(held) if len(held) > 1 else held[0]


def grow(
    scene: Scene,
    out: str | os.PathLike[str],
    scheduler: str,
    chunk: int | None = None,
    target: str = "generic",
    skin: bool = True,
    progress: Progress | None = None,
    layout: str | None = None,
) -> tuple[int, int]:
    """Grow ``scene``'s hair on the Dask cluster ``scheduler`` (see :func:`connect`) in
    tasks of ``chunk`` hair ids and write it to ``out`` (any format ``follicle grow``
    writes; USD and Alembic with the guides and, with ``skin``, the skin for
    ``target``), the same bytes as a grow in one process (see the module). Returns
    (hairs, points); ``progress(done, total)`` is called as parts are written.

    ``layout`` (default the scene's ``[output].layout``) ``"payloads"`` (USD): each task
    writes its hairs as one part file of the payloads layout
    (:mod:`follicle.io.usd_payloads`; ``chunk`` hairs each, default
    :data:`~follicle.io.usd_payloads.PART_HAIRS`) and the client only the root layer, the
    same bytes as ``follicle grow --layout payloads`` in one process with that chunk."""
    layout = layout or scene.output.layout
    if layout not in LAYOUTS:
        raise ConfigError(f"layout {layout!r}: give one of {', '.join(LAYOUTS)}")
    if layout == "payloads":
        return _grow_payloads(scene, out, scheduler, chunk, target, skin, progress)
    from ..io.dispatch import save
    from ..pipeline import groom_scene

    chunk = whole(CHUNK if chunk is None else chunk, "chunk", 1)
    out = Path(out)
    total = scene.groom.count
    text = scene_to_toml(scene, comments=False)
    local = scheduler.startswith("local:")
    with cluster(scheduler) as client, parts_folder(out, local) as folder:
        calls = [
            (text, str(scene.base_dir), a, min(chunk, total - a), target, str(folder / f"{a:012d}"))
            for a in range(0, total, chunk)
        ]
        done = streamed(client, _grow_part, calls, "grow", AHEAD * workers_of(client))
        groom = groom_scene(scene)  # the guides and skin of the file, as the tasks run
        tally = [0]

        def written() -> Iterator[HairCurves]:
            for (*_, a, n, _, path), points in zip(calls, done, strict=True):
                part = read_part(path)
                tally[0] += points
                yield part
                shutil.rmtree(path, ignore_errors=True)
                if progress is not None:
                    progress(a + n, total)

        extras = writer_extras(out, target, groom.guides, groom.mesh if skin else None)
        chunks = _rechunked(written(), CHUNK) if total else iter([groom.generate(count=0)])
        # a local cluster's workers hold the other cores: the client's own kernels (the
        # parts' checks, the bounds) on its one, where a parallel kernel's join would
        # wait for threads the workers hold (3× the time of the checks here)
        with threads_for(1, 1) if local else contextlib.nullcontext():
            if out.suffix.lower() == ".npz":
                save(HairCurves.concatenate(list(chunks)), out)
            else:
                save(chunks, out, **extras)
    return total, tally[0]


def part_ranges(total: int, chunk: int) -> list[tuple[int, int]]:
    """(start, count) of each part of ``total`` hairs in parts of ``chunk``: one empty
    part for none, so that a groom of 0 hairs is still a file."""
    return [(a, min(chunk, total - a)) for a in range(0, total, chunk)] or [(0, 0)]


def _grow_payloads(
    scene: Scene,
    out: str | os.PathLike[str],
    scheduler: str,
    chunk: int | None,
    target: str,
    skin: bool,
    progress: Progress | None,
) -> tuple[int, int]:
    """:func:`grow` in the payloads layout: one task per part file, written by the worker
    into a folder beside ``out`` that every worker must reach; the client writes the
    root layer when all are in (the cluster's progress as they come, in any order)."""
    from distributed import as_completed

    from ..io.usd_payloads import PART_HAIRS, check_payloads_target, finish_payloads, part_file
    from ..pipeline import groom_scene

    chunk = whole(PART_HAIRS if chunk is None else chunk, "chunk", 1)
    out = check_payloads_target(out)
    total = scene.groom.count
    text = scene_to_toml(scene, comments=False)
    ranges = part_ranges(total, chunk)
    with cluster(scheduler) as client, temporary_folder(out, "payloads") as staged:
        calls = [
            (text, str(scene.base_dir), a, n, target, str(part_file(staged, i)), True)
            for i, (a, n) in enumerate(ranges)
        ]
        futures = submit_all(client, _grow_part, calls, "grow")
        groom = groom_scene(scene)  # the guides and skin of the root, as the tasks run
        sizes = {future.key: n for future, (_, n) in zip(futures, ranges, strict=True)}
        points = done = 0
        for future in as_completed(futures):
            points += future.result()
            done += sizes[future.key]
            if progress is not None:
                progress(done, total)
        mesh = groom.mesh if skin else None
        finish_payloads(out, staged, len(ranges), groom.guides, mesh=mesh, target=target)
    return total, points
