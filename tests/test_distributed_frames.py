"""Frames and scenes on a Dask cluster (issue: beyond one machine): a cache's frames
rendered by LocalClusters of 1, 2 or 3 worker processes, in any task size, are the
single-process PNGs and MP4 byte for byte; scenes simulated one per task are the
single-process caches; bad options are one clean line; Ctrl-C leaves whole frames only;
a worker that cannot reach the cache or the output folder says so."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from PIL import Image

import follicle.distributed.cluster as dcluster
import follicle.distributed.render as drender
import follicle.distributed.simulate as dsim
from follicle.errors import ConfigError, InputError
from follicle.io.sim_cache import load_cache, write_cache
from follicle.pipeline import render_cache, render_frames, simulate_scene
from follicle.render.video import write_mp4
from follicle.scene import scene_from_toml
from hostile import assert_cli_refused, run_cli, session, session_workers, wait_session_ends, warm

pytestmark = pytest.mark.slow  # local Dask clusters and signalled subprocesses

SCENE = """[groom]
count = 1500
[sim]
motion = "turn"
[render]
size = [64, 48]
engine = "cpu"
"""
FRAMES = 12


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A folder with the scene s.toml, its cache sim.npz of FRAMES frames and what one
    process renders of it: serial/frame_0000.png, … and serial.mp4."""
    folder = tmp_path_factory.mktemp("frames")
    (folder / "s.toml").write_text(SCENE)
    cache, _ = simulate_scene(scene_from_toml(SCENE, "s.toml", folder), FRAMES)
    write_cache(cache, folder / "sim.npz")
    cache = load_cache(folder / "sim.npz")
    render_cache(cache, folder / "serial")
    write_mp4((image for _, image in render_frames(cache)), folder / "serial.mp4", cache.fps)
    return folder


def _same_frames(folder: Path, serial: Path, frames: range) -> None:
    """``folder`` holds exactly the PNGs of ``frames``, each the bytes of ``serial``'s."""
    names = [f"frame_{f:04d}.png" for f in frames]
    assert sorted(p.name for p in folder.iterdir()) == names  # nothing hidden left either
    for name in names:
        assert (folder / name).read_bytes() == (serial / name).read_bytes(), name


@pytest.mark.parametrize(
    "workers, per_task, frames",
    [(1, None, None), (2, 5, range(FRAMES)), (3, 1, range(3, 11))],
)
def test_a_cluster_renders_the_single_process_pngs(made, tmp_path, workers, per_task, frames):
    """Any run of frames, in tasks of any size, is drawn through the whole sequence's
    camera: frames 3–10 alone are the bytes of the serial render's."""
    seen = []
    paths = drender.render_cache(
        load_cache(made / "sim.npz"),
        tmp_path / "out",
        f"local:{workers}",
        frames=frames,
        frames_per_task=per_task,
        progress=lambda done, total: seen.append((done, total)),
    )
    frames = frames or range(FRAMES)
    assert paths == [tmp_path / "out" / f"frame_{f:04d}.png" for f in frames]
    _same_frames(tmp_path / "out", made / "serial", frames)
    per = per_task or drender.default_frames_per_task(len(frames), workers)
    assert seen[-1] == (len(frames), len(frames)) and len(seen) == -(-len(frames) // per)


def test_a_cluster_encodes_the_single_process_mp4(made, tmp_path):
    """Tasks of 5 frames on 2 workers, encoded in order: the serial video, byte for byte
    (libx264 is deterministic for the same frames on the same machine)."""
    seen = []
    path = drender.render_video(
        load_cache(made / "sim.npz"),
        tmp_path / "v.mp4",
        "local:2",
        frames_per_task=5,
        progress=lambda done, total: seen.append((done, total)),
    )
    assert path.read_bytes() == (made / "serial.mp4").read_bytes()
    assert seen == [(5, FRAMES), (10, FRAMES), (FRAMES, FRAMES)]
    assert [p.name for p in tmp_path.iterdir()] == ["v.mp4"]


def test_the_default_task_size_keeps_every_worker_busy():
    assert drender.default_frames_per_task(48, 2) == 6
    assert drender.default_frames_per_task(49, 2) == 7
    assert drender.default_frames_per_task(3, 4) == 1


def test_scenes_simulated_one_per_task_are_the_single_process_caches(made, tmp_path):
    texts = [SCENE, SCENE.replace('"turn"', '"nod"').replace("1500", "700")]
    scenes = [scene_from_toml(text, "s.toml", made) for text in texts]
    serial = []
    for k, scene in enumerate(scenes):
        write_cache(simulate_scene(scene, 6)[0], tmp_path / f"serial{k}.npz")
        serial.append((tmp_path / f"serial{k}.npz").read_bytes())
    seen = []
    outs = [tmp_path / "c" / "a.npz", tmp_path / "c" / "b.npz"]
    runs = dsim.simulate_scenes(
        scenes, outs, "local:2", frames=6, progress=lambda *a: seen.append(a)
    )
    assert [out.read_bytes() for out in outs] == serial
    assert [(r.frames, r.strands) for r in runs] == [(6, 300), (6, 300)]
    assert seen == [(1, 2), (2, 2)]
    assert sorted(p.name for p in (tmp_path / "c").iterdir()) == ["a.npz", "b.npz"]


def test_a_worker_that_cannot_reach_the_cache_or_the_folder_says_so(made, tmp_path):
    """The path is the client's; a worker on another disk reads nothing there."""
    cache = load_cache(made / "sim.npz")
    job = drender._FramesJob(cache, None, None, None)
    missing = str(tmp_path / "elsewhere" / "sim.npz")
    with dcluster.cluster("local:1") as client:
        call = job.calls(client)[0]
        future = client.submit(
            drender._render_task, missing, *call[1:], str(tmp_path), str(tmp_path / "gone")
        )
        with pytest.raises(InputError, match="every worker must reach it") as exc:
            future.result()
        assert missing in str(exc.value) and "cannot read this simulation cache" in str(exc.value)
        future = client.submit(drender._render_task, *call, str(tmp_path), str(tmp_path / "gone"))
        with pytest.raises(InputError, match="cannot reach this output folder") as exc:
            future.result()
        assert str(tmp_path) in str(exc.value)
    assert list(tmp_path.iterdir()) == []


def test_an_unreachable_scheduler_is_refused_before_anything_is_written(
    made, tmp_path, monkeypatch
):
    monkeypatch.setattr(dcluster, "CONNECT_SECONDS", 1)
    cache = load_cache(made / "sim.npz")
    with pytest.raises(ConfigError, match="tcp://127.0.0.1:9.*no Dask scheduler answered"):
        drender.render_cache(cache, tmp_path / "f", "tcp://127.0.0.1:9")
    with pytest.raises(ConfigError, match="no Dask scheduler answered"):
        drender.render_video(cache, tmp_path / "v.mp4", "tcp://127.0.0.1:9")
    scene = scene_from_toml(SCENE, "s.toml", made)
    with pytest.raises(ConfigError, match="no Dask scheduler answered"):
        dsim.simulate_scenes([scene], [tmp_path / "c.npz"], "tcp://127.0.0.1:9")
    assert list(tmp_path.iterdir()) == []  # not even the folder for the frames


def test_the_cli_renders_and_simulates_on_a_cluster_in_a_terminal(made, tmp_path):
    """The bar counts frames or scenes, the lines are one process's, and so are the
    bytes: the frames of the serial render, the caches of `follicle simulate` of each
    scene (its stored scene and base folder included)."""
    warm()
    texts = {"a": SCENE, "b": SCENE.replace('"turn"', '"shake"')}
    for name, text in texts.items():
        (tmp_path / f"{name}.toml").write_text(text)
    (tmp_path / "sim.npz").write_bytes((made / "sim.npz").read_bytes())
    render = ["render", "sim.npz", "-o", "f", "--scheduler", "local:2", "--frames-per-task", 5]
    simulate = ["simulate", "a.toml", "b.toml", "--frames", 5, "-o", "c", "--scheduler", "local:2"]
    for args, bar, line in [
        (render, "rendering frames on Dask", "12 frames (0–11) of 1,500 hairs, 64×48"),
        (simulate, "simulating scenes on Dask", "5 frames at 24 fps (shake)"),
    ]:
        out = run_cli(*args, cwd=tmp_path, tty=True, timeout=300)
        assert out.rc == 0 and "Traceback" not in out.stdout, out.stdout[-3000:]
        assert bar in out.stdout and line in out.stdout, out.stdout[-3000:]
    _same_frames(tmp_path / "f", made / "serial", range(FRAMES))
    for name, text in texts.items():  # what `follicle simulate NAME.toml` writes
        scene = scene_from_toml(text, f"{name}.toml", tmp_path.resolve())
        write_cache(simulate_scene(scene, 5)[0], tmp_path / f"{name}.npz")
        assert (tmp_path / "c" / f"{name}.npz").read_bytes() == (
            tmp_path / f"{name}.npz"
        ).read_bytes()


def _refused_in_a_terminal(args: list, cwd: Path, *names: str) -> str:
    """``follicle ARGS`` under a pseudo-terminal leaves one ``error:`` line on the screen,
    naming each of ``names`` (the progress bar that spun meanwhile erased)."""
    return assert_cli_refused(run_cli(*args, cwd=cwd, tty=True), *names)


def test_bad_options_are_one_line_in_a_terminal(made, tmp_path):
    warm()
    (tmp_path / "a.toml").write_text(SCENE)
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "a.toml").write_text(SCENE)
    (tmp_path / "sim.npz").write_bytes((made / "sim.npz").read_bytes())
    frames = ["render", "sim.npz", "-o", "f"]
    two = ["simulate", "a.toml", "sub/a.toml"]
    nowhere = "tcp://127.0.0.1:9"
    cases = [  # the addresses first: they take 10 s to give up
        ([*frames, "--scheduler", nowhere], "--scheduler", nowhere, "no Dask scheduler"),
        (["simulate", "a.toml", "-o", "x.npz", "--scheduler", nowhere], "--scheduler", nowhere),
        ([*frames, "--frames-per-task", 3], "--frames-per-task", "--scheduler"),
        ([*frames, "--scheduler", "local:2", "--frames-per-task", 0], "--frames-per-task", "≥ 1"),
        ([*frames, "--scheduler", "local:0"], "--scheduler", "local:0"),
        (["render", "a.toml", "--scheduler", "local:2"], "--scheduler", "a scene"),
        (two, "-o FOLDER"),
        ([*two, "-o", "x.npz"], "-o x.npz", "a folder"),
        ([*two, "-o", "c"], "sub/a.toml", "would both write"),
    ]
    with ThreadPoolExecutor(4) as pool:
        lines = list(
            pool.map(lambda case: _refused_in_a_terminal(case[0], tmp_path, *case[1:]), cases)
        )
    assert all(line.startswith("error: ") for line in lines)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.toml", "sim.npz", "sub"]


def _started(tmp_path: Path, made: Path, out: str, ready: str) -> subprocess.Popen:
    """`follicle render sim.npz -o OUT` of a slow render (30,000 hairs at 320×240, a frame
    a task) on local:2 in a child process, returned once ``ready`` matches a file."""
    warm()
    (tmp_path / "sim.npz").write_bytes((made / "sim.npz").read_bytes())
    proc = subprocess.Popen(
        [sys.executable, "-m", "follicle.cli", "render", "sim.npz", "-o", out]
        + ["--count", "30000", "--size", "320", "240", "--scheduler", "local:2"]
        + ["--frames-per-task", "1"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its session: every process it starts, to wait on
    )
    deadline = time.monotonic() + 120
    while not list(tmp_path.glob(ready)):
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.05)
    return proc


@pytest.mark.parametrize("out, ready", [("f", "f/frame_*.png"), ("v.mp4", ".v.mp4.*")])
def test_ctrl_c_stops_the_workers_and_leaves_only_whole_frames(made, tmp_path, out, ready):
    """SIGINT mid-render: the workers are stopped, then the job's folder (frames not yet
    renamed) or the unfinished video goes; the frames already written stay, whole."""
    proc = _started(tmp_path, made, out, ready)
    assert session_workers(proc.pid), session(proc.pid)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    wait_session_ends(proc.pid)  # no worker is left that could still write
    if out == "v.mp4":
        assert sorted(p.name for p in tmp_path.iterdir()) == ["sim.npz"]
        return
    frames = sorted((tmp_path / "f").iterdir())
    assert 1 <= len(frames) < FRAMES, frames
    assert all(re.fullmatch(r"frame_\d{4}\.png", p.name) for p in frames), frames
    for path in frames:
        with Image.open(path) as image:
            image.load()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f", "sim.npz"]
