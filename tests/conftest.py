"""Slow set-up that later tests need, begun in the background when the session starts,
so that it overlaps the first tests on CI's two cores instead of stalling one test:

- numba compiling follicle's kernels into their cache (:func:`hostile.warm`: grow,
  simulate and render through the CLI), when nothing is cached yet (a fresh clone);
- Blender's test environment (``.venv-blender``, :mod:`blender_env`), when the session
  runs ``test_blender.py`` and it is not made yet.

Each runs in a child process (not a thread: tests patch those modules' globals), and
the tests that need the work wait for it as before (``warm()`` finds the cache,
``blender_python()`` waits on the environment's lock and reuses it), so the results do
not change, only when the work happens. What is still running when the session ends is
stopped. ``FOLLICLE_NO_PREWARM=1`` turns this off.
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
_COLD = pytest.StashKey[bool]()


def _cold() -> bool:
    """True when numba has cached none of follicle's kernels (see cli._first_run)."""
    cache = os.environ.get("NUMBA_CACHE_DIR")
    root = Path(cache) if cache else SOURCES
    return not root.is_dir() or next(root.rglob("*.nbi"), None) is None


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


def pytest_configure(config: pytest.Config) -> None:
    # before collection: importing the test modules compiles a few kernels already
    config.stash[_COLD] = _cold()


def pytest_collection_finish(session: pytest.Session) -> None:
    if os.environ.get("FOLLICLE_NO_PREWARM") or session.config.option.collectonly:
        return
    files = {Path(str(item.fspath)).name for item in session.items}
    if len(files) > 1 and session.config.stash[_COLD]:
        _start("from hostile import warm; warm()", "kernels")
    if "test_blender.py" in files:
        import blender_env

        if not blender_env.READY.exists() and not os.environ.get("FOLLICLE_BLENDER_PYTHON"):
            _start("import blender_env; blender_env.blender_python()", "blender")


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
    """Run the test once per raster engine: ``follicle.render(...)`` without an
    ``engine`` (and without settings) then draws with it."""
    from follicle.render import settings

    monkeypatch.setattr(settings, "_DEFAULTS", settings.RenderParams(engine=request.param))
    return request.param
