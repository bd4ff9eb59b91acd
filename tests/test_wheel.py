"""The wheel a user installs: built from this repository (``pip wheel``), with the kernels
it ships prebuilt, installed in a fresh virtual environment, where the first commands a
new user runs compile nothing: an empty numba cache stays empty, no line says it is
compiling, and the pictures are made. A damaged prebuilt kernel is compiled again, not
run; the package's files are installed with new times, as pip installs them.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # builds a wheel and installs it in a new venv

ROOT = Path(__file__).resolve().parents[1]
STROKES = {
    "follicle_strokes": 1,
    "mesh": "builtin:head",
    "guides": "builtin:short",
    "strokes": [
        {
            "brush": "comb",
            "path": [[400.0, 190.0], [480.0, 160.0], [560.0, 190.0]],
            "radius": 30.0,
            "strength": 0.5,
            "size": [960, 540],
            "camera": {"eye": [0.9, 0.1, 0.1], "target": [0.0, 0.03, 0.0]},
        }
    ],
}


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh virtual environment with follicle installed from a wheel built here: its
    ``bin`` folder."""
    tmp = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation"]
        + ["-q", "-w", str(tmp / "dist")],
        check=True,
        cwd=tmp,
    )
    (wheel,) = (tmp / "dist").glob("follicle-*.whl")
    tag = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    assert wheel.name.startswith(f"follicle-0.1.0-{tag}-{tag}-"), wheel.name  # not pure
    with zipfile.ZipFile(wheel) as archive:
        manifest = json.loads(archive.read("follicle/_kernels/manifest.json"))
        assert manifest["uncompiled"] == {}, manifest["uncompiled"]
        assert sum(n.endswith(".nbc") for n in archive.namelist()) > 150
        assert not [n for n in archive.namelist() if "/." in n]  # no lock or temporary file
        assert "follicle/mesh/data/bust.npz" in archive.namelist()  # builtin:bust
    venv.EnvBuilder(with_pip=True, clear=True).create(tmp / "venv")
    bin_ = tmp / "venv" / "bin"
    subprocess.run([bin_ / "pip", "install", "-q", str(wheel)], check=True)
    return bin_


def _follicle(bin_: Path, cwd: Path, cache: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    env.pop("PYTHONPATH", None)
    return subprocess.run(
        [bin_ / "follicle", *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )


def test_the_first_commands_of_a_wheel_install_compile_nothing(installed, tmp_path):
    cache = tmp_path / "numba-cache"
    cache.mkdir()
    (tmp_path / "s.toml").write_text("[groom]\ncount = 2000\n")
    (tmp_path / "strokes.json").write_text(json.dumps(STROKES))
    commands = [
        ("demo", "--out", "demo"),
        ("simulate", "s.toml", "--frames", "12", "-o", "sim.npz"),
        ("render", "s.toml", "--engine", "cpu", "-o", "cpu.png", "--size", "320", "240"),
        ("groom", "strokes.json", "-o", "groomed.npz"),
        ("grow", "s.toml", "-o", "x.abc"),
        ("view", "s.toml", "--offscreen", "--frames", "10", "--screenshot", "v.png"),
    ]
    for args in commands:
        done = _follicle(installed, tmp_path, cache, *args)
        assert done.returncode == 0, (args, done.stderr[-2000:])
        assert "compiling" not in done.stderr, (args, done.stderr)
        assert not list(cache.rglob("*.nbi")), (args, sorted(cache.rglob("*.nbi")))
    for made in ("demo/demo.png", "sim.npz", "cpu.png", "groomed.npz", "x.abc", "v.png"):
        assert (tmp_path / made).stat().st_size > 0, made
    site = next((installed.parent / "lib").glob("python*/site-packages"))
    source = site / "follicle" / "arrays.py"
    shipped = site / "follicle" / "_kernels" / "manifest.json"
    assert abs(source.stat().st_mtime - shipped.stat().st_mtime) < 3600  # installed anew


def test_a_damaged_prebuilt_kernel_is_compiled_again(installed, tmp_path):
    """A shipped kernel's data damaged: the demo compiles that kernel alone again. The
    bounds kernel is one the demo calls from Python itself (framing its camera), so no
    other kernel's compiled code stands in for it."""
    site = next((installed.parent / "lib").glob("python*/site-packages"))
    kernels = site / "follicle" / "_kernels"
    files = sorted(kernels.rglob("arrays._point_bounds-*.nbc"))
    assert files, sorted(p.name for p in kernels.rglob("arrays.*"))
    originals = [data.read_bytes() for data in files]
    for data, original in zip(files, originals, strict=True):
        damaged = bytearray(original)
        damaged[len(damaged) // 2] ^= 0xFF
        data.write_bytes(bytes(damaged))
    try:
        cache = tmp_path / "numba-cache"
        done = _follicle(installed, tmp_path, cache, "demo", "--out", "d", "--count", "500")
        assert done.returncode == 0, done.stderr[-2000:]
        assert "compiling follicle.arrays._point_bounds" in done.stderr
        assert [p.name.split("-")[0] for p in cache.rglob("*.nbi")] == ["arrays._point_bounds"]
    finally:
        for data, original in zip(files, originals, strict=True):
            data.write_bytes(original)


def test_follicle_warm_on_a_terminal_has_nothing_to_compile_where_kernels_ship(installed, tmp_path):
    """`follicle warm` on a terminal (``script`` gives it a pseudo-terminal): nothing to
    do where the wheel's kernels run; a bad ``--jobs`` is one line and exit 2."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("PYTHONPATH", None)

    def on_terminal(*args: str) -> subprocess.CompletedProcess:
        line = " ".join([str(installed / "follicle"), *args])
        return subprocess.run(
            ["script", "-qec", line, "/dev/null"],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )

    done = on_terminal("warm")
    assert done.returncode == 0, done.stdout
    assert "nothing to compile: this install's prebuilt kernels (" in done.stdout
    refused = on_terminal("warm", "--jobs", "0")
    assert refused.returncode == 2
    lines = [line for line in refused.stdout.splitlines() if line.strip()]
    assert len(lines) == 1 and "--jobs" in lines[0] and "Traceback" not in refused.stdout
    assert not (tmp_path / "cache").exists() or not list((tmp_path / "cache").rglob("*.nbi"))
