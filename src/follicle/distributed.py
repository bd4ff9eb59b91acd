"""Growing on a Dask cluster, byte for byte as one process grows.

Every hair is a pure function of the scene, its seed and its id, so a groom of any size
splits into ranges of hair ids that any worker can grow alone. :func:`grow` sends one
Dask task per range of ``chunk`` ids to the cluster (``"local:N"``: a LocalCluster of N
worker processes on this machine; or a scheduler's address); each worker builds the
groom once from the scene's TOML text (kept per process), grows its range and writes
it as a part file in a folder beside the output, which every worker must reach (a
local disk for ``local:N``, a shared one for a cluster). A part is written to a
temporary name and renamed, and a task names its part by its range, so a retried or
speculative task writes the same bytes over the same name: it can neither corrupt nor
duplicate a part. The client then reads the parts in id order, cuts them into the
writer's own chunks (:data:`follicle.groom.generator.CHUNK`) and streams them into the
one output file through the writer a single-process grow uses, so the file is the same,
byte for byte, for any number of workers and any ``chunk``. The parts folder is removed
when the file is written or the grow fails; the output is written atomically.
"""

from __future__ import annotations

import contextlib
import logging
import os
import uuid
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TypeVar

from .atomic import temporary_folder
from .errors import ConfigError
from .groom.generator import CHUNK, Groom
from .io.targets import NAMED_FORMATS
from .scene import Scene, scene_from_toml, scene_to_toml
from .validate import whole

__all__ = [
    "connect",
    "close",
    "cluster",
    "submit_all",
    "in_order",
    "task_setup",
    "write_part",
    "read_part",
    "grow",
    "target_chunk",
]

R = TypeVar("R")

log = logging.getLogger("follicle")

CONNECT_SECONDS = 10  # how long a scheduler's address may take to answer
WORKER_NICE = 10  # local workers yield the cores to the client's writing (task_setup)
_GROOMS: dict[tuple[str, str], Groom] = {}  # per worker process: the scenes it has built


def connect(scheduler: str) -> object:
    """A ``distributed.Client`` for ``scheduler``: ``"local:N"`` starts a LocalCluster
    of N single-threaded worker processes here (closed with the client), each with its
    share of the cores for numba (``NUMBA_NUM_THREADS``); anything else is a scheduler's
    address (``tcp://host:8786``). ConfigError naming ``--scheduler`` when Dask is not
    installed, N is not a whole number ≥ 1, the workers cannot start, or the address
    does not answer within CONNECT_SECONDS."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ConfigError(
            "--scheduler: Dask is not installed; pip install 'follicle[dist]' (dask[distributed])"
        ) from None
    if scheduler.startswith("local:"):
        n = scheduler.removeprefix("local:")
        if not (n.isdigit() and int(n) >= 1):
            raise ConfigError(
                f"--scheduler {scheduler!r}: local:N takes a whole number of workers ≥ 1"
            )
        logging.getLogger("distributed").setLevel(logging.ERROR)  # its start-up chatter
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
        try:
            cluster = LocalCluster(
                n_workers=int(n),
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",
                silence_logs=logging.ERROR,
                env={
                    "NUMBA_NUM_THREADS": str(max(1, (cores or 1) // int(n))),
                    "FOLLICLE_WORKER_NICE": str(WORKER_NICE),
                },
            )
        except RuntimeError:
            raise ConfigError(
                f"--scheduler {scheduler!r}: the local worker processes did not start; from"
                " a Python script, call follicle.distributed under"
                ' `if __name__ == "__main__":` (they import the script again)'
            ) from None
        client = Client(cluster)
        client._follicle_cluster = cluster  # closed with the client (close())
        log.info("Dask: %d local workers, dashboard %s", int(n), client.dashboard_link)
        return client
    try:
        client = Client(scheduler, timeout=CONNECT_SECONDS)
        log.info("Dask: scheduler %s, dashboard %s", scheduler, client.dashboard_link)
        return client
    except (OSError, TimeoutError, ValueError) as exc:
        raise ConfigError(
            f"--scheduler {scheduler!r}: no Dask scheduler answered there within"
            f" {CONNECT_SECONDS} s ({type(exc).__name__}); start one (dask scheduler) or"
            " give local:N"
        ) from None


def close(client: object) -> None:
    """Close ``client`` and the LocalCluster :func:`connect` started for it, if any."""
    cluster = getattr(client, "_follicle_cluster", None)
    client.close()
    if cluster is not None:
        cluster.close()


@contextmanager
def cluster(scheduler: str) -> Iterator[object]:
    """:func:`connect` to ``scheduler`` for the ``with`` block, closed on leaving."""
    client = connect(scheduler)
    try:
        yield client
    finally:
        close(client)


def submit_all(client: object, fn: Callable[..., R], calls: Sequence[tuple], name: str) -> list:
    """One Dask task ``fn(*call)`` per call, keyed ``follicle-NAME-RUN-I``: a retried or
    speculative task keeps its key, so the scheduler never holds two results for one
    call (``fn`` writes its outputs atomically, under names fixed by its arguments)."""
    run = uuid.uuid4().hex
    return [
        client.submit(fn, *call, key=f"follicle-{name}-{run}-{i}") for i, call in enumerate(calls)
    ]


def in_order(futures: list) -> Iterator[object]:
    """The results of ``futures`` in their order, each as soon as it and those before it
    are done (later tasks keep running meanwhile); a finished future is dropped from
    the list, so its result is not held longer than the caller holds it."""
    for i, future in enumerate(futures):
        result = future.result()
        futures[i] = None
        yield result


def task_setup() -> int:
    """Make the calling thread a Dask task's: numba threads set to the worker process's
    share (``NUMBA_NUM_THREADS``, which :func:`connect` sets per local worker) split
    between the worker's task threads, and on a local cluster the thread's priority
    lowered (``FOLLICLE_WORKER_NICE``): the client, which writes the one output file, is
    the job's critical path and shares these cores. Returns the numba thread count."""
    import numba
    from distributed import get_worker

    threads = max(1, numba.config.NUMBA_NUM_THREADS // get_worker().state.nthreads)
    numba.set_num_threads(threads)
    nice = int(os.environ.get("FOLLICLE_WORKER_NICE", "0"))
    if nice and hasattr(os, "setpriority"):
        with contextlib.suppress(OSError):  # Linux: this thread; elsewhere: the process
            os.setpriority(os.PRIO_PROCESS, 0, nice)
    return threads


def write_part(curves: object, path: str | os.PathLike[str]) -> None:
    """``curves`` (HairCurves) as a part file: its arrays as .npy records one after the
    other, the first naming the rest. A part lives for one job in its own folder, so it
    skips .npz's zip directory and its checks against hostile files; it is written to a
    temporary name and renamed, so a reader never sees half of one."""
    import json

    import numpy as np

    arrays = {"points": curves.points, "offsets": curves.offsets}
    arrays.update({f"p.{k}": v for k, v in sorted(curves.point_data.items())})
    arrays.update({f"c.{k}": v for k, v in sorted(curves.curve_data.items())})
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "wb") as fh:
        np.lib.format.write_array(fh, np.array(json.dumps(list(arrays))), allow_pickle=False)
        for arr in arrays.values():
            np.lib.format.write_array(fh, np.ascontiguousarray(arr), allow_pickle=False)
    os.replace(tmp, path)


def read_part(path: str | os.PathLike[str]) -> object:
    """The HairCurves of a part :func:`write_part` wrote."""
    import json

    import numpy as np

    from .curves import HairCurves

    with open(path, "rb") as fh:
        names = json.loads(str(np.lib.format.read_array(fh, allow_pickle=False)))
        arrays = {name: np.lib.format.read_array(fh, allow_pickle=False) for name in names}
    pd = {k[2:]: v for k, v in arrays.items() if k.startswith("p.")}
    cd = {k[2:]: v for k, v in arrays.items() if k.startswith("c.")}
    return HairCurves(arrays["points"], arrays["offsets"], pd, cd)


def target_chunk(groom: Groom, chunk: object, target: str) -> object:
    """``chunk`` as the ``target`` tool reads it: for one that reads the binding (Unreal)
    each hair also carries the three guides it blends most and their weights."""
    from .curves import HairCurves
    from .io.targets import TARGETS

    if "closest_guides" not in TARGETS[target].curve_names:
        return chunk
    index, weight = groom.guide_binding(chunk.curve_data["hair_id"])
    return HairCurves(
        chunk.points,
        chunk.offsets,
        chunk.point_data,
        {**chunk.curve_data, "closest_guides": index, "guide_weights": weight},
    )


def _groom(text: str, base_dir: str) -> Groom:
    """The groom of the scene ``text`` (relative paths from ``base_dir``), built once per
    worker process."""
    from .pipeline import groom_scene

    key = (text, base_dir)
    if key not in _GROOMS:
        _GROOMS.clear()  # one scene at a time: a worker keeps no more than one groom
        _GROOMS[key] = groom_scene(scene_from_toml(text, "scene", Path(base_dir)))
    return _GROOMS[key]


def _grow_part(text: str, base_dir: str, start: int, count: int, target: str, path: str) -> int:
    """A worker's task: hairs ``start`` … ``start + count − 1`` written to the part file
    ``path``; returns their point count."""
    task_setup()
    groom = _groom(text, base_dir)
    part = target_chunk(groom, groom.generate(count, start), target)
    write_part(part, path)
    return part.point_count


def _rechunked(parts: Iterable[object], size: int) -> Iterator[object]:
    """``parts`` (HairCurves) in order, as chunks of ``size`` hairs (the last shorter)."""
    from .curves import HairCurves

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
    chunk: int = CHUNK,
    target: str = "generic",
    skin: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[int, int]:
    """Grow ``scene``'s hair on the Dask cluster ``scheduler`` (see :func:`connect`) in
    tasks of ``chunk`` hair ids and write it to ``out`` (any format ``follicle grow``
    writes; USD and Alembic with the guides and, with ``skin``, the skin for
    ``target``), the same bytes as a grow in one process (see the module). Returns
    (hairs, points); ``progress(done, total)`` is called as parts are written."""
    from .pipeline import groom_scene

    chunk = whole(chunk, "chunk", 1)
    out = Path(out)
    groom = groom_scene(scene)  # here too: the guides and skin of the file, and errors now
    with cluster(scheduler) as client, temporary_folder(out, "parts") as parts_dir:
        return _grow_on(client, groom, scene, out, parts_dir, chunk, target, skin, progress)


def _grow_on(
    client: object,
    groom: Groom,
    scene: Scene,
    out: Path,
    parts_dir: Path,
    chunk: int,
    target: str,
    skin: bool,
    progress: Callable[[int, int], None] | None,
) -> tuple[int, int]:
    """:func:`grow`'s work on a connected ``client``, parts in ``parts_dir``: the parts
    are written into the file in id order as they arrive, while the later ones grow,
    and each part is removed once written."""
    from .curves import HairCurves
    from .io.dispatch import save

    total = groom.params.count
    text = scene_to_toml(scene, comments=False)
    ranges = [(a, min(chunk, total - a)) for a in range(0, total, chunk)]
    paths = [parts_dir / f"part_{a:012d}" for a, _ in ranges]
    calls = [
        (text, str(scene.base_dir), a, n, target, str(p))
        for (a, n), p in zip(ranges, paths, strict=True)
    ]
    futures = submit_all(client, _grow_part, calls, "grow")
    tally = [0]

    def parts() -> Iterator[HairCurves]:
        for (a, n), path, _ in zip(ranges, paths, in_order(futures), strict=True):
            part = read_part(path)
            path.unlink()
            tally[0] += part.point_count
            if progress is not None:
                progress(a + n, total)
            yield part

    extras = {}
    if out.suffix.lower() in NAMED_FORMATS:  # as `follicle grow` writes them
        extras = {"target": target, "guides": groom.guides.curves}
        extras["mesh"] = groom.mesh if skin else None
    chunks = _rechunked(parts(), CHUNK) if total else iter([groom.generate(count=0)])
    if out.suffix.lower() == ".npz":
        save(HairCurves.concatenate(list(chunks)), out)
    else:
        save(chunks, out, **extras)
    return total, tally[0]
