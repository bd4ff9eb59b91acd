"""The cluster's plumbing that growing, simulating, rendering, exporting and batches share.

:func:`connect` makes a Dask client (``"local:N"``: a LocalCluster of N worker processes
on this machine; or a scheduler's address), :func:`cluster` holds one for a job and
stops local workers first on leaving; :func:`submit_all`, :func:`in_order` and
:func:`streamed` send tasks and take their results in order with a bounded number run
ahead; :func:`task_setup` gives local workers their share of the cores for numba and
:func:`on_worker` names the worker in an error. A grow's parts travel as folders of
.npy files (:func:`write_part`, :func:`read_part`) in a :func:`parts_folder`, and each
worker process builds a scene's groom once (:func:`worker_groom`).
"""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import sys
import uuid
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, TypeVar, cast

from ..atomic import temporary_folder
from ..errors import ConfigError, FileAccessError, FollicleError
from ..groom.generator import Groom
from ..inputs import base_folder
from ..scene import scene_from_toml

__all__ = [
    "connect",
    "close",
    "cluster",
    "submit_all",
    "in_order",
    "streamed",
    "workers_of",
    "task_setup",
    "on_worker",
    "write_part",
    "read_part",
    "parts_folder",
    "worker_groom",
]

R = TypeVar("R")
R_co = TypeVar("R_co", covariant=True)

if TYPE_CHECKING:
    from ..curves import HairCurves


class Future(Protocol[R_co]):
    """What follicle uses of a ``distributed.Future``: its task's key, and its result,
    waited for."""

    key: str

    def result(self) -> R_co: ...


class DaskClient(Protocol):
    """What follicle uses of a ``distributed.Client``: tasks submitted under a key, the
    workers' threads, closing; typed so a checker sees what a task returns."""

    dashboard_link: str

    def submit(self, fn: Callable[..., R], *args: Any, key: str) -> Future[R]: ...

    def nthreads(self) -> dict[str, int]: ...

    def close(self) -> object: ...


log = logging.getLogger("follicle")

_QUIET_TRACKER = "ignore:resource_tracker:UserWarning"
CONNECT_SECONDS = 10  # how long a scheduler's address may take to answer
MAX_WORKERS_PER_CORE = 4  # local:N at most this many worker processes a core
AHEAD = 3  # grow tasks in flight per worker thread, ahead of the client's writing
_LOCAL_CLUSTERS: dict[int, Any] = {}  # the LocalCluster connect started, by its client's id
_GROOMS: dict[tuple[str, str], Groom] = {}  # per worker process: the scenes it has built


def connect(scheduler: str) -> DaskClient:
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
        local = Client(cluster)
        _LOCAL_CLUSTERS[id(local)] = cluster  # closed with the client (close())
        log.info("Dask: %d local workers, dashboard %s", int(n), local.dashboard_link)
        return cast(DaskClient, local)
    _check_answers(scheduler)
    try:
        remote = Client(scheduler, timeout=CONNECT_SECONDS)
        log.info("Dask: scheduler %s, dashboard %s", scheduler, remote.dashboard_link)
        return cast(DaskClient, remote)
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


def close(client: DaskClient) -> None:
    """Close ``client`` and the LocalCluster :func:`connect` started for it, if any."""
    cluster = _LOCAL_CLUSTERS.pop(id(client), None)
    client.close()
    if cluster is not None:
        cluster.close()


@contextmanager
def cluster(scheduler: str) -> Iterator[DaskClient]:
    """:func:`connect` to ``scheduler`` for the ``with`` block, closed on leaving."""
    client = connect(scheduler)
    try:
        yield client
    finally:
        close(client)


def submit_all(
    client: DaskClient, fn: Callable[..., R], calls: Sequence[tuple], name: str
) -> list[Future[R]]:
    """One Dask task ``fn(*call)`` per call, keyed ``follicle-NAME-RUN-I``: a retried or
    speculative task keeps its key, so the scheduler never holds two results for one
    call (``fn`` writes its outputs atomically, under names fixed by its arguments)."""
    run = uuid.uuid4().hex
    return [
        client.submit(fn, *call, key=f"follicle-{name}-{run}-{i}") for i, call in enumerate(calls)
    ]


def in_order(futures: list[Future[R]]) -> Iterator[R]:
    """The results of ``futures`` in their order, each as soon as it and those before it
    are done (later tasks keep running meanwhile); a finished future is dropped from
    the list, so its result is not held longer than the caller holds it."""
    held: list[Future[R] | None] = list(futures)
    futures.clear()  # the caller's list no longer holds them either
    for i, future in enumerate(held):
        assert future is not None
        result = future.result()
        held[i] = None
        yield result


def streamed(
    client: DaskClient, fn: Callable[..., R], calls: Sequence[tuple], name: str, ahead: int
) -> Iterator[R]:
    """The results of ``fn(*call)`` for each call, in order, computed as Dask tasks (keyed
    as :func:`submit_all` keys them) with at most ``ahead`` of them submitted and not yet
    handed over: the workers run ahead of the caller by that much and no more, so their
    results, held in their memory until fetched, stay bounded whatever the job's size.
    The first ``ahead`` tasks are submitted at once, before the first result is asked
    for, so the caller can do its own work while they run."""
    run = uuid.uuid4().hex

    def submit(i: int) -> Future[R]:
        return client.submit(fn, *calls[i], key=f"follicle-{name}-{run}-{i}")

    pending = deque(submit(i) for i in range(min(ahead, len(calls))))

    def results() -> Iterator[R]:
        for i in range(len(pending), len(calls) + len(pending)):
            result = pending.popleft().result()
            if i < len(calls):
                pending.append(submit(i))
            yield result

    return results()


def workers_of(client: DaskClient) -> int:
    """How many tasks ``client``'s cluster runs at once (its workers' threads), at least 1."""
    return max(1, sum(client.nthreads().values()))


def task_setup() -> int:
    """Make the calling thread a Dask task's: numba threads set to the worker process's
    share (``NUMBA_NUM_THREADS``, which :func:`connect` sets per local worker) split
    between the worker's task threads, so that the workers of one machine do not ask
    for more threads than it has cores. Returns the numba thread count."""
    import numba

    from distributed import get_worker

    from ..kernels.cache import config

    threads = max(1, config.NUMBA_NUM_THREADS // get_worker().state.nthreads)
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


def write_part(curves: HairCurves, path: str | os.PathLike[str]) -> None:
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


def read_part(path: str | os.PathLike[str]) -> HairCurves:
    """The HairCurves of a part :func:`write_part` wrote, read into memory (mapping it
    saves the copy but pays as much in page faults, measured)."""
    import numpy as np

    from ..curves import HairCurves

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


def worker_groom(text: str, base_dir: str) -> Groom:
    """The groom of the scene ``text`` (relative paths from ``base_dir``), built once per
    worker process."""
    from ..pipeline import groom_scene

    key = (text, base_dir)
    if key not in _GROOMS:
        _GROOMS.clear()  # one scene at a time: a worker keeps no more than one groom
        _GROOMS[key] = groom_scene(scene_from_toml(text, "scene", base_folder(base_dir)))
    return _GROOMS[key]
