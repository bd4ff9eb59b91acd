"""Reading files with C++ libraries that trust their input, without trusting the file.

usd-core and Alembic are C++: a corrupt or hostile file can make them crash
(segfault), map gigabytes or loop for ever. :func:`read_guarded` therefore reads in a
child process: :mod:`follicle.io.guard_server` runs as a process (``python -I``, with
numpy, the binding and follicle's pure-numpy reader modules only) that stays up and
forks a fresh child per file. The limits are the same for every format
(:func:`limits`): the child caps its address space at ``MEMORY_BASE + MEMORY_PER_BYTE
× size`` (1.5 GiB + 16 × size; the server may have pxr mapped, and Python and pxr
alone take 1.1 GB opening a stage) and is killed after ``SECONDS_BASE + size /
BYTES_PER_SECOND`` of wall time (6 s + 1 s per 16 MB), the size being what the read
loads. A refusal, a crash, the memory limit or the time limit becomes one FormatError
naming the file, and so do parts whose arrays pass what the file's size allows
(:func:`array_room`). Each format checks its container in Python first
(:mod:`follicle.io.usd_guard`, :mod:`follicle.io.alembic_guard`, through
:func:`checking`) and says what it reads.

Cost: the first read of a kind in a process imports its binding in the server (pxr:
0.5-1.5 s, alembic3d: 0.2 s); each read then takes a fork and the read itself, about
50-100 ms for a small file. The arrays come back through an ``.npz`` in a temporary
folder, loaded without pickle.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import select
import signal
import subprocess
import tempfile
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from time import monotonic
from typing import cast

import numpy as np

from ..curves import HairCurves
from ..errors import FileAccessError, FormatError, InputError
from . import guard_server
from .guard_rules import MAX_ANIMATION_POINTS

__all__ = [
    "GuardedReader",
    "checking",
    "read_guarded",
    "limits",
    "array_room",
    "died",
    "curves_from_parts",
]

log = logging.getLogger("follicle")

MEMORY_BASE = 3 << 29  # bytes of address space: the server may have pxr mapped (1.1 GB)
MEMORY_PER_BYTE = 16  # and this many bytes per byte the read loads
SECONDS_BASE = 6.0  # wall time for the child to start and read a small file
BYTES_PER_SECOND = 16 << 20  # and one more second per this many bytes it loads

# The arrays a file may give, as this process will hold them (and then joins, copies
# and grows from them, several times their size, beside the 1.3 GB follicle maps): a
# file's objects may share one array on disk (Alembic and USD store it once), so
# without a bound 2.5 MB asked for gigabytes and ran the 2 GiB of the docs' Bad input
# page out. Files store their arrays whole (or nearly: USD's crate packs integers), and
# reading widens little (a constant width and colour per point: under 3 ×), so 8 × the bytes read is
# room to spare.
ARRAYS_BASE = 32 << 20
ARRAYS_PER_BYTE = 8


def died(
    path: Path, reply: dict | None, stderr: Path, memory: int, seconds: float, tool: str, hint: str
) -> FormatError:
    """The one line for a child that ended without a result: ``tool`` (the library,
    "usd-core") could not read ``path`` and why; ``hint`` ends it."""
    if reply is None:
        why = "its reader process stopped"
    elif reply["timed_out"]:
        why = f"took more than {seconds:.0f} s"
    elif reply["code"] < 0:
        name = signal.Signals(-reply["code"]).name
        why = f"crashed with {name}, or needed more than {memory / 2**30:.1f} GiB"
    else:
        text = stderr.read_text(errors="replace") if stderr.exists() else ""
        last = text.strip().splitlines()[-1:] or ["no output"]
        why = (
            f"failed (exit {reply['code']}: {last[0][:200]}); or needed more than"
            f" {memory / 2**30:.1f} GiB"
        )
    return FormatError(f"{path}: {tool} could not read it ({why}); {hint}")


class _Server:
    """The long-lived :mod:`~follicle.io.guard_server` process that forks one child per
    read (started on first use). It exits when this process closes its stdin, i.e. when this process
    ends."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.proc: subprocess.Popen[bytes] | None = None

    def _start(self) -> subprocess.Popen[bytes]:
        if self.proc is None or self.proc.poll() is not None:
            env = {
                **os.environ,
                "PXR_WORK_THREAD_LIMIT": "1",
                "OPENBLAS_NUM_THREADS": "1",
                "OMP_NUM_THREADS": "1",
                "MALLOC_ARENA_MAX": "2",
            }  # one thread: fork-safe
            # unbuffered: select() then sees every reply line, none hides in a buffer
            self.proc = subprocess.Popen(
                guard_server.command(),
                env=env,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
                bufsize=0,
            )
        return self.proc

    def _stop(self) -> None:
        if self.proc is not None:
            self.proc.kill()
            self.proc.wait()
            self.proc = None

    def _reply(self, proc: subprocess.Popen[bytes], seconds: float) -> dict | None:
        """The server's next ``@@`` line, or None if it ends or goes quiet."""
        assert proc.stdout is not None  # _start opens it with stdout=PIPE
        deadline = monotonic() + seconds
        while (left := deadline - monotonic()) > 0:
            ready, _, _ = select.select([proc.stdout], [], [], left)
            line = proc.stdout.readline() if ready else b""
            if not line:
                return None
            if line.startswith(b"@@"):
                return json.loads(line[2:])
        return None

    def ask(self, request: dict) -> dict | None:
        """Send ``request``; the reply (``code``, ``timed_out``) or None if the server
        failed twice (it is restarted once)."""
        with self.lock:
            for _ in range(2):
                proc = self._start()
                assert proc.stdin is not None  # _start opens it with stdin=PIPE
                try:
                    proc.stdin.write(json.dumps(request).encode() + b"\n")
                    reply = self._reply(proc, request["seconds"] + 60)
                except OSError:
                    reply = None
                if reply is not None:
                    return reply
                self._stop()
            return None


_SERVER = _Server()


def _decode(value: object, arrays: np.lib.npyio.NpzFile) -> object:
    """The parts as the child made them: ``{"@array": name}`` back to the array."""
    if isinstance(value, dict):
        if len(value) == 1 and isinstance(value.get("@array"), str):
            return arrays[value["@array"]]
        return {k: _decode(v, arrays) for k, v in value.items()}
    if isinstance(value, list):
        return [_decode(v, arrays) for v in value]
    return value


def array_room(size: int, animated: bool = False) -> int:
    """Bytes of arrays a file (or the layers a stage loads) of ``size`` bytes may give,
    as the parent holds them: :data:`ARRAYS_BASE` + :data:`ARRAYS_PER_BYTE` × size; and
    with ``animated`` (a skin animation, whose frames may be one rest pose moved by
    Xforms: a few bytes each on disk) the float64 frames it may hold beside, at most
    ``MAX_ANIMATION_POINTS``."""
    frames = 3 * 8 * MAX_ANIMATION_POINTS if animated else 0
    return ARRAYS_BASE + ARRAYS_PER_BYTE * size + frames


def limits(size: int) -> tuple[int, float]:
    """(bytes of address space, seconds) the child may use reading ``size`` bytes."""
    return MEMORY_BASE + MEMORY_PER_BYTE * size, SECONDS_BASE + size / BYTES_PER_SECOND


@contextlib.contextmanager
def checking(path: Path) -> Iterator[None]:
    """A format's checks of ``path``'s container, an OSError while they read it becoming
    one FileAccessError naming the file."""
    try:
        yield
    except OSError as exc:
        raise FileAccessError(f"{path}: cannot be read ({exc.strerror or exc})") from None


def read_guarded(
    kind: str,
    path: Path,
    size: int,
    tool: str,
    hint: str,
    *,
    animated: bool = False,
    **options: object,
) -> list[dict]:
    """The parts the reader of ``kind`` (see :data:`follicle.io.guard_server.READERS`)
    makes of ``path``, read in a child process under the :func:`limits` of ``size``
    bytes (what the read loads: the file, or the layers a stage loads), refused when
    their arrays pass :func:`array_room` (``animated``: a skin animation's frames
    allowed beside); ``animated`` and ``options`` go to the reader. FormatError naming
    the file (``tool`` could not read it; ``hint``) on any failure."""
    memory, seconds = limits(size)
    with tempfile.TemporaryDirectory(prefix="follicle-read-") as folder:
        reply = _SERVER.ask(
            {
                "kind": kind,
                "source": os.path.abspath(path),
                "shown": str(path),
                "out": folder,
                "memory": memory,
                "seconds": seconds,
                "arrays": array_room(size, animated),
                "tool": tool,
                "hint": hint,
                "animated": animated,
                **options,
            }
        )
        result_file = Path(folder, "result.json")
        if reply is None or not result_file.exists():
            raise died(path, reply, Path(folder, "stderr.txt"), memory, seconds, tool, hint)
        result = json.loads(result_file.read_text())
        if "refused" in result:
            raise FormatError(result["refused"])
        with np.load(Path(folder, "arrays.npz"), allow_pickle=False) as arrays:
            # the child writes "parts" as a list of dicts; _decode keeps that shape
            return cast("list[dict]", _decode(result["parts"], arrays))


@dataclass(frozen=True)
class GuardedReader:
    """A format's reads in the guarded child: its reader kinds for curves and meshes
    (:data:`follicle.io.guard_server.READERS`), the library its errors name (``tool``),
    the ``hint`` they end with, and ``size``: the bytes a read of a path loads (what
    the limits follow)."""

    curves_kind: str
    mesh_kind: str
    tool: str
    hint: str
    size: Callable[[Path], int]

    def curves(
        self, path: Path, time: float | None, guides: bool, stored: bool = False
    ) -> list[dict]:
        """The chosen curves parts of ``path`` (dicts of ``where``, ``points``,
        ``offsets``, ``point_data`` and ``curve_data`` arrays; ``time``, ``guides`` and
        ``stored``, the file's own names, as the format's reader takes them), read in a
        child process; FormatError naming the file on any failure."""
        return read_guarded(
            self.curves_kind,
            path,
            self.size(path),
            self.tool,
            self.hint,
            time=time,
            guides=guides,
            stored=stored,
        )

    def meshes(self, path: Path, animated: bool = False) -> list[dict]:
        """The mesh parts of ``path`` (``animated``: the points of the first at every
        sample), read as :meth:`curves` reads curves."""
        size = self.size(path)
        return read_guarded(self.mesh_kind, path, size, self.tool, self.hint, animated=animated)


# ------------------------------------------------------------------ curves from parts
def _widened(data: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """int32 arrays as int64, follicle's integer type: writers store ids as int32 where
    the tools that open the file read no int64 (:mod:`follicle.io.targets`)."""
    return {k: v.astype(np.int64) if v.dtype == np.int32 else v for k, v in data.items()}


# another tool's name -> follicle's, per point and per curve: Houdini's (what the
# houdini target writes, follicle.io.targets), taken when follicle's is not there
_OURS_POINT = {"Alpha": "opacity"}
_OURS_CURVE = {"id": "hair_id"}


def _ours(
    point_data: dict[str, np.ndarray], curve_data: dict[str, np.ndarray]
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """``point_data`` and ``curve_data`` with Houdini's ``Alpha`` (per point) and
    ``id`` (per curve) under follicle's names, opacity and hair_id, where those are
    not there already: a file written for Houdini reads back as follicle wrote it."""
    out = []
    for data, names in ((point_data, _OURS_POINT), (curve_data, _OURS_CURVE)):
        data = dict(data)
        for theirs, ours in names.items():
            if theirs in data and ours not in data:
                data[ours] = data.pop(theirs)
        out.append(data)
    return out[0], out[1]


def _curves(part: dict, stored: bool = False) -> HairCurves:
    """One curves part from the child (``where``, ``points``, ``offsets``, ``point_data``,
    ``curve_data``) as HairCurves (FormatError if they are not valid curves), integers
    as int64. Curves of one point are not hair (and Unity refuses a whole file for one):
    they are left out with a warning naming the part."""
    points, offsets = part["points"], np.asarray(part["offsets"])
    point_data, curve_data = part["point_data"], part["curve_data"]
    if not stored:
        point_data, curve_data = _widened(point_data), _widened(curve_data)
        point_data, curve_data = _ours(point_data, curve_data)
    counts = np.diff(offsets)
    if offsets.ndim == 1 and len(offsets) and (counts == 1).any():
        log.warning(
            "%s: %d curve(s) with fewer than 2 points left out",
            part["where"],
            int((counts == 1).sum()),
        )
        keep, rows = counts != 1, np.repeat(counts != 1, counts)
        points = points[rows]
        point_data = {k: v[rows] for k, v in point_data.items()}
        curve_data = {k: v[keep] for k, v in curve_data.items()}
        offsets = np.concatenate([[0], np.cumsum(counts[keep])])
    try:
        return HairCurves(points, offsets, point_data, curve_data)
    except InputError as exc:
        raise FormatError(f"{part['where']}: {exc}") from None


# what a curves object without an attribute gets when joined to others that have it:
# zeros, as Blender's Join fills them, but opacity 1 (a file without opacity is opaque;
# zero would hide that object's hair)
_FILL = {"opacity": 1.0}


def _filled(
    curves: list[HairCurves], get: Callable[[HairCurves], dict], rows: Callable[[HairCurves], int]
) -> tuple[list[dict], dict[str, list[int]]]:
    """Each part's attributes (``get``: point or curve data) with those some parts lack
    added to them (:data:`_FILL`, else zeros) where all that have one agree on its row
    shape, and the parts that lacked each; attributes of disagreeing shapes
    are left out of every part."""
    names = set().union(*(set(get(p)) for p in curves))
    out: list[dict] = [{} for _ in curves]
    missing: dict[str, list[int]] = {}
    for name in sorted(names):
        have = [get(p)[name] for p in curves if name in get(p)]
        if len({a.shape[1:] for a in have}) != 1:
            continue
        for i, p in enumerate(curves):
            if name in get(p):
                out[i][name] = get(p)[name]
            else:
                fill = _FILL.get(name, 0)
                out[i][name] = np.full((rows(p), *have[0].shape[1:]), fill, have[0].dtype)
                missing.setdefault(name, []).append(i)
    return out, missing


def curves_from_parts(parts: list[dict], source: Path, stored: bool = False) -> HairCurves:
    """Curves parts (prims, objects) joined in order. An attribute some parts lack is
    kept, filled on them as Blender's Join does (zeros; opacity 1), with one warning
    naming the parts without it; one whose row shape differs between parts is dropped
    with a warning. ``stored``: integers kept as the file stores them (for `follicle
    check`)."""
    curves = [_curves(p, stored) for p in parts]
    if len(curves) == 1:
        return curves[0]
    point_data, pmissing = _filled(curves, lambda p: p.point_data, lambda p: len(p.points))
    curve_data, cmissing = _filled(curves, lambda p: p.curve_data, lambda p: p.curve_count)
    kept = set(point_data[0]) | set(curve_data[0])
    dropped = set().union(*(set(p.point_data) | set(p.curve_data) for p in curves)) - kept
    if dropped:
        log.warning(
            "%s: attributes of different shapes on different curves objects were dropped: %s",
            source,
            ", ".join(sorted(dropped)),
        )
    without: dict[int, list[str]] = {}
    for name, where in sorted({**pmissing, **cmissing}.items()):
        for i in where:
            without.setdefault(i, []).append(name)
    if without:
        log.warning(
            "%s: attributes not on every curves object were filled (zeros, opacity 1) on %s",
            source,
            "; ".join(f"{parts[i]['where']} (no {', '.join(n)})" for i, n in without.items()),
        )
    return HairCurves.concatenate(
        [
            HairCurves(p.points, p.offsets, pd, cd)
            for p, pd, cd in zip(curves, point_data, curve_data, strict=True)
        ]
    )
