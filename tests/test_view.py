"""The live viewer: the Controller offscreen (real simulation and pixels), the CLI's
exit codes, and the real GLFW window under Xvfb."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from importlib.util import find_spec

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from follicle.cli import main
from follicle.errors import ConfigError, InputError
from follicle.scene import parse_scene
from follicle.view import Controller, view
from glmark import gl

SCENE = """\
[guides]
path = "builtin:long"
[groom]
count = 1500
[render]
size = [160, 90]
msaa = 0
shadows = false
"""


def small_scene():
    return parse_scene({"guides": {"path": "builtin:long"}, "groom": {"count": 1500},
                        "render": {"msaa": 0, "shadows": False}})  # fmt: skip


@pytest.fixture(scope="module")
def ctl():
    c = Controller(small_scene(), size=(160, 90), fps=30.0)
    yield c
    c.release()


def tips_y(c: Controller) -> float:
    return float(c.sim.positions[:, -1, 1].mean())


def test_hair_moves_between_frames(ctl):
    ctl.reset()
    before = ctl.sim.positions.copy()
    ctl.step()
    ctl.step()
    assert np.abs(ctl.sim.positions - before).max() > 1e-5
    assert ctl.frame == 2 and ctl.time == pytest.approx(2 / 30)


def test_pause_holds_and_step_advances(ctl):
    ctl.reset()
    ctl.playing = False
    ctl.sim.step(0.0)
    before = ctl.sim.positions.copy()
    ctl.hair()
    assert ctl.frame == 0 and np.array_equal(ctl.sim.positions, before)
    ctl.step()
    assert ctl.frame == 1
    ctl.toggle_play()
    assert ctl.playing


def test_gravity_changes_tip_height(ctl):
    heights = {}
    for g in (0.0, 9.8):
        ctl.set_param("sim", "gravity", (0.0, -g, 0.0))
        ctl.reset()
        for _ in range(10):
            ctl.step()
        heights[g] = tips_y(ctl)
    assert ctl.sim.params.gravity == (0.0, -9.8, 0.0) and ctl.sim.solver.params is ctl.sim.params
    assert heights[9.8] < heights[0.0] - 1e-3


def test_groom_change_regenerates(ctl):
    ctl.reset()
    first = ctl.hair()
    ctl.set_param("groom", "count", 700)
    assert ctl.hair().curve_count == 700 < first.curve_count
    ctl.set_param("groom", "frizz_tip", 0.01)
    frizzy = ctl.hair()
    ctl.set_param("groom", "frizz_tip", 0.0)
    assert not np.allclose(frizzy.points, ctl.hair().points)
    ctl.set_param("groom", "count", 1500)


def test_head_motion_moves_roots(ctl):
    ctl.reset()
    ctl.set_param("sim", "motion", "turn")
    ctl.step()
    ctl.turn_head(yaw=20.0)
    roots = ctl.sim.positions[:, 0].copy()
    ctl.step()
    assert np.abs(ctl.sim.positions[:, 0] - roots).max() > 1e-3
    ctl.set_param("sim", "motion", "none")


@gl
def test_screenshot_has_hair_pixels(ctl, tmp_path):
    ctl.reset()
    ctl.set_param("groom", "count", 0)
    bare = ctl.draw().copy()
    ctl.set_param("groom", "count", 1500)
    path = ctl.screenshot(tmp_path / "shot.png")
    ctl.step_frame()
    image = np.asarray(Image.open(path))
    assert image.shape == (90, 160, 4)
    changed = np.abs(image[..., :3].astype(int) - bare[..., :3]).max(axis=2) > 16
    assert changed.sum() > 100  # the hair covers pixels the head and background alone do not
    assert ctl.stats()["render_ms"] > 0 and ctl.stats()["hairs"] == 1500


def test_orbit_and_zoom_move_the_camera_about_its_target(ctl):
    before = ctl.camera
    target = np.asarray(before.target)
    r = np.linalg.norm(np.asarray(before.eye) - target)
    ctl.orbit(90.0, 0.0)
    turned = np.asarray(ctl.camera.eye) - target
    assert np.linalg.norm(turned) == pytest.approx(r)  # on the same sphere
    was = np.asarray(before.eye) - target
    assert turned[1] == pytest.approx(was[1])  # same height, turned a quarter about +y
    assert np.dot(turned[[0, 2]], was[[0, 2]]) == pytest.approx(0.0, abs=1e-9 * r * r)
    ctl.orbit(0.0, 200.0)  # over the top: stops 85° up
    assert (np.asarray(ctl.camera.eye) - target)[1] == pytest.approx(r * np.sin(np.radians(85)))
    ctl.zoom(0.5)
    assert np.linalg.norm(np.asarray(ctl.camera.eye) - target) == pytest.approx(r / 2)
    with pytest.raises(InputError, match="zoom"):
        ctl.zoom(0.0)
    ctl.camera = before


def test_bad_parameters_name_the_field(ctl):
    with pytest.raises(ConfigError, match=r"\[sim\]\.gravty: unknown parameter"):
        ctl.set_param("sim", "gravty", (0, 0, 0))
    with pytest.raises(ConfigError, match=r"\[sim\]\.damping"):
        ctl.set_param("sim", "damping", -1.0)
    with pytest.raises(ConfigError, match="unknown section"):
        ctl.set_param("camera", "fov", 30)
    assert ctl.scene.sim.damping >= 0


@gl
def test_view_offscreen_runs_frames(tmp_path):
    ctl = view(small_scene(), frames=3, screenshot=tmp_path / "o.png", size=(96, 54),
               window=False)  # fmt: skip
    assert ctl.frame == 3 and ctl.loop_fps > 0
    assert Image.open(tmp_path / "o.png").size == (96, 54)


def test_cli_bad_input_exits_2(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[sim]\ndampin = 1\n")
    result = CliRunner().invoke(main, ["view", str(bad), "--offscreen", "--frames", "2"])
    assert result.exit_code == 2 and "[sim].dampin" in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    result = CliRunner().invoke(main, ["view", "--offscreen"])
    assert result.exit_code == 2 and "--frames" in result.output


@gl
def test_cli_offscreen(tmp_path):
    (tmp_path / "scene.toml").write_text(SCENE)
    out = tmp_path / "shot.png"
    result = CliRunner().invoke(main, ["view", str(tmp_path / "scene.toml"), "--offscreen",
                                       "--frames", "2", "--size", "64", "36",
                                       "--screenshot", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "2 frames of 1,500 hairs" in result.output and out.is_file()


def _display_command() -> list[str] | None:
    """How to run a windowed command here: as is with a display, else under xvfb-run."""
    if os.environ.get("DISPLAY"):
        return []
    if shutil.which("xvfb-run"):
        return ["xvfb-run", "-a", "-s", "-screen 0 1024x768x24"]
    return None


@pytest.mark.skipif(
    not os.environ.get("CI") and (_display_command() is None or not find_spec("imgui_bundle")),
    reason="no display and no Xvfb (apt-get install xvfb), or no view extra",
)
def test_window_runs_frames_and_exits(tmp_path):
    (tmp_path / "scene.toml").write_text(SCENE)
    out = tmp_path / "window.png"
    command = [*(_display_command() or []), sys.executable, "-m", "follicle.cli", "view",
               str(tmp_path / "scene.toml"), "--frames", "4", "--size", "160", "90",
               "--screenshot", str(out)]  # fmt: skip
    env = {**os.environ, "NUMBA_NUM_THREADS": os.environ.get("NUMBA_NUM_THREADS", "1")}
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 0, done.stderr
    assert "4 frames of 1,500 hairs" in done.stdout
    image = np.asarray(Image.open(out))
    assert image.shape == (90, 160, 4) and image[..., :3].std() > 5
