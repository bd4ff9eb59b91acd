"""Running follicle the way hostile input meets it: in a child process under the limits
the README promises (2 GiB of address space, 30 s), and checking the one clean refusal.

``run_cli`` runs the ``follicle`` command (piped, or under a pseudo-terminal with
``tty=True``); ``run_api`` runs a Python snippet and reports the exception it ended in.
``assert_cli_refused`` / ``assert_api_refused`` check what the README promises of bad
input: exit 2 with one ``error:`` line naming the file or key (CLI), or a FollicleError
subclass (Python), no traceback, within the limits, and no file left behind.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import pty
import re
import resource
import select
import signal
import struct
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

from hypothesis import strategies as st

MEMORY = 2 << 30  # bytes of address space a child may map (RLIMIT_AS)
SECONDS = 30.0  # wall time a child may take
FOLLICLE = [sys.executable, "-m", "follicle.cli"]


@dataclass
class Outcome:
    """What a child process did: exit code (negative: killed by that signal), its output,
    and how long it took; ``timed_out`` when it was killed at the time limit; ``tty``
    when it ran on a pseudo-terminal (its one output is ``stdout``, colours and all)."""

    rc: int
    stdout: str
    stderr: str
    seconds: float
    timed_out: bool
    tty: bool = False


def _limits(memory: int, file_size: int | None = None) -> None:  # in the child, before exec
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    if file_size is not None:  # a full disk: writes past it fail (SIGXFSZ left as it is)
        resource.setrlimit(resource.RLIMIT_FSIZE, (file_size, file_size))
    os.setsid()  # its own process group, so a time-out kills every process it started


def _env(extra: dict[str, str] | None) -> dict[str, str]:
    env = {**os.environ, "PYTHONFAULTHANDLER": "0", "COLUMNS": "120", "TERM": "xterm-256color"}
    env.pop("NO_COLOR", None)
    return {**env, **(extra or {})}


def _kill(proc: subprocess.Popen) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()


def run(
    argv: list[str],
    cwd: str | os.PathLike[str],
    *,
    tty: bool = False,
    timeout: float = SECONDS,
    memory: int = MEMORY,
    stdin: bytes | None = None,
    env: dict[str, str] | None = None,
    file_size: int | None = None,
) -> Outcome:
    """Run ``argv`` under the limits. With ``tty`` its stdin, stdout and stderr are one
    pseudo-terminal (what a person's terminal is) and ``stdout`` holds all it printed.
    ``file_size`` (bytes) is a file-size limit (RLIMIT_FSIZE), a disk that fills there:
    SIGXFSZ keeps its default action, so a command that does not set it aside dies of
    it rather than reporting the failed write."""
    start = time.perf_counter()
    if not tty:
        proc = subprocess.Popen(
            argv,
            cwd=cwd,
            env=_env(env),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            preexec_fn=lambda: _limits(memory, file_size),
        )
        try:
            out, err = proc.communicate(stdin or b"", timeout=timeout)
        except subprocess.TimeoutExpired:
            _kill(proc)
            out, err = proc.communicate()
            return Outcome(
                proc.returncode,
                out.decode(errors="replace"),
                err.decode(errors="replace"),
                time.perf_counter() - start,
                True,
            )
        return Outcome(
            proc.returncode,
            out.decode(errors="replace"),
            err.decode(errors="replace"),
            time.perf_counter() - start,
            False,
        )
    master, slave = pty.openpty()
    proc = subprocess.Popen(
        argv,
        cwd=cwd,
        env=_env(env),
        stdin=slave,
        stdout=slave,
        stderr=slave,
        preexec_fn=lambda: _limits(memory, file_size),
        close_fds=True,
    )
    os.close(slave)
    chunks: list[bytes] = []
    timed_out = False
    while True:
        left = timeout - (time.perf_counter() - start)
        if left <= 0:
            timed_out = True
            _kill(proc)
            break
        ready, _, _ = select.select([master], [], [], min(left, 0.5))
        if ready:
            try:
                data = os.read(master, 65536)
            except OSError:  # EIO: the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
        elif proc.poll() is not None:
            break
    proc.wait()
    os.close(master)
    text = b"".join(chunks).decode(errors="replace")
    return Outcome(proc.returncode, text, "", time.perf_counter() - start, timed_out, True)


def run_cli(
    *args: object,
    cwd: str | os.PathLike[str],
    tty: bool = False,
    timeout: float = SECONDS,
    memory: int = MEMORY,
    env: dict[str, str] | None = None,
    file_size: int | None = None,
) -> Outcome:
    """``follicle ARGS`` in a child process under the limits (``file_size``: see :func:`run`)."""
    argv = [*FOLLICLE, *map(str, args)]
    return run(argv, cwd, tty=tty, timeout=timeout, memory=memory, env=env, file_size=file_size)


_API = """
import json, sys, traceback
import follicle
from follicle.errors import FollicleError
def _report(**kw):
    sys.stdout.write("\\n@@" + json.dumps(kw) + "\\n")
try:
{body}
except FollicleError as exc:
    _report(kind="refused", error=type(exc).__name__,
            bases=[c.__name__ for c in type(exc).__mro__], message=str(exc))
except BaseException as exc:
    _report(kind="crash", error=type(exc).__name__, message=str(exc),
            traceback=traceback.format_exc())
else:
    _report(kind="ok", result=repr(globals().get("result"))[:2000])
"""


@dataclass
class ApiOutcome:
    """What a snippet of the Python API ended in: ``kind`` is ok, refused (a
    FollicleError), crash (any other exception) or died (killed, or out of time)."""

    kind: str
    error: str
    message: str
    outcome: Outcome
    detail: dict


def run_api(
    code: str, cwd: str | os.PathLike[str], *, timeout: float = SECONDS, memory: int = MEMORY
) -> ApiOutcome:
    """Run ``code`` (it may set ``result``) with ``follicle`` imported, in a child process
    under the limits."""
    body = textwrap.indent(textwrap.dedent(code).strip() or "pass", "    ")
    out = run([sys.executable, "-c", _API.format(body=body)], cwd, timeout=timeout, memory=memory)
    for line in reversed(out.stdout.splitlines()):
        if line.startswith("@@"):
            detail = json.loads(line[2:])
            return ApiOutcome(
                detail["kind"], detail.get("error", ""), detail.get("message", ""), out, detail
            )
    why = "timed out" if out.timed_out else f"exit {out.rc}"
    return ApiOutcome("died", why, out.stderr[-2000:], out, {})


def files(folder: str | os.PathLike[str]) -> set[str]:
    """Every path under ``folder`` (relative), hidden ones included."""
    root = Path(folder)
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def session(sid: int) -> list:
    """The live processes (psutil) of session ``sid``: a child started with
    ``start_new_session=True`` (``sid`` its pid) and every process it started, however
    deep, orphaned or not, that did not leave the session itself. Zombies are dead."""
    import psutil

    alive = []
    for proc in psutil.process_iter():
        try:
            if os.getsid(proc.pid) == sid and proc.status() != psutil.STATUS_ZOMBIE:
                alive.append(proc)
        except (OSError, psutil.Error):  # gone meanwhile
            continue
    return alive


def session_workers(sid: int) -> list:
    """The worker processes (multiprocessing's spawned children: Dask's local workers)
    of session ``sid``."""
    import psutil

    found = []
    for proc in session(sid):
        with contextlib.suppress(psutil.Error):
            if "spawn_main" in " ".join(proc.cmdline()):
                found.append(proc)
    return found


def wait_session_ends(sid: int, timeout: float = 60.0) -> None:
    """Return once no process of session ``sid`` is alive, so nothing it started can
    still write; fail naming the ones left after ``timeout`` seconds. What a check that
    a stopped command left nothing behind waits on, instead of a fixed sleep that a slow
    machine outlasts."""
    deadline = time.monotonic() + timeout
    while left := session(sid):
        if time.monotonic() > deadline:
            names = []
            for proc in left:
                with contextlib.suppress(Exception):
                    names.append(" ".join(proc.cmdline())[:200])
            raise AssertionError(f"{len(left)} processes still running: {names}")
        time.sleep(0.05)


def screen(text: str) -> list[str]:
    """The lines a terminal shows once ``text`` is written to it: a carriage return goes
    back to the line's start, ``ESC[nA`` up ``n`` lines, ``ESC[2K`` (``ESC[K``) erases
    the line (the rest of it); other escapes (colours) show nothing. A progress bar
    drawn over itself and erased at the end leaves nothing behind, as on the screen."""
    lines, row, col = [""], 0, 0
    for token in re.findall(r"\x1b\[[0-9;?]*[A-Za-z]|[\r\n]|[^\x1b\r\n]+|\x1b", text):
        if token == "\n":
            row, col = row + 1, 0
            lines += [""] * (row + 1 - len(lines))
        elif token == "\r":
            col = 0
        elif token.startswith("\x1b["):
            if token[-1] == "A":
                row = max(row - int(token[2:-1] or 1), 0)
            elif token[-1] == "K":
                lines[row] = "" if token[2:-1] == "2" else lines[row][:col]
        elif token != "\x1b":
            line = lines[row].ljust(col)
            lines[row] = line[:col] + token + line[col + len(token) :]
            col += len(token)
    return lines


def assert_cli_refused(out: Outcome, *names: str) -> str:
    """The promise for bad input on the command line: exit 2, one ``error:`` line that
    names each of ``names``, no traceback, within the limits. Returns the line."""
    shown = (
        f"rc={out.rc} timed_out={out.timed_out}\nstdout: {out.stdout[-3000:]}\n"
        f"stderr: {out.stderr[-3000:]}"
    )
    assert not out.timed_out, f"did not finish in {SECONDS} s\n{shown}"
    assert out.rc == 2, shown
    assert "Traceback" not in out.stderr + out.stdout, shown
    said = "\n".join(screen(out.stdout)) if out.tty else out.stderr
    lines = [line.strip() for line in said.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), shown
    for name in names:
        assert name in lines[0], f"{name!r} not named\n{shown}"
    return lines[0]


def assert_api_refused(res: ApiOutcome, *names: str, error: str = "FollicleError") -> str:
    """The promise for bad input in Python: a FollicleError subclass (``error`` among its
    bases) whose message names each of ``names``, within the limits. Returns the message."""
    shown = (
        f"{res.kind} {res.error}: {res.message}\n{res.detail.get('traceback', '')}"
        f"\n{res.outcome.stderr[-2000:]}"
    )
    assert res.kind == "refused", shown
    assert error in res.detail["bases"], shown
    for name in names:
        assert name in res.message, f"{name!r} not named\n{shown}"
    return res.message


def read_within(path: Path, read, slack: int) -> object:
    """``read(path)``'s result, or the FormatError it raised, checking in this process
    that it allocated at most 16 × the file's size + ``slack`` bytes (tracemalloc sees
    numpy's arrays) and that a refusal is one line naming the file."""
    import tracemalloc

    from follicle.errors import FormatError

    size = path.stat().st_size
    tracemalloc.start()
    try:
        result = read(path)
    except FormatError as exc:
        result = exc
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert peak <= 16 * size + slack, f"allocated {peak} bytes reading {size}"
    if isinstance(result, FormatError):
        assert str(result).startswith(f"{path}: ") and "\n" not in str(result), str(result)
    return result


@functools.cache
def warm() -> None:
    """Compile (and cache) numba's kernels once in a child with no time limit, so the
    30 s limit of later children measures their work, not a first-run compilation:
    growing, simulating and rendering with both raster engines. Once per process
    (functools.cache): the numba cache stays, so later calls return at once."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "s.toml").write_text("[groom]\ncount = 50\n")
        render = ["render", "sim.npz", "--size", "32", "32", "--count", "20"]
        for args in (
            ["grow", "s.toml", "-o", "h.npz"],
            ["simulate", "s.toml", "--frames", "2", "-o", "sim.npz"],
            [*render, "-o", "f"],
            [*render, "-o", "g", "--engine", "cpu"],
        ):
            out = run_cli(*args, cwd=tmp, timeout=900, memory=8 << 30)
            assert out.rc == 0, out.stderr


@st.composite
def byte_damage(draw, data: bytes) -> bytes:
    """``data`` truncated, or with bytes or 8-byte fields (a binary format's offsets and
    sizes) overwritten, by edge values or any."""
    out = bytearray(data)
    how = draw(st.sampled_from(["truncate", "bytes", "field"]))
    if how == "truncate":
        return bytes(out[: draw(st.integers(0, len(out) - 1))])
    if how == "bytes":
        for _ in range(draw(st.integers(1, 8))):
            out[draw(st.integers(0, len(out) - 1))] = draw(st.integers(0, 255))
        return bytes(out)
    at = draw(st.integers(0, len(out) - 8))
    value = draw(
        st.sampled_from(
            [
                0,
                1,
                2**31,
                2**32 - 1,
                2**63 - 1,
                2**63,
                2**64 - 1,
                len(out),
                len(out) - 8,
                1 << 63 | 16,
            ]
        )
        | st.integers(0, 2**64 - 1)
    )
    out[at : at + 8] = struct.pack("<Q", value)
    return bytes(out)


# values a hostile JSON document puts where any value goes
HOSTILE_VALUES = [
    None,
    True,
    -1,
    0,
    2**64,
    10**30,
    1e308,
    -1e308,
    float("nan"),
    float("inf"),
    "x",
    "",
    [],
    {},
    [1e308, 1e308, 1e308],
    [[0, 0]] * 5000,
    [[[[[]]]]],
    {"zz": 1},
]


@st.composite
def json_damage(draw, text: str) -> str:
    """The JSON document ``text`` damaged as bytes (:func:`byte_damage`), or as a
    document: one value anywhere replaced by a wrong type, an edge number, NaN or
    infinity, a huge array or a deep nesting, or an unknown key added."""
    how = draw(st.sampled_from(["bytes", "value", "huge", "deep", "unknown"]))
    if how == "bytes":
        return draw(byte_damage(text.encode())).decode("utf-8", "replace")
    doc = json.loads(text)
    slots = []  # (container, key) of every value
    todo = [doc]
    while todo:
        node = todo.pop()
        keys = node if isinstance(node, dict) else range(len(node))
        for key in keys:
            slots.append((node, key))
            if isinstance(node[key], (dict, list)):
                todo.append(node[key])
    node, key = draw(st.sampled_from(slots))
    if how == "value":
        node[key] = draw(st.sampled_from(HOSTILE_VALUES))
    elif how == "huge":
        node[key] = [node[key]] * draw(st.sampled_from([10_000, 200_000]))
    elif how == "deep":
        node[key] = None
        depth = draw(st.sampled_from([100, 3000]))
        return json.dumps(doc).replace("null", "[" * depth + "]" * depth, 1)
    elif isinstance(node, dict):
        node["zz_unknown"] = 1
    else:
        node.append({"zz_unknown": 1})
    return json.dumps(doc)
