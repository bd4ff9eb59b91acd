"""`follicle simulate` and `follicle render CACHE`: caches, PNG sequences, exit codes."""

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from follicle import cli
from follicle.cli import main
from follicle.io.sim_cache import is_cache, load_cache
from follicle.pipeline import cache_scene
from follicle.sim.motion import MOTIONS
from glmark import gl

SCENE = """\
[mesh]
path = "builtin:head"
[guides]
path = "builtin:short"
[groom]
count = 3000
[sim]
motion = "nod"
motion_amplitude = 50
motion_period = 0.5
[render]
size = [64, 64]
msaa = 0
"""


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    """A 3-frame turn of the head: (folder, cache path, command output)."""
    folder = tmp_path_factory.mktemp("sim")
    (folder / "scene.toml").write_text(SCENE)
    result = run(
        "simulate",
        folder / "scene.toml",
        "--frames",
        3,
        "--fps",
        12,
        "--motion",
        "turn",
        "--count",
        500,
    )
    assert result.exit_code == 0, result.output
    return folder, folder / "sim.npz", result.output


@pytest.mark.slow
def test_simulate_writes_a_cache_beside_the_scene(sim):
    folder, path, output = sim
    assert is_cache(path)
    cache = load_cache(path)
    assert cache.positions.shape[0] == 3 and cache.positions.shape[3] == 3
    assert cache.positions.shape[1] > 10 and cache.positions.shape[2] >= 2
    assert cache.transforms.shape == (3, 4, 4) and cache.fps == 12.0
    assert np.array_equal(cache.transforms[0], np.eye(4))
    scene = cache_scene(cache)
    assert scene.sim.motion == "turn"  # --motion beats [sim].motion
    assert scene.groom.count == 500 and scene.guides.path == "builtin:short"
    assert str(scene.base_dir) == str(folder.resolve())
    lo = np.array([-0.09538657, -0.232, -0.11098265])
    hi = np.array([0.09538657, 0.11997434, 0.11623616])
    pivot = np.array([0.5 * (lo[0] + hi[0]), lo[1], 0.5 * (lo[2] + hi[2])])  # the head's neck
    # frame 2 at 12 fps is t = 1/6 s, a third of the 0.5 s turn: 5/6 of the way out (the
    # first 0.4 of the period) on the minimum-jerk curve s³(10 − 15s + 6s²) = 625/648 at
    # s = 5/6, so a yaw of 50° × 625/648 = 48.225° about +y through the pivot
    yaw = np.radians(50.0 * 625 / 648)
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    expected = np.eye(4)
    expected[:3, :3], expected[:3, 3] = rot, pivot - rot @ pivot
    assert np.allclose(cache.transforms[2], expected, atol=1e-6)
    # the hair moved with the head: guides at frame 2 are off the rest pose
    moved = np.linalg.norm(cache.positions[2] - cache.positions[0], axis=2)
    assert moved[:, 0].max() > 0.01  # roots ride on the turning skin
    assert np.isfinite(cache.positions).all()
    assert sorted(p.name for p in folder.iterdir()) == ["scene.toml", "sim.npz"]
    line = output.strip()
    assert "\n" not in line
    assert line.startswith("3 frames at 12 fps (turn), ")
    for part in ("guides ×", "vertices", "frames/s", "max stretch", "max penetration", "sim.npz"):
        assert part in line


@pytest.mark.slow
def test_same_scene_same_bytes(sim, tmp_path):
    folder, path, _ = sim
    again = tmp_path / "again.npz"
    result = run(
        "simulate",
        folder / "scene.toml",
        "--frames",
        3,
        "--fps",
        12,
        "--motion",
        "turn",
        "--count",
        500,
        "-o",
        again,
    )
    assert result.exit_code == 0, result.output
    assert again.read_bytes() == path.read_bytes()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--frames", 0], "frames: expected a whole number ≥ 1 (got 0)"),
        (["--fps", 0], "fps: must be > 0 (got 0.0)"),
        (["--fps", -24], "fps: must be > 0 (got -24.0)"),
        (["--fps", "nan"], "fps: must be finite and > 0 (got nan)"),
        (["--fps", "inf"], "fps: must be finite and > 0 (got inf)"),
        (["-o", "{dir}/c.abc"], "c.abc: output must end in .npz"),
        (["--count", -1], "[groom].count: Input should be greater than or equal to 0"),
        (["--motion", "spin"], "Invalid value for '--motion'"),
    ],
)
def test_bad_simulate_input_is_exit_2_and_no_file(tmp_path, args, message):
    (tmp_path / "scene.toml").write_text(SCENE)
    args = [str(a).format(dir=tmp_path) for a in args]
    result = run("simulate", tmp_path / "scene.toml", *args)
    assert result.exit_code == 2, result.output
    assert message in result.output
    if "--motion" not in args:  # click's own usage errors print the usage too
        assert result.output.startswith("error:") and result.output.count("\n") == 1
    assert [p.name for p in tmp_path.iterdir()] == ["scene.toml"]


def test_missing_or_bad_scene(tmp_path):
    result = run("simulate", tmp_path / "nope.toml")
    assert result.exit_code == 2 and "no such scene file" in result.output
    (tmp_path / "bad.toml").write_text('[sim]\nmotion = "wave"\n')
    result = run("simulate", tmp_path / "bad.toml")
    assert result.exit_code == 2 and "[sim].motion" in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


def test_cli_motions_match_the_module_and_the_scene():
    from typing import get_args

    from follicle.scene import SimParams

    option = next(o for o in cli.simulate.params if o.name == "motion")
    offered = tuple(option.type.choices)
    assert offered == MOTIONS == get_args(SimParams.model_fields["motion"].annotation)


@pytest.mark.parametrize("command", [["simulate"], ["render"]])
def test_help(command):
    result = run(*command, "--help")
    assert result.exit_code == 0 and "Usage:" in result.output
    text = " ".join(result.output.split())  # help is wrapped to the terminal
    if command == ["simulate"]:
        assert "sim.npz in the scene's folder" in text
    else:
        assert "CACHE" in text and "MP4" in text


@gl
@pytest.mark.slow
def test_render_a_cache_to_a_png_sequence(sim, tmp_path):
    _, path, _ = sim
    out = tmp_path / "frames"
    result = run("render", path, "-o", out, "--size", 48, 40)
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in out.iterdir())
    assert names == ["frame_0000.png", "frame_0001.png", "frame_0002.png"]
    images = [np.asarray(Image.open(out / n).convert("RGB")).astype(int) for n in names]
    assert all(img.shape == (40, 48, 3) for img in images)
    assert np.abs(images[2] - images[0]).mean() > 1.0  # the head turned: the picture changed
    line = result.output.strip()
    assert "\n" not in line and line.startswith("3 frames (0–2) of 500 hairs, 48×40")
    # one camera for the whole sequence: a range renders the same frames again
    part = tmp_path / "part"
    result = run("render", path, "-o", part, "--size", 48, 40, "--frames", "1:")
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in part.iterdir()) == names[1:]
    for n in names[1:]:
        assert (part / n).read_bytes() == (out / n).read_bytes()


@gl
@pytest.mark.slow
def test_render_defaults_and_hair_count(sim, tmp_path):
    _, path, _ = sim
    cache = tmp_path / "c.npz"
    cache.write_bytes(path.read_bytes())
    result = run("render", cache, "--frames", 2, "--count", 50)
    assert result.exit_code == 0, result.output
    assert [p.name for p in (tmp_path / "c_frames").iterdir()] == ["frame_0002.png"]
    assert Image.open(tmp_path / "c_frames" / "frame_0002.png").size == (64, 64)  # [render]
    assert "of 50 hairs" in result.output


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--frames", "2:9"], "--frames 2:9: the cache has 3 frames (0..2)"),
        (["--frames", "2:2"], "0 ≤ START < STOP ≤ 3"),
        (["--frames", "-1:"], "the cache has 3 frames"),
        (["--frames", "a:b"], "expected START:STOP"),
        (["-o", "{dir}/x.png"], "renders to a folder of frame_0000.png"),
        (["--mesh", "builtin:head"], "--mesh does not apply to a simulation cache"),
        (["--count", -3], "[groom].count: Input should be greater than or equal to 0"),
        (["--size", 0, 10], "[render].size"),
    ],
)
@pytest.mark.slow
def test_bad_render_input_is_exit_2_and_no_file(sim, tmp_path, args, message):
    _, path, _ = sim
    args = [str(a).format(dir=tmp_path) for a in args]
    result = run("render", path, "-o", tmp_path / "out", *args)
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert result.output.startswith("error:") and result.output.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_frames_and_count_need_the_right_source(tmp_path):
    (tmp_path / "s.toml").write_text("[groom]\ncount = 5\n")
    result = run("render", tmp_path / "s.toml", "--frames", "0:2", "-o", tmp_path / "s.png")
    assert result.exit_code == 2 and "--frames does not apply to a scene" in result.output
    result = run("render", tmp_path / "h.npz", "--count", 4)
    assert result.exit_code == 2 and "--count does not apply to a curves file" in result.output
    assert [p.name for p in tmp_path.iterdir()] == ["s.toml"]


@pytest.mark.parametrize("ext", [".usdc", ".abc"])
@pytest.mark.slow
def test_a_cache_exports_with_the_skin_moving_with_the_head(sim, tmp_path, ext):
    """`follicle export sim.npz -o anim.EXT`: the guides of every frame exact, and the
    skin's head transform at each frame the cache's."""
    _, path, _ = sim
    out = tmp_path / f"anim{ext}"
    result = run("export", path, "-o", out)
    assert result.exit_code == 0, result.output
    assert "3 frames of" in result.output and "with the moving skin" in result.output
    cache = load_cache(path)
    if ext == ".abc":
        from alembic3d import Abc, AbcGeom

        from follicle.io.alembic import load_abc

        for f in range(3):
            back = load_abc(out, time=f / 12)
            np.testing.assert_array_equal(
                back.points.reshape(cache.positions[f].shape), cache.positions[f]
            )
        head = AbcGeom.IXform(
            Abc.IArchive(str(out)).getTop().getChild("Groom").getChild("Head"),
            Abc.WrapExistingFlag.kWrapExisting,
        ).getSchema()
        matrix = np.array(head.getValue(Abc.ISampleSelector(2 / 12)).getMatrix()).T
    else:
        from pxr import Usd, UsdGeom

        from follicle.io.usd import load_usd

        for f in range(3):
            back = load_usd(out, time=f)
            np.testing.assert_array_equal(
                back.points.reshape(cache.positions[f].shape), cache.positions[f]
            )
        stage = Usd.Stage.Open(str(out))
        xf = UsdGeom.Xformable(stage.GetPrimAtPath("/Groom/Head"))
        matrix = np.array(xf.GetLocalTransformation(2)).T
    np.testing.assert_allclose(matrix, cache.transforms[2], atol=1e-12)
    assert not np.allclose(cache.transforms[2], np.eye(4))  # the head did turn


def test_a_cache_exports_for_a_target(sim, tmp_path):
    """`follicle export sim.npz -o anim.abc --target unreal`: the guides in centimetres,
    flagged as guides, and Unreal's check passes it."""
    from follicle.io.alembic import load_abc

    _, path, _ = sim
    out = tmp_path / "anim.abc"
    result = run("export", path, "-o", out, "--target", "unreal")
    assert result.exit_code == 0, result.output
    cache = load_cache(path)
    back = load_abc(out, time=1 / 12, stored=True)
    np.testing.assert_allclose(
        back.points.reshape(cache.positions[1].shape), cache.positions[1] * 100, rtol=1e-6
    )
    assert back.curve_data["groom_guide"].all()
    result = run("check", out, "--target", "unreal")
    assert result.exit_code == 0, result.output


def test_the_export_library_does_what_the_command_does(sim, tmp_path):
    """follicle.export from Python: export_cache writes the file the command writes (the
    same bytes) and says what it wrote, with progress per frame; export_skin writes the
    skin alone; export_targets maps many inputs into a folder and refuses a clash."""
    from follicle.errors import InputError
    from follicle.export import export_cache, export_skin, export_targets
    from follicle.io.usd import load_usd

    _, path, _ = sim
    heard = []
    done = export_cache(str(path), tmp_path / "py.usda", progress=lambda d, t: heard.append((d, t)))
    assert (done.frames, done.vertices, done.fps, done.skin) == (
        3,
        load_cache(path).vertex_count,
        12.0,
        "moving",
    )
    assert heard == [(1, 3), (2, 3), (3, 3)]
    assert run("export", path, "-o", tmp_path / "cli.usda").exit_code == 0
    assert (tmp_path / "py.usda").read_bytes() == (tmp_path / "cli.usda").read_bytes()
    assert export_cache(str(path), tmp_path / "bare.abc", skin=False).skin is None

    mesh = export_skin("builtin:head", tmp_path / "head.usda")
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(tmp_path / "head.usda"))
    skin = UsdGeom.Mesh(stage.GetPrimAtPath("/Groom/Skin"))
    assert len(skin.GetPointsAttr().Get()) == len(mesh.rest_vertices)
    assert load_usd(tmp_path / "head.usda").curve_count == 0

    assert export_targets(["a/x.abc", "b/y.npz"], tmp_path / "o", ".usdc") == [
        str(tmp_path / "o" / "x.usdc"),
        str(tmp_path / "o" / "y.usdc"),
    ]
    with pytest.raises(InputError, match="a/x.abc and b/x.npz would both be converted"):
        export_targets(["a/x.abc", "b/x.npz"], tmp_path / "o", "usdc")
