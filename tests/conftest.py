"""Slow set-up that later tests need, done once when the session starts:

- follicle's prebuilt kernels (``src/follicle/_kernels``, what a wheel ships: numba
  compiling every kernel once, in as many processes as there are cores), when they are
  missing or stale and more than one test file runs. It is done before collection (which
  runs kernels), so no test compiles a kernel (the tests then run the kernels a wheel's
  user runs, and the wheel test's build copies them instead of compiling them again). A
  single test file compiles what it needs on first use, as a source install does.
- Blender's test environment (``.venv-blender``, :mod:`blender_env`), begun in the
  background when the session runs ``test_blender.py`` and it is not made yet; the tests
  that need it wait on its lock.

What is still running in the background when the session ends is stopped.
``FOLLICLE_NO_PREWARM=1`` turns both off.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent
SOURCES = TESTS.parent / "src" / "follicle"
_started: list[subprocess.Popen] = []


def _kernels_stale() -> bool:
    """True when src/follicle/_kernels was not built for these sources, this numba and
    Python, and the CPU levels a wheel built here would ship."""
    from follicle.prebuild.build import default_levels, is_fresh

    return not is_fresh(SOURCES / "_kernels", SOURCES, default_levels())


def _build_kernels() -> None:
    """``python -m follicle.prebuild build`` into src/follicle/_kernels, now; its output
    goes to a log in the temp folder, whose end is shown when it fails."""
    log = Path(tempfile.gettempdir(), "follicle-prewarm-kernels.log")
    sys.stderr.write(f"\nbuilding follicle's prebuilt kernels for the tests, once (log: {log})\n")
    with open(log, "wb") as out:
        done = subprocess.run(
            [sys.executable, "-m", "follicle.prebuild", "build"],
            cwd=TESTS,
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    if done.returncode != 0:
        tail = log.read_text(errors="replace")[-3000:]
        sys.stderr.write(f"building the kernels failed; tests compile on first use:\n{tail}\n")


def _start(code: str, name: str) -> None:
    """Run ``code`` in the background; what it prints goes to a log in the temp folder
    (``follicle-prewarm-<name>.log``), for when the work it does fails."""
    log = Path(tempfile.gettempdir(), f"follicle-prewarm-{name}.log")
    with open(log, "wb") as out:
        _started.append(
            subprocess.Popen(
                [sys.executable, "-c", code],
                cwd=TESTS,
                stdin=subprocess.DEVNULL,
                stdout=out,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )
        )


def _test_files(config: pytest.Config) -> set[str]:
    """The names of the test files the session's arguments name, or hold when folders."""
    files: set[str] = set()
    for arg in config.args or [str(TESTS)]:
        path = Path(config.invocation_params.dir, arg.split("::")[0])
        if path.is_dir():
            files.update(p.name for p in path.rglob("test_*.py"))
        elif path.suffix == ".py":
            files.add(path.name)
    return files


def pytest_configure(config: pytest.Config) -> None:
    """Before collection, because collecting runs kernels (parameters made from grooms):
    a process that ran one before the prebuilt kernels were there compiles them all."""
    if os.environ.get("FOLLICLE_NO_PREWARM") or config.option.collectonly:
        return
    files = _test_files(config)
    if "test_blender.py" in files:  # first: it downloads while the kernels compile
        import blender_env

        made = blender_env.READY.exists() or blender_env.skipped()
        if not made and not os.environ.get("FOLLICLE_BLENDER_PYTHON"):
            _start("import blender_env; blender_env.blender_python()", "blender")
    if len(files) > 1 and _kernels_stale():
        _build_kernels()


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    for proc in _started:
        if proc.poll() is None:  # it and the commands it started: its own process group
            _signal(proc, signal.SIGTERM)
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                _signal(proc, getattr(signal, "SIGKILL", signal.SIGTERM))


def _signal(proc: subprocess.Popen, signum: int) -> None:
    killpg = getattr(os, "killpg", None)  # POSIX; elsewhere the child alone
    if killpg is None:
        proc.send_signal(signum)
        return
    try:
        killpg(proc.pid, signum)
    except ProcessLookupError:
        pass


@pytest.fixture(params=["opengl", "cpu"])
def each_engine(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run the test once per raster engine: ``follicle.render_image(...)`` without an
    ``engine`` (and without settings) then draws with it. Engine availability is per
    parameter: without EGL / OpenGL 3.3 the ``opengl`` run is skipped (as ``@gl`` skips,
    never in CI) and the ``cpu`` run goes ahead. A test that needs OpenGL whatever the
    engine (one making an OpenGL ``Renderer`` itself) carries ``@gl`` as well."""
    if request.param == "opengl":
        from glmark import skip_without_gl  # here: finding out makes an EGL context

        skip_without_gl()
    from follicle.render import settings

    monkeypatch.setattr(settings, "_DEFAULTS", settings.RenderParams(engine=request.param))
    return request.param
