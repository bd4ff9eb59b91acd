"""Growing on a Dask cluster (issue: beyond one machine, first increment): the file a
LocalCluster of 1, 2 or 3 worker processes writes equals the single-process grow byte
for byte, for any task size and format; bad schedulers are one clean refusal and leave
no file behind."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import follicle.distributed.cluster as dcluster
import follicle.distributed.grow as dgrow
from follicle.errors import ConfigError
from follicle.pipeline import groom_scene
from follicle.scene import scene_from_toml
from hostile import assert_cli_refused, run_cli, session, session_workers, wait_session_ends, warm

pytestmark = pytest.mark.slow  # local Dask clusters and signalled subprocesses

SCENE = "[groom]\ncount = 3000\n"


def _scene(tmp_path):
    (tmp_path / "s.toml").write_text(SCENE)
    return scene_from_toml(SCENE, "s.toml", tmp_path)


def _one_process(scene, path, target="generic"):
    """What `follicle grow` writes in one process (follicle.export.grow_file, its call)."""
    from follicle.export import grow_file

    grow_file(scene, path, target)
    return path


def _one_process_payloads(scene, path, target, chunk):
    """What `follicle grow --layout payloads --chunk CHUNK` writes in one process."""
    from follicle.export import grow_file

    grow_file(scene, path, target, chunk=chunk, layout="payloads")
    return path


def _layout_bytes(root: Path) -> dict[str, bytes]:
    """The root layer's bytes and each part file's, by name."""
    folder = root.with_name(f"{root.name}.payloads")
    found = {"root": root.read_bytes().replace(root.name.encode(), b"ROOT")}
    found.update({p.name: p.read_bytes() for p in sorted(folder.iterdir())})
    return found


@pytest.mark.parametrize(
    "workers, chunk, ext, target, layout",
    [
        (1, 1000, ".usdc", "generic", "file"),
        (2, 1234, ".abc", "generic", "file"),
        (3, 700, ".hair", "generic", "file"),
        (2, 5000, ".npz", "generic", "file"),  # one task bigger than the groom
        (3, 999, ".usda", "unreal", "file"),  # the binding Unreal reads, per hair
        # each worker writes the part files it grows, the client only the root layer
        (1, 3000, ".usdc", "generic", "payloads"),
        (2, 700, ".usda", "generic", "payloads"),
        (3, 999, ".usd", "unreal", "payloads"),
    ],
)
def test_a_cluster_grow_is_the_single_process_output(tmp_path, workers, chunk, ext, target, layout):
    """The file, or the root layer and every part file, are the bytes one process writes
    (for payloads: with the same --chunk)."""
    scene = _scene(tmp_path)
    if layout == "file":
        want = {"file": _one_process(scene, tmp_path / f"one{ext}", target).read_bytes()}
    else:
        want = _layout_bytes(_one_process_payloads(scene, tmp_path / f"one{ext}", target, chunk))
    seen = []
    hairs, points = dgrow.grow(
        scene,
        tmp_path / f"two{ext}",
        f"local:{workers}",
        chunk=chunk,
        target=target,
        progress=lambda done, total: seen.append((done, total)),
        layout=layout,
    )
    if layout == "file":
        assert {"file": (tmp_path / f"two{ext}").read_bytes()} == want
    else:
        assert _layout_bytes(tmp_path / f"two{ext}") == want
        assert len(want) == 1 + -(-3000 // chunk)
    assert hairs == 3000 and points > 3000 * 2
    assert seen[-1] == (3000, 3000) and len(seen) == -(-3000 // chunk)
    folders = [f"one{ext}.payloads", f"two{ext}.payloads"] if layout == "payloads" else []
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [f"one{ext}", f"two{ext}", "s.toml", *folders]
    )


def test_a_part_file_written_twice_is_one_whole_file(tmp_path):
    """A retried or speculative task over one part file: the same bytes under the same
    name, and no temporary file of either left."""
    path = tmp_path / "part_0000.usdc"
    call = (SCENE, str(tmp_path), 0, 200, "generic", str(path), True)
    with dcluster.cluster("local:1") as client:
        assert client.submit(dgrow._grow_part, *call, pure=False).result() > 200
        first = path.read_bytes()
        assert client.submit(dgrow._grow_part, *call, pure=False).result() > 200
    assert path.read_bytes() == first
    assert [p.name for p in tmp_path.iterdir()] == ["part_0000.usdc"]


def test_bad_schedulers_are_refused_and_write_nothing(tmp_path, monkeypatch):
    scene = _scene(tmp_path)
    monkeypatch.setattr(dcluster, "CONNECT_SECONDS", 1)
    with pytest.raises(ConfigError, match="tcp://127.0.0.1:9.*no Dask scheduler answered"):
        dgrow.grow(scene, tmp_path / "h.usdc", "tcp://127.0.0.1:9")
    for bad in ("local:0", "local:two", "local:"):
        with pytest.raises(ConfigError, match="whole number of workers"):
            dgrow.grow(scene, tmp_path / "h.usdc", bad)
    assert [p.name for p in tmp_path.iterdir()] == ["s.toml"]


@pytest.mark.parametrize(
    ("address", "words"),
    [
        ("local:²", "whole number of workers"),  # a digit to str.isdigit, not to int()
        ("local:" + "9" * 400, "whole number of workers"),
        ("local:100000", "at most"),  # a Python process each: refused before any starts
        ("tls://127.0.0.1:8786", "tcp:// only"),
        ("ucx://127.0.0.1:8786", "tcp:// only"),
        ("nowhere", "tcp://HOST:PORT"),
    ],
)
def test_schedulers_it_cannot_use_are_refused_at_once(tmp_path, address, words):
    with pytest.raises(ConfigError, match=f"--scheduler .*{words}"):
        dcluster.connect(address)


def test_an_address_that_accepts_but_never_speaks_is_refused_in_time(monkeypatch):
    """A Dask server sends its handshake as it accepts; a silent one would hold the
    client for ever (its own timeout covers only the connection)."""
    import socket
    import threading

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    held = []
    threading.Thread(target=lambda: held.append(server.accept()), daemon=True).start()
    monkeypatch.setattr(dcluster, "CONNECT_SECONDS", 1)
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    try:
        with pytest.raises(ConfigError, match="accepted a connection but said nothing within 1 s"):
            dcluster.connect(address)
    finally:
        server.close()


def test_a_running_scheduler_is_reached_by_its_address_with_or_without_tcp():
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=1, processes=False, protocol="tcp://", dashboard_address=":0"
    ) as cluster:
        for address in (cluster.scheduler_address, cluster.scheduler_address[len("tcp://") :]):
            client = dcluster.connect(address)
            try:
                assert client.submit(sum, [41, 1]).result() == 42
            finally:
                dcluster.close(client)


def test_the_cli_refuses_bad_schedulers_in_one_line_on_a_terminal(tmp_path):
    (tmp_path / "s.toml").write_text(SCENE)
    for address in ("local:²", "local:100000", "tls://127.0.0.1:8786"):
        out = run_cli(
            "grow", "s.toml", "-o", "x.abc", "--scheduler", address, cwd=tmp_path, tty=True
        )
        assert out.rc == 2 and "Traceback" not in out.stdout, out.stdout
        text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", out.stdout)  # the bar, erased
        assert text.count("error:") == 1 and "error: --scheduler" in text, text
    assert not (tmp_path / "x.abc").exists()


def test_the_cli_grows_on_a_local_cluster_in_a_terminal(tmp_path):
    (tmp_path / "s.toml").write_text(SCENE)
    warm()
    out = run_cli(
        "grow",
        "s.toml",
        "-o",
        "h.abc",
        "--scheduler",
        "local:2",
        "--chunk",
        1000,
        cwd=tmp_path,
        tty=True,
        timeout=300,
    )
    assert out.rc == 0, out.stdout + out.stderr
    assert "3,000 hairs" in out.stdout and "Traceback" not in out.stdout
    single = run_cli("grow", "s.toml", "-o", "one.abc", cwd=tmp_path, timeout=300)
    assert single.rc == 0
    assert (tmp_path / "h.abc").read_bytes() == (tmp_path / "one.abc").read_bytes()
    refused = run_cli("grow", "s.toml", "-o", "x.abc", "--chunk", 10, cwd=tmp_path)
    assert_cli_refused(refused, "--chunk", "--scheduler")
    refused = run_cli("grow", "s.toml", "-o", "x.abc", "--scheduler", "local:0", cwd=tmp_path)
    assert_cli_refused(refused, "--scheduler", "local:0")
    assert not (tmp_path / "x.abc").exists()


SHM = Path("/dev/shm")


def _parts_folders(out: str) -> set[Path]:
    """The parts folders of a local grow to a file named ``out``, in memory."""
    return set(SHM.glob(f".{out}.parts-*"))


def _grow_until_parts(tmp_path, count: int, out: str) -> subprocess.Popen:
    """`follicle grow` of ``count`` hairs to ``out`` on local:2 in tasks of 20,000, in a
    child process, returned once a worker has written its first part (in /dev/shm)."""
    (tmp_path / "s.toml").write_text(f"[groom]\ncount = {count}\n")
    warm()
    before = _parts_folders(out)
    proc = subprocess.Popen(
        [sys.executable, "-m", "follicle.cli", "grow", "s.toml", "-o", out]
        + ["--scheduler", "local:2", "--chunk", "20000"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its session: every process it starts, to wait on
    )
    deadline = time.monotonic() + 120
    while not any(list(folder.iterdir()) for folder in _parts_folders(out) - before):
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.05)
    return proc


def test_ctrl_c_stops_the_workers_and_leaves_no_parts(tmp_path):
    """SIGINT while the workers write parts: they are stopped first, then the parts
    folder and any temporary output go; exit 130."""
    before = _parts_folders("h.usdc")
    proc = _grow_until_parts(tmp_path, 2_000_000, "h.usdc")
    assert session_workers(proc.pid), session(proc.pid)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    # one line: no warning of the killed workers' semaphores from multiprocessing
    assert err.decode().split() == "error: stopped by SIGINT; no output was written".split(), err
    wait_session_ends(proc.pid)  # no worker is left that could still write
    assert [p.name for p in tmp_path.iterdir()] == ["s.toml"]
    assert _parts_folders("h.usdc") == before


def test_a_worker_killed_mid_run_is_replaced_and_the_file_still_equals(tmp_path):
    """SIGKILL to a worker process while it grows its range: Dask's nanny starts another
    and the scheduler runs the lost task again; the file is the single-process one."""
    import psutil

    proc = _grow_until_parts(tmp_path, 400_000, "h.hair")
    children = psutil.Process(proc.pid).children(recursive=True)
    workers = [p for p in children if "spawn_main" in " ".join(p.cmdline())]
    assert workers, [p.cmdline() for p in children]
    workers[-1].send_signal(signal.SIGKILL)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    single = run_cli("grow", "s.toml", "-o", "one.hair", cwd=tmp_path, timeout=300)
    assert single.rc == 0
    assert (tmp_path / "h.hair").read_bytes() == (tmp_path / "one.hair").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.hair", "one.hair", "s.toml"]


def test_a_part_reads_back_equal_and_a_second_writer_keeps_the_first(tmp_path):
    """Parts carry every array; a task run twice over one part leaves that part whole."""
    scene = _scene(tmp_path)
    curves = dgrow.target_chunk(groom_scene(scene), groom_scene(scene).generate(50), "unreal")
    dcluster.write_part(curves, tmp_path / "p")
    dcluster.write_part(curves[:10], tmp_path / "p")  # a late duplicate of the task
    back = dcluster.read_part(tmp_path / "p")
    assert back.curve_count == 50 and (back.points == curves.points).all()
    assert sorted(back.point_data) == sorted(curves.point_data)
    assert sorted(back.curve_data) == sorted(curves.curve_data)
    for name, arr in curves.curve_data.items():
        assert (back.curve_data[name] == arr).all(), name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p", "s.toml"]


def test_streamed_results_come_in_order_with_a_bounded_window(tmp_path):
    """Tasks of uneven length come back in call order, and no more than ``ahead`` are
    ever submitted and not handed over: when result k is handed over, at most tasks
    0 … k + ahead have started."""
    calls = [(str(tmp_path), i, 0.05 * (i % 3)) for i in range(12)]
    with dcluster.cluster("local:2") as client:
        got, most = [], 0
        for k, result in enumerate(dcluster.streamed(client, _sleepy, calls, "t", ahead=3)):
            started = {int(p.name) for p in tmp_path.iterdir()}
            assert max(started) <= k + 3, (k, sorted(started))
            most = max(most, len(started) - k)
            got.append(result)
    assert got == [i * i for i in range(12)]
    assert most >= 2  # and the workers did run ahead


def _sleepy(folder: str, i: int, seconds: float) -> int:
    """A task that marks its start in ``folder``, sleeps, and returns i²."""
    Path(folder, str(i)).touch()
    time.sleep(seconds)
    return i * i


def test_a_script_without_a_main_guard_is_told_so(tmp_path):
    """Local workers import the calling script again: without `if __name__ ==
    "__main__":` they cannot start, and the ConfigError says what to write."""
    script = tmp_path / "job.py"
    script.write_text(
        "import follicle.distributed.cluster as d\n"
        "from follicle.errors import ConfigError\n"
        "try:\n"
        "    d.connect('local:1')\n"
        "except ConfigError as exc:\n"
        "    print('REFUSED', exc)\n"
    )
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=tmp_path
    )
    assert "REFUSED --scheduler 'local:1'" in done.stdout, done.stdout + done.stderr
    assert 'if __name__ == "__main__":' in done.stdout


def test_a_worker_that_lacks_a_file_says_so(tmp_path):
    """A scene whose texture the worker cannot find (here: its folder given wrong, as a
    worker without the client's shared disk sees it): the FormatError comes back naming
    the file, the worker and what every worker needs."""
    from follicle.errors import FormatError

    text = "[groom]\ncount = 100\ndensity = 'density.png'\n"
    with dcluster.cluster("local:1") as client:
        future = client.submit(
            dgrow._grow_part,
            text,
            str(tmp_path / "elsewhere"),
            0,
            100,
            "generic",
            str(tmp_path / "part"),
        )
        with pytest.raises(FormatError) as err:
            future.result()
    message = str(err.value)
    assert "density.png" in message and "on Dask worker tcp://" in message
    assert "every worker must reach the scene's files" in message
    assert type(err.value).__name__ == "FileAccessError"  # a FormatError, as it was
    assert not (tmp_path / "part").exists()


def test_a_worker_that_finds_a_bad_file_names_it_without_the_paths_hint(tmp_path):
    """A texture every worker reaches but that is not an image: the error names it and
    the worker, and does not send the user looking for shared disks."""
    from follicle.errors import FollicleError

    (tmp_path / "density.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(40))  # cut short
    text = "[groom]\ncount = 100\ndensity = 'density.png'\n"
    with dcluster.cluster("local:1") as client:
        call = (text, str(tmp_path), 0, 100, "generic", str(tmp_path / "part"))
        with pytest.raises(FollicleError) as err:
            client.submit(dgrow._grow_part, *call).result()
    message = str(err.value)
    assert "density.png" in message and "on Dask worker tcp://" in message
    assert "every worker must reach" not in message
