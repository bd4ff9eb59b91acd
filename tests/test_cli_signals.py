"""Stopping the follicle command: SIGTERM is handled like Ctrl-C (the temporary output is
removed, the exit code is 128 + the signal), and a file-size limit or a full disk is one line and
exit 2, not a killed process, with nothing left behind."""

import os
import signal
import subprocess
import time

import pytest

from hostile import FOLLICLE, assert_cli_refused, files, run_cli, warm

pytestmark = pytest.mark.slow  # signalled subprocesses


@pytest.fixture(scope="module", autouse=True)
def _warm():
    warm()


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
@pytest.mark.parametrize("suffix", [".hair", ".usdc"])
def test_a_stopped_grow_leaves_no_file(tmp_path, signum, suffix):
    (tmp_path / "s.toml").write_text("[groom]\ncount = 400000\n")
    proc = subprocess.Popen(
        [*FOLLICLE, "grow", "s.toml", "-o", f"big{suffix}"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 120
    while not any(name.startswith(".big") for name in os.listdir(tmp_path)):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the temporary output never appeared"
        time.sleep(0.05)
    time.sleep(0.3)  # well inside the write
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signum, err.decode()
    assert err.decode().strip() == f"error: stopped by {signum.name}; no output was written"
    assert files(tmp_path) == {"s.toml"}


@pytest.mark.parametrize("suffix", [".npz", ".hair", ".tfx", ".usdc", ".usda", ".usdz"])
def test_a_file_size_limit_is_one_line_and_exit_2(tmp_path, suffix):
    (tmp_path / "s.toml").write_text("[groom]\ncount = 3000\n")
    args = ("grow", "s.toml", "-o", f"h{suffix}")
    out = run_cli(*args, cwd=tmp_path, timeout=120, file_size=200_000)
    assert_cli_refused(out, f"h{suffix}")
    assert files(tmp_path) == {"s.toml"}


def test_the_line_of_a_stop_names_the_outputs_this_run_finished(tmp_path):
    """What a signal's line says was kept (export's files, simulate's caches, render's
    frames): only the outputs put in place since the command began, not older files of
    the same names, nor the ones not yet written."""
    from follicle.cli import _finished

    old, new, later = (tmp_path / n for n in ("a.usdc", "b.usdc", "c.usdc"))
    old.write_text("from an earlier run")
    note = _finished([old, new, later])
    assert note() is None
    new.write_text("this run's")
    assert note() == f"the 1 of 3 files finished ({new})"
    old.write_text("replaced")  # in place: the mtime moves
    tmp = tmp_path / ".a.usdc.tmp"
    tmp.write_text("renamed onto it, as every output is")
    os.replace(tmp, old)
    assert note() == f"the 2 of 3 files finished ({old} … b.usdc)"
