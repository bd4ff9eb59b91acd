"""Work on a Dask cluster, byte for byte as one process does it; first of all, growing.

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

The pieces (:func:`cluster`, :func:`submit_all`, :func:`in_order`, :func:`streamed`,
:func:`task_setup`) serve the other commands that run on a cluster.
"""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import sys
import uuid
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TypeVar

from .atomic import temporary_folder
from .errors import ConfigError, FileAccessError, FollicleError
from .groom.generator import CHUNK, Groom
from .inputs import base_folder
from .io.targets import writer_extras
from .scene import Scene, scene_from_toml, scene_to_toml
from .threads import threads_for
from .validate import whole

__all__ = [
    "connect",
    "close",
    "cluster",
    "submit_all",
    "in_order",
    "task_setup",
    "on_worker",
    "write_part",
    "read_part",
    "grow",
    "part_ranges",
    "target_chunk",
    "LAYOUTS",
]

R = TypeVar("R")

log = logging.getLogger("follicle")

_QUIET_TRACKER = "ignore:resource_tracker:UserWarning"
CONNECT_SECONDS = 10  # how long a scheduler's address may take to answer
MAX_WORKERS_PER_CORE = 4  # local:N at most this many worker processes a core
LAYOUTS = ("file", "payloads")  # how a grow's USD is laid out: one file, or a root and parts
AHEAD = 3  # grow tasks in flight per worker thread, ahead of the client's writing
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
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if scheduler.startswith("local:"):
        n = scheduler.removeprefix("local:")
        most = MAX_WORKERS_PER_CORE * (cores or 1)
        if not (n.isascii() and n.isdigit() and len(n) <= 6 and int(n) >= 1):
            raise ConfigError(
                f"--scheduler {scheduler[:40]!r}: local:N takes a whole number of workers ≥ 1"
            )
        if int(n) > most:
            raise ConfigError(
                f"--scheduler {scheduler!r}: at most {most} local workers here"
                f" ({MAX_WORKERS_PER_CORE} a core; each is a Python process); give"
                f" local:{cores or 1} for one a core"
            )
        logging.getLogger("distributed").setLevel(logging.ERROR)  # its start-up chatter
        # Ctrl-C kills the workers (cli._interrupted): multiprocessing's resource tracker,
        # started with the cluster, then removes the semaphores they held and would warn
        # of each on the terminal, under the CLI's one line; its flags come from here
        if _QUIET_TRACKER not in sys.warnoptions:
            sys.warnoptions.append(_QUIET_TRACKER)
        try:
            cluster = LocalCluster(
                n_workers=int(n),
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",
                silence_logs=logging.CRITICAL,  # a failed task comes back as its error, once
                env={"NUMBA_NUM_THREADS": str(max(1, (cores or 1) // int(n)))},
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
    _check_answers(scheduler)
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


def _check_answers(scheduler: str) -> None:
    """ConfigError naming ``--scheduler`` unless ``scheduler`` is a TCP address whose
    server speaks within CONNECT_SECONDS: a Dask server sends its handshake as soon as it
    accepts a connection, and the client's own timeout does not cover a server that
    accepts and then says nothing (it would wait for ever)."""
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    shown = repr(scheduler[:200])
    try:
        scheme, location = parse_address(scheduler)
        host, port = parse_host_port(location)
    except (ValueError, TypeError):
        raise ConfigError(
            f"--scheduler {shown}: expected local:N or a scheduler's address, tcp://HOST:PORT"
        ) from None
    if scheme != "tcp":
        raise ConfigError(
            f"--scheduler {shown}: follicle connects to a Dask scheduler over tcp:// only"
            f" ({scheme}:// needs security or transport settings that follicle does not pass);"
            " give tcp://HOST:PORT, e.g. through an SSH tunnel"
        )
    try:
        with socket.create_connection((host, port), timeout=CONNECT_SECONDS) as conn:
            conn.settimeout(CONNECT_SECONDS)
            said = conn.recv(1)
    except TimeoutError:
        said = b""
    except OSError as exc:
        raise ConfigError(
            f"--scheduler {shown}: no Dask scheduler answered there within"
            f" {CONNECT_SECONDS} s ({type(exc).__name__}); start one (dask scheduler) or"
            " give local:N"
        ) from None
    if not said:
        raise ConfigError(
            f"--scheduler {shown}: the address accepted a connection but said nothing within"
            f" {CONNECT_SECONDS} s, so it is not a Dask scheduler; check the host and port"
        )


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


def streamed(
    client: object, fn: Callable[..., R], calls: Sequence[tuple], name: str, ahead: int
) -> Iterator[R]:
    """The results of ``fn(*call)`` for each call, in order, computed as Dask tasks (keyed
    as :func:`submit_all` keys them) with at most ``ahead`` of them submitted and not yet
    handed over: the workers run ahead of the caller by that much and no more, so their
    results, held in their memory until fetched, stay bounded whatever the job's size.
    The first ``ahead`` tasks are submitted at once, before the first result is asked
    for, so the caller can do its own work while they run."""
    run = uuid.uuid4().hex

    def submit(i: int) -> object:
        return client.submit(fn, *calls[i], key=f"follicle-{name}-{run}-{i}")

    pending = deque(submit(i) for i in range(min(ahead, len(calls))))

    def results() -> Iterator[R]:
        for i in range(len(pending), len(calls) + len(pending)):
            result = pending.popleft().result()
            if i < len(calls):
                pending.append(submit(i))
            yield result

    return results()


def workers_of(client: object) -> int:
    """How many tasks ``client``'s cluster runs at once (its workers' threads), at least 1."""
    return max(1, sum(client.nthreads().values()))


def task_setup() -> int:
    """Make the calling thread a Dask task's: numba threads set to the worker process's
    share (``NUMBA_NUM_THREADS``, which :func:`connect` sets per local worker) split
    between the worker's task threads, so that the workers of one machine do not ask
    for more threads than it has cores. Returns the numba thread count."""
    import numba

    from distributed import get_worker

    threads = max(1, numba.config.NUMBA_NUM_THREADS // get_worker().state.nthreads)
    numba.set_num_threads(threads)
    return threads


@contextmanager
def on_worker() -> Iterator[None]:
    """Run a task's body: a FollicleError raised in it comes back to the client naming
    the Dask worker; one about a file it could not find, read or write
    (:class:`~follicle.errors.FileAccessError`) also says what
    every worker needs (the scene's files and the output's folder at the client's
    paths), the usual cause on a cluster. A bad file is named as it is, no hint."""
    try:
        yield
    except FollicleError as exc:
        from distributed import get_worker

        hint = ""
        if isinstance(exc, FileAccessError):
            hint = (
                " (every worker must reach the scene's files and the output's folder at"
                " the paths the client gives)"
            )
        raise type(exc)(f"on Dask worker {get_worker().address}: {exc}{hint}") from None


def write_part(curves: object, path: str | os.PathLike[str]) -> None:
    """``curves`` (HairCurves) as a part: a folder of one .npy file per array
    (``points``, ``offsets``, ``p.NAME``, ``c.NAME`` for point and curve data), written
    under a temporary name and renamed, so a reader never sees half of one and a task
    run twice leaves one. A part lives for one job in a folder of its own, so it skips
    .npz's zip directory and its checks against hostile files."""
    import numpy as np

    arrays = {"points": curves.points, "offsets": curves.offsets}
    arrays.update({f"p.{k}": v for k, v in curves.point_data.items()})
    arrays.update({f"c.{k}": v for k, v in curves.curve_data.items()})
    target = Path(path)
    tmp = target.with_name(f"{target.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    tmp.mkdir()
    for name, arr in arrays.items():
        np.save(tmp / f"{name}.npy", np.ascontiguousarray(arr), allow_pickle=False)
    try:
        os.rename(tmp, target)
    except OSError:  # the same part, written by a retried task first: keep that one
        shutil.rmtree(tmp, ignore_errors=True)
        if not target.is_dir():
            raise


def read_part(path: str | os.PathLike[str]) -> object:
    """The HairCurves of a part :func:`write_part` wrote, read into memory (mapping it
    saves the copy but pays as much in page faults, measured)."""
    import numpy as np

    from .curves import HairCurves

    arrays = {f.name[:-4]: np.load(f) for f in sorted(Path(path).glob("*.npy"))}
    pd = {k[2:]: v for k, v in arrays.items() if k.startswith("p.")}
    cd = {k[2:]: v for k, v in arrays.items() if k.startswith("c.")}
    return HairCurves(arrays["points"], arrays["offsets"], pd, cd)


def parts_folder(out: Path, local: bool) -> contextlib.AbstractContextManager[Path]:
    """A temporary folder for a job's parts (removed on leaving, and on a signal): for a
    local cluster in memory (``/dev/shm``, where there is one: a part costs a copy, not
    a disk write and read), else beside ``out``, where every worker of a cluster must
    reach it."""
    shm = Path("/dev/shm")
    if local and shm.is_dir() and os.access(shm, os.W_OK):
        return temporary_folder(shm / out.name, "parts")
    return temporary_folder(out, "parts")


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
        _GROOMS[key] = groom_scene(scene_from_toml(text, "scene", base_folder(base_dir)))
    return _GROOMS[key]


def _grow_part(
    text: str, base_dir: str, start: int, count: int, target: str, path: str, usd: bool = False
) -> int:
    """A worker's task: hairs ``start`` … ``start + count − 1`` written as the part
    ``path`` (:func:`write_part`; with ``usd``, the USD part file of a payloads layout,
    :func:`follicle.io.usd_payloads.save_usd_part`); returns their point count."""
    task_setup()
    with on_worker():
        groom = _groom(text, base_dir)
        part = target_chunk(groom, groom.generate(count, start), target)
        if usd:
            from .io.usd_payloads import save_usd_part

            save_usd_part(part, path, target=target)
        else:
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
    chunk: int | None = None,
    target: str = "generic",
    skin: bool = True,
    progress: Callable[[int, int], None] | None = None,
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
    from .curves import HairCurves
    from .io.dispatch import save
    from .pipeline import groom_scene

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

        extras = writer_extras(out, target, groom.guides.curves, groom.mesh if skin else None)
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
    progress: Callable[[int, int], None] | None,
) -> tuple[int, int]:
    """:func:`grow` in the payloads layout: one task per part file, written by the worker
    into a folder beside ``out`` that every worker must reach; the client writes the
    root layer when all are in (the cluster's progress as they come, in any order)."""
    from distributed import as_completed

    from .io.usd_payloads import PART_HAIRS, check_payloads_target, finish_payloads, part_file
    from .pipeline import groom_scene

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
        finish_payloads(out, staged, len(ranges), groom.guides.curves, mesh=mesh, target=target)
    return total, points
