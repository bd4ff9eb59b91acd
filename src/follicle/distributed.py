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

import logging
import os
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

from .atomic import temporary_folder
from .errors import ConfigError
from .groom.generator import CHUNK, Groom
from .io.targets import NAMED_FORMATS
from .scene import Scene, scene_from_toml, scene_to_toml
from .validate import whole

__all__ = ["connect", "grow", "target_chunk"]

log = logging.getLogger("follicle")

CONNECT_SECONDS = 10  # how long a scheduler's address may take to answer
_GROOMS: dict[tuple[str, str], Groom] = {}  # per worker process: the scenes it has built


def connect(scheduler: str) -> object:
    """A ``distributed.Client`` for ``scheduler``: ``"local:N"`` starts a LocalCluster
    of N single-threaded worker processes here (closed with the client), anything else
    is a scheduler's address (``tcp://host:8786``). ConfigError naming ``--scheduler``
    when Dask is not installed, N is not a whole number ≥ 1, or the address does not
    answer within CONNECT_SECONDS."""
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
        cluster = LocalCluster(
            n_workers=int(n),
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        )
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
    """A worker's task: hairs ``start`` … ``start + count − 1`` written to ``path`` (.npz,
    through a temporary name); returns their point count."""
    from .io.dispatch import save

    groom = _groom(text, base_dir)
    part = target_chunk(groom, groom.generate(count, start), target)
    tmp = f"{path}.{os.getpid()}.tmp.npz"
    save(part, tmp)
    os.replace(tmp, path)
    return part.point_count


def _rechunked(paths: list[Path], size: int) -> Iterator[object]:
    """The parts at ``paths`` in order, as chunks of ``size`` hairs (the last shorter)."""
    from .curves import HairCurves
    from .io.dispatch import load_curves

    held: list[HairCurves] = []
    count = 0
    for path in paths:
        part = load_curves(path)
        held.append(part)
        count += part.curve_count
        while count >= size:
            whole_ = HairCurves.concatenate(held) if len(held) > 1 else held[0]
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
    (hairs, points); ``progress(done, total)`` is called as parts arrive."""
    from .pipeline import groom_scene

    chunk = whole(chunk, "chunk", 1)
    out = Path(out)
    groom = groom_scene(scene)  # here too: the guides and skin of the file, and errors now
    client = connect(scheduler)
    try:
        with temporary_folder(out, "parts") as parts_dir:
            return _grow_on(client, groom, scene, out, parts_dir, chunk, target, skin, progress)
    finally:
        close(client)


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
    """:func:`grow`'s work on a connected ``client``, parts in ``parts_dir``."""
    from distributed import as_completed

    from .io.dispatch import save

    total = groom.params.count
    text = scene_to_toml(scene, comments=False)
    ranges = [(a, min(chunk, total - a)) for a in range(0, total, chunk)]
    paths = [parts_dir / f"part_{a:012d}.npz" for a, _ in ranges]
    run = uuid.uuid4().hex
    futures = [
        client.submit(
            _grow_part,
            text,
            str(scene.base_dir),
            a,
            n,
            target,
            str(p),
            key=f"follicle-grow-{run}-{a}",  # a retry keeps its key and its part
        )
        for (a, n), p in zip(ranges, paths, strict=True)
    ]
    done = points = 0
    for future in as_completed(futures):
        points += future.result()
        done += 1
        if progress is not None:
            progress(min(done * chunk, total), total)
    extras = {}
    if out.suffix.lower() in NAMED_FORMATS:  # as `follicle grow` writes them
        extras = {"target": target, "guides": groom.guides.curves}
        extras["mesh"] = groom.mesh if skin else None
    chunks = _rechunked(paths, CHUNK) if total else iter([groom.generate(count=0)])
    if out.suffix.lower() == ".npz":
        from .curves import HairCurves

        save(HairCurves.concatenate(list(chunks)), out)
    else:
        save(chunks, out, **extras)
    return total, points
