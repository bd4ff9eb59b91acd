"""The guarded reading server: C++ file readers (usd-core, Alembic) run in forked children.

:mod:`follicle.io.guard` starts it as a process (:func:`command`). A reader
module may import numpy, its C++ binding and follicle's pure-numpy modules, nothing
heavier (numba, the renderer: memory the children would carry for nothing);
``import follicle`` itself loads none of them (``tests/test_public_api.py``).

Each request (one JSON line on stdin) names a ``kind``; :data:`READERS` maps it to a
module whose ``read_request(request)`` returns (or yields) parts, dicts of arrays
(nested dicts, lists, strings and numbers allowed), or raises
:class:`~follicle.io.guard_rules.Refused`. The
server imports that module once (and calls its ``prepare()``, if any, so plugins load
before any fork), then forks a child per request, which caps its address space at
``request["memory"]`` bytes, reads, refuses parts whose arrays pass
``request["arrays"]`` bytes (:func:`_within`), and writes ``OUT/arrays.npz`` plus
``OUT/result.json``: ``{"parts": manifest}`` (the parts with every array replaced by
``{"@array": name in the npz}``) or ``{"refused": message}``. The server waits up to
``request["seconds"]`` for the child (then kills it) and answers one ``@@``-prefixed
JSON line: the child's exit ``code`` (negative: the signal that ended it) and
``timed_out``.

The same command, given a name of :data:`SCRIPTS` (``command("abc-sink")``), serves that
module instead: :mod:`follicle.io.alembic_sink`, alembic3d
writing an archive.
"""

from __future__ import annotations

import importlib
import json
import os
import resource
import select
import signal
import sys
import traceback
from collections.abc import Iterable, Iterator
from pathlib import Path
from types import ModuleType

import numpy as np

from .guard_rules import Refused

__all__ = ["READERS", "serve"]

# request kind -> module serving it with read_request(request) -> Iterable[dict]
READERS = {
    "usd-curves": "follicle.io.usd_stage",
    "usd-mesh": "follicle.io.usd_mesh",
    "abc-curves": "follicle.io.alembic_archive",
    "abc-mesh": "follicle.io.alembic_archive",
}


def _encode(value: object, arrays: dict[str, np.ndarray]) -> object:
    """``value`` for JSON, its arrays moved into ``arrays`` and replaced by their names."""
    if isinstance(value, np.ndarray):
        key = f"a{len(arrays)}"
        arrays[key] = np.ascontiguousarray(value)
        return {"@array": key}
    if isinstance(value, dict):
        return {k: _encode(v, arrays) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_encode(v, arrays) for v in value]
    return value


def _save(parts: list[dict], out: Path) -> dict:
    """Write the parts' arrays to ``out/arrays.npz``; the result naming them."""
    arrays: dict[str, np.ndarray] = {}
    manifest = _encode(parts, arrays)
    np.savez(out / "arrays.npz", allow_pickle=True, **arrays)  # numpy's default, named for mypy
    return {"parts": manifest}


def _arrays(value: object) -> Iterator[np.ndarray]:
    """Every array in ``value`` (parts as readers make them: dicts, lists, arrays)."""
    if isinstance(value, np.ndarray):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _arrays(item)
    elif isinstance(value, (list, tuple)):
        for item in value:
            yield from _arrays(item)


def _within(parts: Iterable[dict], room: int, source: str, tool: str) -> list[dict]:
    """The parts, taken one at a time, refused as soon as their arrays, each counted
    whole as the parent will hold it, pass ``room`` bytes (what the file's size
    allows): a file whose objects share one array on disk (Alembic and USD deduplicate)
    reads small here, as views, but is a copy per object once written out and joined,
    so a few megabytes could fill the parent's memory. A reader that yields its parts
    is stopped at the first one past the room, before the child fills its own."""
    kept, total = [], 0
    for part in parts:
        total += sum(a.nbytes for a in _arrays(part))
        if total > room:
            raise Refused(
                f"{source}: its objects hold more than the {room / 2**20:,.0f} MiB of arrays"
                f" a file of its size may give once read ({tool} stores an array that many"
                " objects share once); split it, or join its objects in the tool that made it"
            )
        kept.append(part)
    return kept


def _read_request(request: dict, reader: ModuleType) -> None:
    """Read ``request["source"]`` into ``request["out"]`` (see the module), with the
    address space capped at ``request["memory"]`` bytes first."""
    source, out = request["shown"], Path(request["out"])
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = request["memory"] if hard == resource.RLIM_INFINITY else min(request["memory"], hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        parts = _within(reader.read_request(request), request["arrays"], source, request["tool"])
        result = _save(parts, out)
    except Refused as exc:
        result = {"refused": str(exc)}
    except MemoryError:
        result = {
            "refused": f"{source}: {request['tool']} needed more than {cap / 2**30:.1f}"
            f" GiB reading it; {request['hint']}"
        }
    _result(out, result)


def _result(out: Path, result: dict) -> None:
    """Write ``out/result.json`` whole or not at all."""
    tmp = out / "result.json.tmp"
    tmp.write_text(json.dumps(result))
    os.replace(tmp, out / "result.json")


def _child(request: dict, reader: ModuleType) -> None:
    """In the forked child: output to ``OUT/stderr.txt``, default signals, then read;
    never returns."""
    log = os.open(Path(request["out"], "stderr.txt"), os.O_WRONLY | os.O_CREAT, 0o600)
    os.dup2(log, 1)
    os.dup2(log, 2)
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    code = 1
    try:
        _read_request(request, reader)
        code = 0
    except BaseException:  # noqa: BLE001 - the child reports every failure, then exits
        traceback.print_exc()
    finally:
        sys.stdout.flush()
        os._exit(code)


def _wait(pid: int, seconds: float) -> dict:
    """Wait up to ``seconds`` for child ``pid`` (then kill it): its exit code (negative:
    the signal that ended it) and whether it ran out of time."""
    fd = os.pidfd_open(pid)
    try:
        ready, _, _ = select.select([fd], [], [], seconds)
    finally:
        os.close(fd)
    if not ready:
        os.kill(pid, signal.SIGKILL)
    _, status = os.waitpid(pid, 0)
    return {"code": os.waitstatus_to_exitcode(status), "timed_out": not ready}


def _reader(kind: str, loaded: dict[str, ModuleType]) -> ModuleType:
    """The module serving ``kind``, imported (and prepared) on first use."""
    if kind not in loaded:
        module = importlib.import_module(READERS[kind])
        prepare = getattr(module, "prepare", None)
        if prepare is not None:
            prepare()
        loaded[kind] = module
    return loaded[kind]


def serve() -> None:
    """The reading server: one JSON request a line on stdin (``kind``, ``source``,
    ``shown``, ``out``, ``memory``, ``seconds``, ``tool``, ``hint`` and the reader's own
    options), each read in a child forked from this single-threaded process (the
    reader's binding already imported, so a read starts in milliseconds); one
    ``@@``-prefixed JSON reply a line on stdout. Ends when stdin closes (its parent is
    gone)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    loaded: dict[str, ModuleType] = {}
    for line in sys.stdin:
        request = json.loads(line)
        try:
            reader = _reader(request["kind"], loaded)
        except ImportError as exc:  # the binding is missing or broken: say so, keep serving
            _result(
                Path(request["out"]),
                {
                    "refused": f"{request['shown']}: {request['tool']}"
                    f" cannot be imported ({exc}); reinstall follicle's"
                    " dependencies"
                },
            )
            reply = {"code": 0, "timed_out": False}
        else:
            pid = os.fork()
            if pid == 0:
                _child(request, reader)
            reply = _wait(pid, request["seconds"])
        sys.stdout.write("@@" + json.dumps(reply) + "\n")
        sys.stdout.flush()


# what command(NAME) serves: reading, or writing Alembic
SCRIPTS = {"read": "follicle.io.guard_server", "abc-sink": "follicle.io.alembic_sink"}


def command(name: str = "read") -> list[str]:
    """The command line of a server for ``name`` (:data:`SCRIPTS`): ``python -I -B -c``,
    isolated from the environment and writing no bytecode into the install from a child
    under limits, with the folder holding ``follicle/`` put first on the path (``-I``
    leaves ``PYTHONPATH`` and the working folder off it), then the module's ``serve()``.
    ``import follicle`` loads only its errors, so the children carry nothing heavier
    than the readers."""
    root = str(Path(__file__).resolve().parents[2])
    code = (
        f"import sys; sys.path.insert(0, {root!r}); import importlib;"
        f" importlib.import_module({SCRIPTS[name]!r}).serve()"
    )
    return [sys.executable, "-I", "-B", "-c", code]
