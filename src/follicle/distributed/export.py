"""Many curves files converted, each as `follicle export IN -o OUT` converts one: here one
after another, or one Dask task per file (`follicle export IN... -o FOLDER --to SUFFIX
--scheduler …`) — a groom dataset to .usdc for Unreal, say.

Every file goes through :func:`convert`, the single-file export too: read by
:func:`~follicle.io.dispatch.load_curves`, written by :func:`~follicle.io.dispatch.save`
with the target tool's names, types and units. A file's bytes depend on the file read
and the target alone, so they are the same whichever way, and wherever, it was made.

**Files.** Each file is converted into the job's hidden folder beside its output
(:func:`~follicle.atomic.pending_folders`, :func:`~follicle.atomic.deliver`), and this
process renames it into place in input order, as soon as it and every file before it
are converted. So an output is whole or absent; a retried or speculative twin of a task
only replaces its own copy in the job folder; and when a file fails (unreadable, say),
the files before it stay, whole, and neither it nor any after it is written. The job
folder goes when the job ends, fails or is stopped (SIGINT/SIGTERM: local workers are
stopped first), and with it whatever later tasks had converted.

**On a cluster** (``scheduler``, see :func:`follicle.distributed.cluster.connect`) the paths a
worker is given are absolute, and every worker must reach them: the inputs and the
output folders (a local disk for ``local:N``, a shared one for a cluster).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from ..atomic import deliver, pending_folders
from ..errors import FollicleError, FormatError, InputError
from ..inputs import is_url
from ..io.dispatch import WRITERS, load_curves, save
from ..io.sim_cache import is_cache
from ..io.targets import NAMED_FORMATS, check_named, get_target
from ..progress import Progress

__all__ = ["convert", "export_files"]

Call = tuple[str, str, str, str]  # (source, output, target, the output folder's pending folder)


def convert(
    source: str | os.PathLike[str], out: str | os.PathLike[str], target: str = "generic"
) -> tuple[int, int]:
    """Read the curves file ``source`` and write it to ``out`` in the format its extension
    names, for USD and Alembic with the attribute names, types and units of the
    ``target`` tool (the other formats hold no names). ``out`` is written atomically:
    whole, or left as it was. Returns (hairs, points)."""
    curves = load_curves(source)
    named = Path(out).suffix.lower() in NAMED_FORMATS
    save(curves, out, **({"target": target} if named else {}))
    return curves.curve_count, curves.point_count


def export_files(
    sources: Sequence[str | os.PathLike[str]],
    outs: Sequence[str | os.PathLike[str]],
    scheduler: str | None = None,
    target: str = "generic",
    progress: Progress | None = None,
) -> list[tuple[int, int]]:
    """Convert each of ``sources`` (curves files) to the matching entry of ``outs`` as
    :func:`convert` does: one after another here, or with ``scheduler`` one Dask task per
    file, the same bytes either way. Each output is renamed into place once it and those
    before it are converted (see the module): when a file fails, those before it stay,
    and it and those after it are not written. Returns (hairs, points) per file, in
    order; ``progress(done, total)`` counts files.

    InputError, before anything is read, for outputs that are not one per source and
    each its own, an output that is one of the sources, and a built-in mesh; FormatError for
    an output format follicle does not write, or ``target`` for one without names. A
    simulation cache among the sources is an InputError when its turn comes (a cache
    exports alone: `follicle export CACHE -o anim.usdc`)."""
    pairs = _checked(sources, outs, target)
    done: list[tuple[int, int]] = []
    folders = list(dict.fromkeys(out.parent for _, out in pairs))
    with pending_folders(folders) as pending, _runner(scheduler) as run:  # workers stop first
        calls = [(str(src), str(out), target, pending[out.parent]) for src, out in pairs]
        if progress is not None:
            progress(0, len(calls))
        try:
            for (_, out, _, folder), counts in zip(calls, run(calls), strict=True):
                os.replace(Path(folder) / Path(out).name, out)
                done.append(counts)
                if progress is not None:
                    progress(len(done), len(calls))
        except FollicleError as exc:
            raise type(exc)(
                f"{exc} ({len(done)} of {len(calls)} files converted before it; it and the"
                " files after it not written)"
            ) from None
    return done


def _checked(
    sources: Sequence[str | os.PathLike[str]],
    outs: Sequence[str | os.PathLike[str]],
    target: str,
) -> list[tuple[str, Path]]:
    """(source, output) pairs as absolute paths (a URL source as given), checked as
    :func:`export_files` says."""
    get_target(target)
    if len(outs) != len(sources):
        raise InputError(f"outs: expected one output per source ({len(sources)}, not {len(outs)})")
    for source in sources:
        if os.fspath(source).startswith("builtin:"):
            raise InputError(
                f"{source}: a built-in mesh exports alone, as a mesh file"
                f" (`follicle export {source} -o head.obj`)"
            )
    read = {Path(source).resolve(): Path(source) for source in sources if not is_url(source)}
    pairs: list[tuple[str, Path]] = []
    written: dict[Path, Path] = {}
    for source, out in zip(sources, outs, strict=True):
        src = source if is_url(source) else Path(source).resolve()  # a URL as given
        dst = Path(out).resolve()
        suffix = dst.suffix.lower()
        if suffix not in WRITERS:
            raise FormatError(
                f"{out}: cannot write '{suffix or 'no extension'}' curves files; use one of"
                f" {', '.join(sorted(WRITERS))}"
            )
        check_named(str(out), suffix, target)
        if dst in written:
            raise InputError(
                f"{dst}: both {written[dst]} and {source} would be converted to it; give each"
                " file its own output"
            )
        if dst in read:
            which = "its own input" if dst == src else f"the input {read[dst]}"
            raise InputError(
                f"{out}: the output of {source} would replace {which}; give another folder"
                " or format"
            )
        written[dst] = Path(source)
        pairs.append((str(src), dst))
    return pairs


@contextlib.contextmanager
def _runner(scheduler: str | None) -> Iterator[Callable[[list[Call]], Iterator[tuple[int, int]]]]:
    """For the ``with`` block, a function that converts calls and yields their counts in
    order: here one after another, or on the Dask cluster ``scheduler`` (connected on
    entering, closed on leaving), all submitted at once."""
    if scheduler is None:
        yield lambda calls: (_stage(*call) for call in calls)
        return
    from .cluster import cluster, in_order, submit_all

    with cluster(scheduler) as client:
        yield lambda calls: in_order(submit_all(client, _export_task, calls, "export"))


def _stage(source: str, out: str, target: str, pending: str) -> tuple[int, int]:
    """``source`` converted into the ``pending`` folder under its output's name, where
    :func:`export_files` takes it from (a twin of this call replaces it, the same
    bytes). Returns (hairs, points)."""
    if is_cache(source):
        raise InputError(
            f"{source}: a simulation cache exports alone, to animated USD or Alembic"
            f" (`follicle export {source} -o anim.usdc`)"
        )
    counts: list[tuple[int, int]] = []
    staged = Path(pending) / Path(out).name
    deliver(pending, staged, lambda path: counts.append(convert(source, path, target)))
    return counts[0]


def _export_task(source: str, out: str, target: str, pending: str) -> tuple[int, int]:
    """A Dask worker's task: :func:`_stage`, its errors naming the worker."""
    from .cluster import on_worker, task_setup

    task_setup()
    with on_worker():
        return _stage(source, out, target, pending)
