"""`follicle export IN... -o FOLDER --to SUFFIX [--scheduler]` (issue 26): grooms in
several formats, of unequal segment counts, converted one after another and one Dask task
per file on local:2 are the same bytes as `follicle export IN -o OUT` of each, and read
back as their inputs; ambiguous or bad input is one line naming it and writes nothing; a
bad file among several keeps the files before it, whole, and writes neither it nor those
after it; Ctrl-C / SIGTERM leaves only whole files."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from follicle.cli import main
from follicle.distributed.export import export_files
from follicle.errors import InputError
from follicle.io.dispatch import load_curves, save
from follicle.io.sim_cache import CACHE_FORMAT
from hairfiles import hair
from hostile import FOLLICLE, files, session, session_workers, wait_session_ends

# name: (segments + 1 per hair, seed); each groom saved in its own format
GROOMS = {
    "a.npz": ((4, 6, 2, 5), 0),
    "b.abc": ((3, 9, 2), 1),
    "c.usdc": ((5, 5, 7, 2, 12), 2),
    "d.hair": ((2, 8), 3),
}
INPUTS = sorted(GROOMS)


def run(*args: object, cwd: Path):
    """``follicle ARGS`` in this process, run from the folder ``cwd``."""
    here = os.getcwd()
    os.chdir(cwd)
    try:
        return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
    finally:
        os.chdir(here)


@pytest.fixture(scope="module")
def grooms(tmp_path_factory) -> Path:
    """A folder holding :data:`GROOMS`, and single/NAME.SUFFIX: what `follicle export
    NAME -o single/NAME.SUFFIX` (one file, today's path) writes for .usdc, .abc, .hair."""
    folder = tmp_path_factory.mktemp("grooms")
    for name, (counts, seed) in GROOMS.items():
        save(hair(counts, seed), folder / name)
    for suffix in (".usdc", ".abc", ".hair"):
        for name in INPUTS:
            out = Path("single") / f"{Path(name).stem}{suffix}"
            done = run("export", name, "-o", out, cwd=folder)
            assert done.exit_code == 0, done.output
    return folder


def _inputs(grooms: Path, into: Path) -> None:
    for name in INPUTS:
        shutil.copy(grooms / name, into / name)


def _read_back_as_inputs(folder: Path, suffix: str, grooms: Path) -> None:
    """``folder`` holds NAME.SUFFIX for each input and nothing else (nothing hidden), each
    the bytes of the single-file export, with the input's points and curves."""
    names = sorted(f"{Path(n).stem}{suffix}" for n in INPUTS)
    assert sorted(files(folder)) == names
    for name in INPUTS:
        out = f"{Path(name).stem}{suffix}"
        assert (folder / out).read_bytes() == (grooms / "single" / out).read_bytes(), out
        back, source = load_curves(folder / out), load_curves(grooms / name)
        np.testing.assert_array_equal(back.offsets, source.offsets)
        np.testing.assert_allclose(back.points, source.points, atol=1e-6)


@pytest.mark.parametrize("suffix", [".usdc", "abc", ".hair"])
@pytest.mark.slow
def test_many_files_convert_one_after_another_as_each_alone(grooms, tmp_path, suffix):
    _inputs(grooms, tmp_path)
    done = run("export", *INPUTS, "-o", "out/", "--to", suffix, cwd=tmp_path)
    assert done.exit_code == 0, done.output
    dot = suffix if suffix.startswith(".") else f".{suffix}"
    lines = done.output.splitlines()
    assert lines[0] == f"4 hairs, 17 points → {Path('out') / f'a{dot}'}"
    assert lines[2] == f"5 hairs, 31 points → {Path('out') / f'c{dot}'}"
    assert len(lines) == len(INPUTS)
    _read_back_as_inputs(tmp_path / "out", dot, grooms)


@pytest.mark.slow
def test_a_cluster_writes_the_bytes_of_one_process(grooms, tmp_path):
    """One task per file on local:2, the outputs in three formats and two folders: the
    same bytes as the serial run, counted by the progress."""
    sources = [grooms / name for name in INPUTS]
    outs = ["x/a.usdc", "x/b.abc", "y/c.hair", "y/d.usdc"]
    seen: list[tuple[int, int]] = []
    dask = export_files(
        sources,
        [tmp_path / "dask" / o for o in outs],
        "local:2",
        progress=lambda *a: seen.append(a),
    )
    serial = export_files(sources, [tmp_path / "serial" / o for o in outs])
    assert dask == serial == [(4, 17), (3, 14), (5, 31), (2, 10)]
    assert seen == [(0, 4), (1, 4), (2, 4), (3, 4), (4, 4)]
    assert files(tmp_path / "dask") == files(tmp_path / "serial") == {"x", "y", *outs}
    for out in outs:
        assert (tmp_path / "dask" / out).read_bytes() == (tmp_path / "serial" / out).read_bytes()
    for name, out in zip(INPUTS, outs, strict=True):
        if out.endswith(".usdc"):
            assert (tmp_path / "dask" / out).read_bytes() == (
                grooms / "single" / f"{Path(name).stem}.usdc"
            ).read_bytes()


@pytest.mark.parametrize("scheduler", [None, "local:2"])
@pytest.mark.slow
def test_a_bad_file_keeps_those_before_it_and_writes_no_more(grooms, tmp_path, scheduler):
    """b.hair is cut short: a.usdc stays, whole; neither b nor c (converted or not on a
    worker) is written; one line names b.hair, exit 2."""
    shutil.copy(grooms / "a.npz", tmp_path / "a.npz")
    (tmp_path / "b.hair").write_bytes((grooms / "single" / "b.hair").read_bytes()[:100])
    shutil.copy(grooms / "c.usdc", tmp_path / "c.usdc")
    args = ["export", "a.npz", "b.hair", "c.usdc", "-o", "out", "--to", ".usdc"]
    done = run(*args, *(["--scheduler", scheduler] if scheduler else []), cwd=tmp_path)
    assert done.exit_code == 2, done.output
    lines = done.output.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), done.output
    assert "b.hair" in lines[0] and "1 of 3 files converted before it" in lines[0]
    assert (" on Dask worker " in lines[0]) == (scheduler is not None)
    assert files(tmp_path / "out") == {"a.usdc"}
    assert (tmp_path / "out" / "a.usdc").read_bytes() == (grooms / "single" / "a.usdc").read_bytes()


@pytest.mark.slow
def test_ambiguous_or_bad_input_is_one_line_and_writes_nothing(grooms, tmp_path):
    _inputs(grooms, tmp_path)
    shutil.copy(grooms / "a.npz", tmp_path / "a.hair")
    (tmp_path / "folder").mkdir()
    (tmp_path / "file.txt").write_text("not a folder")
    np.savez(tmp_path / "sim.npz", format=np.array(CACHE_FORMAT))  # tagged as a cache
    before = files(tmp_path)
    cases = [
        (["a.npz", "a.hair", "-o", "out", "--to", ".usdc"], "a.npz", "a.hair", "both"),
        (["a.npz", "b.abc", "-o", "out"], "-o out", "--to SUFFIX"),
        (["a.npz", "-o", "folder"], "-o folder", "a folder", "--to SUFFIX"),
        (["c.usdc", "d.hair", "-o", ".", "--to", ".usdc"], "c.usdc", "its own input"),
        (["a.npz", "b.abc", "-o", "out.usdc", "--to", ".usdc"], "-o out.usdc", "a folder"),
        (["a.npz", "b.abc", "-o", "file.txt", "--to", ".usdc"], "-o file.txt", "a folder"),
        (["a.npz", "b.abc", "-o", "out", "--to", ".ply"], "--to .ply", "must end in"),
        (["a.npz", "b.abc", "-o", "out", "--to", ".hair", "--target", "unreal"], "--target"),
        (["sim.npz", "a.npz", "-o", "out", "--to", ".usdc"], "sim.npz", "exports alone"),
        (["builtin:head", "a.npz", "-o", "out", "--to", ".obj"], "builtin:head", "alone"),
        (["nowhere.abc", "a.npz", "-o", "out", "--to", ".usdc"], "nowhere.abc", "no such file"),
    ]
    for args, *names in cases:
        done = run("export", *args, cwd=tmp_path)
        lines = done.output.splitlines()
        assert done.exit_code == 2 and len(lines) == 1, (args, done.output)
        assert lines[0].startswith("error: ") and all(n in lines[0] for n in names), lines[0]
        assert files(tmp_path) == before, (args, files(tmp_path) - before)
    with pytest.raises(InputError, match="one output per source"):
        export_files([tmp_path / "a.npz"], [])


@pytest.mark.parametrize(
    "signum, scheduler",
    [(signal.SIGINT, None), (signal.SIGTERM, "local:2")],
    ids=["SIGINT-serial", "SIGTERM-local:2"],
)
@pytest.mark.slow
def test_a_stopped_export_leaves_only_whole_files(tmp_path, signum, scheduler):
    """Stopped once the first of 40 conversions is in place: each file in the folder is
    whole (reads back as its input), and nothing else is there."""
    rng = np.random.default_rng(0)
    big = hair(tuple(int(n) for n in rng.integers(8, 24, 20000)))
    save(big, tmp_path / "g00.npz")
    names = [f"g{i:02d}.npz" for i in range(40)]
    for name in names[1:]:
        shutil.copy(tmp_path / "g00.npz", tmp_path / name)
    args = ["export", *names, "-o", "out", "--to", ".abc"]
    proc = subprocess.Popen(
        [*FOLLICLE, *args, *(["--scheduler", scheduler] if scheduler else [])],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its session: every process it starts, to wait on
    )
    deadline = time.monotonic() + 120
    while not list((tmp_path / "out").glob("*.abc")):
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.05)
    if scheduler:  # the workers are there to be stopped
        assert session_workers(proc.pid), session(proc.pid)
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signum, err.decode()
    wait_session_ends(proc.pid)  # no worker is left that could still write
    written = sorted(files(tmp_path / "out"))
    assert 1 <= len(written) < len(names), written
    assert set(written) <= {f"{Path(n).stem}.abc" for n in names}, written
    for name in written:
        back = load_curves(tmp_path / "out" / name)
        np.testing.assert_array_equal(back.offsets, big.offsets)
        np.testing.assert_allclose(back.points, big.points, atol=1e-6)
