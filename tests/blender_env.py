"""Blender (``bpy`` from PyPI) in its own virtual environment, for tests in the real client.

``bpy`` 5.0.1 is built for Python 3.11 only and pins numpy below 2, so it cannot share
follicle's environment (numpy 2). :func:`blender_python` makes ``.venv-blender/`` at the
repository root once (``python3.11 -m venv`` and ``pip install bpy==5.0.1``, about a
minute or two: the wheel is ~370 MB) and reuses it after; :func:`run_blender` runs one
script of ``tests/blender_scripts/`` there under a timeout and returns the JSON findings
it wrote, so the pytest side (numpy 2, follicle) does the asserting.

Concurrency and crashes: the venv is made under an exclusive file lock
(``.venv-blender.lock``), and is trusted only when its ready marker names the pinned bpy
version; a half-made one (an install killed part way) is deleted and made again.

Where it runs: the interpreter is the running Python when it is 3.11, else a
``python3.11`` on PATH. With neither there is no bpy wheel to install, so the tests are
skipped with that reason, except under CI (the ``CI`` variable set), where a missing
client must fail, never pass silently. ``FOLLICLE_BLENDER_PYTHON`` names a Python that
already has bpy (a developer's own environment) and skips the install; pip's own
variables apply to the install (``PIP_FIND_LINKS=/folder/with/the/wheel`` saves the
download).

Opting out: ``FOLLICLE_SKIP_BLENDER=1`` skips the Blender tests, saying how to run them,
and makes nothing (the env is about 1 GB on disk). It is for a developer's machine;
``.ci/run`` never sets it, and under CI it fails like any missing client.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

try:
    import fcntl  # POSIX; elsewhere the env is made without a lock
except ImportError:  # pragma: no cover
    fcntl = None

BPY_VERSION = "5.0.1"
BPY_PYTHON = (3, 11)  # the only Python bpy 5.0's wheels are built for
ROOT = Path(__file__).resolve().parent.parent
VENV = ROOT / ".venv-blender"
LOCK = ROOT / ".venv-blender.lock"
READY = VENV / "follicle-ready.txt"  # written last: its text is the bpy version installed
SCRIPTS = Path(__file__).resolve().parent / "blender_scripts"
INSTALL_TIMEOUT = 1200  # seconds: a 370 MB download on a slow runner
SKIP = "FOLLICLE_SKIP_BLENDER"  # =1: skip the Blender tests, make no .venv-blender


def _base_python() -> str | None:
    """An interpreter bpy has a wheel for: this one if it is 3.11, else python3.11 on PATH."""
    if sys.version_info[:2] == BPY_PYTHON:
        return sys.executable
    return shutil.which("python{}.{}".format(*BPY_PYTHON))


def skipped() -> bool:
    """Whether the developer opted out of the Blender tests (``FOLLICLE_SKIP_BLENDER=1``)."""
    return os.environ.get(SKIP) == "1"


def _venv_python() -> Path:
    return VENV / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def _unavailable(why: str) -> None:
    """Skip with ``why``, or fail under CI, where every client test must run."""
    if os.environ.get("CI"):
        pytest.fail(f"Blender tests cannot run under CI: {why}", pytrace=False)
    pytest.skip(why)


def _run(cmd: list[str], what: str) -> None:
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=INSTALL_TIMEOUT)
    except subprocess.TimeoutExpired:
        pytest.fail(
            f"{what}: no result within {INSTALL_TIMEOUT} s ({' '.join(cmd)})", pytrace=False
        )
    if done.returncode != 0:
        pytest.fail(
            f"{what} failed (exit {done.returncode}): {' '.join(cmd)}\n"
            f"{(done.stdout + done.stderr)[-4000:]}",
            pytrace=False,
        )


def blender_python() -> Path:
    """The Python of ``.venv-blender`` with bpy installed, made on first use (see module)."""
    if skipped():
        _unavailable(
            f"{SKIP}=1: the Blender tests are skipped and .venv-blender (bpy {BPY_VERSION},"
            f" about 1 GB) is not made; to run them: unset {SKIP} and run"
            " .venv/bin/python -m pytest tests/test_blender.py tests/test_blender_cards.py"
        )
    given = os.environ.get("FOLLICLE_BLENDER_PYTHON")
    if given:
        return Path(given)
    base = _base_python()
    if base is None:
        _unavailable(
            f"bpy {BPY_VERSION} has wheels for Python {'.'.join(map(str, BPY_PYTHON))}"
            f" only; this is {sys.version.split()[0]} and no python3.11 is on PATH"
        )
    with open(LOCK, "w") as lock:
        if fcntl is not None:
            fcntl.flock(lock, fcntl.LOCK_EX)  # one maker; the others wait, then reuse it
        if READY.exists() and READY.read_text().strip() == BPY_VERSION and _venv_python().exists():
            return _venv_python()
        shutil.rmtree(VENV, ignore_errors=True)  # half-made or another version: start over
        _run([base, "-m", "venv", str(VENV)], "making .venv-blender")
        _run(
            [
                str(_venv_python()),
                "-m",
                "pip",
                "install",
                "-q",
                "--disable-pip-version-check",
                f"bpy=={BPY_VERSION}",
            ],
            f"installing bpy {BPY_VERSION} into .venv-blender",
        )
        READY.write_text(BPY_VERSION + "\n")
    return _venv_python()


def run_blender(python: Path, script: str, *args: object, timeout: float = 600) -> dict:
    """Run ``tests/blender_scripts/<script>`` with ``args`` under ``python`` (Blender's)
    and return the JSON it wrote to the path given as its last argument (``args[-1]``).
    A crash, a timeout or no JSON fails the test with the script's output."""
    out = Path(str(args[-1]))
    cmd = [str(python), str(SCRIPTS / script), *map(str, args)]
    env = {**os.environ, "PYTHONNOUSERSITE": "1"}
    env.pop("PYTHONPATH", None)  # follicle's environment must not leak into Blender's
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(
            f"{script}: Blender did not finish within {timeout:g} s\n"
            f"{str(exc.stdout or '')[-3000:]}",
            pytrace=False,
        )
    log = (done.stdout + done.stderr)[-6000:]
    if done.returncode != 0 or not out.exists():
        pytest.fail(
            f"{script} failed in Blender (exit {done.returncode}, wrote"
            f" {'no' if not out.exists() else 'its'} findings):\n{log}",
            pytrace=False,
        )
    return json.loads(out.read_text())
