"""The follicle command as a user runs it: outputs, exit codes, error lines."""

import re
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import follicle
from follicle.cli import main


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def hair_pixel_fraction(path):
    """Pixels that are neither background gradient nor skin: dark, brownish hair."""
    img = np.asarray(Image.open(path).convert("RGB")).astype(int)
    r, b = img[..., 0], img[..., 2]
    return float(np.mean((r > b + 8) & (r < 150)))


@pytest.fixture(scope="module")
def demo_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    result = run("demo", "--out", out, "--size", 320, 320)
    assert result.exit_code == 0, result.output
    return out


@pytest.mark.slow
def test_demo_writes_20000_hairs_and_a_picture_of_hair(demo_dir):
    curves = follicle.load_curves(demo_dir / "demo.npz")
    assert curves.curve_count == 20000
    assert set(curves.point_data) == {"width", "color", "opacity", "normal"}
    img = Image.open(demo_dir / "demo.png")
    assert img.size == (320, 320) and img.mode == "RGBA"
    assert hair_pixel_fraction(demo_dir / "demo.png") > 0.05
    assert sorted(p.name for p in demo_dir.iterdir()) == ["demo.npz", "demo.png"]


@pytest.mark.slow
def test_grow_render_info_from_a_scene(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text(
        '[groom]\ncount = 1500\nseed = 3\n[guides]\npath = "builtin:short"\n'
        "[render]\nsize = [160, 120]\n"
    )
    result = run("grow", scene, "-o", tmp_path / "a.npz")
    assert result.exit_code == 0 and "1,500 hairs" in result.output
    a = follicle.load_curves(tmp_path / "a.npz")
    assert a.curve_count == 1500 and a.counts[0] == 16
    # same scene, same bytes
    run("grow", scene, "-o", tmp_path / "b.npz")
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()
    # --count / --seed override the scene
    run("grow", scene, "-o", tmp_path / "c.npz", "--count", 10, "--seed", 4)
    assert follicle.load_curves(tmp_path / "c.npz").curve_count == 10

    result = run("render", tmp_path / "a.npz", "--mesh", "builtin:head", "-o", tmp_path / "a.png")
    assert result.exit_code == 0
    assert Image.open(tmp_path / "a.png").size == (960, 960)
    result = run("render", scene, "-o", tmp_path / "s.png", "--msaa", "0")
    assert result.exit_code == 0
    assert Image.open(tmp_path / "s.png").size == (160, 120)

    result = run("info", scene)
    assert "count = 1500" in result.output and 'path = "builtin:short"' in result.output
    assert "[sim]" in result.output
    result = run("info", tmp_path / "a.npz")
    assert "1500 curves" in result.output


@pytest.mark.slow
def test_default_output_paths_come_from_the_scene(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text('[groom]\ncount = 50\n[output]\ncurves = "out/h.npz"\n')
    assert run("grow", scene).exit_code == 0
    assert (tmp_path / "out" / "h.npz").is_file()


@pytest.mark.parametrize(
    ("scene_text", "message"),
    [
        ('[mesh]\npath = "nowhere.obj"\n', "nowhere.obj"),
        ('[mesh]\npath = "head.xyz"\n', "xyz"),
        ("[groom\ncount = 3\n", "TOML syntax error"),
        ("[groom]\ncuont = 3\n", "[groom].cuont: unknown key"),
        ("[groom]\ncount = -4\n", "[groom].count: Input should be greater than or equal to 0"),
        ('[mesh]\npath = "empty.obj"\n', "no faces"),
        ('[mesh]\npath = "nan.obj"\n', "not finite"),
        ('[groom]\ndensity = "missing.png"\n', "missing.png' does not exist"),
        ('[groom]\ndensity = "head.xyz"\n', "cannot be read as an image"),
        ('[groom]\ndensity = "builtin:fur"\n', "unknown built-in texture 'builtin:fur'"),
        ('[groom]\ndensity = "black.png"\n', "'black' is zero everywhere"),
        ('[mesh]\npath = "nouv.obj"\n[groom]\ndensity = "black.png"\n', "no UVs"),
        ("[mesh]\ndensity = 2\n", "[mesh].density: unknown key"),
    ],
)
@pytest.mark.slow
def test_bad_input_is_one_line_exit_2_and_no_output(tmp_path, scene_text, message):
    (tmp_path / "head.xyz").write_text("nothing")
    (tmp_path / "empty.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "nouv.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    Image.fromarray(np.zeros((4, 4), np.uint8)).save(tmp_path / "black.png")
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text)
    proc = subprocess.run(
        [sys.executable, "-m", "follicle.cli", "grow", str(scene), "-o", str(tmp_path / "o.npz")],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr
    assert "Traceback" not in proc.stderr
    assert proc.stderr.startswith("error:")
    assert not (tmp_path / "o.npz").exists()
    assert not any(p.name.startswith(".o.npz") for p in tmp_path.iterdir())


def test_negative_count_on_the_command_line(tmp_path):
    result = CliRunner().invoke(main, ["demo", "--out", str(tmp_path / "d"), "--count", "-5"])
    assert result.exit_code == 2
    assert "count" in result.output and "greater than or equal to 0" in result.output
    assert not (tmp_path / "d").exists()


def test_unknown_output_extension_and_missing_curves(tmp_path):
    result = CliRunner().invoke(main, ["grow", "nope.toml"])
    assert result.exit_code == 2 and "no such scene file" in result.output
    scene = tmp_path / "s.toml"
    scene.write_text("[groom]\ncount = 5\n")
    result = CliRunner().invoke(main, ["grow", str(scene), "-o", str(tmp_path / "x.xyz")])
    assert result.exit_code == 2 and "must end in .npz" in result.output
    result = CliRunner().invoke(main, ["render", str(tmp_path / "missing.npz")])
    assert result.exit_code == 2 and "no such file" in result.output


@pytest.mark.parametrize("command", [[], ["demo"], ["grow"], ["render"], ["info"]])
def test_help_everywhere(command):
    result = run(*command, "--help")
    assert result.exit_code == 0 and "Usage:" in result.output


@pytest.mark.slow
def test_piped_output_has_no_progress_bar(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text("[groom]\ncount = 100\n")
    proc = subprocess.run(
        [sys.executable, "-m", "follicle.cli", "grow", str(scene), "-o", str(tmp_path / "h.npz")],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0 and proc.stderr == ""
    assert proc.stdout.strip().endswith("h.npz")
    verbose = subprocess.run(
        [
            sys.executable,
            "-m",
            "follicle.cli",
            "-v",
            "grow",
            str(scene),
            "-o",
            str(tmp_path / "h.npz"),
        ],
        capture_output=True,
        text=True,
    )
    assert re.search(r"growing hair in \d+\.\d\d s", verbose.stderr)


@pytest.mark.parametrize("suffix", [".npz", ".hair"])
@pytest.mark.slow
def test_an_output_path_the_system_refuses_is_one_line_exit_2(tmp_path, suffix):
    scene = tmp_path / "s.toml"
    scene.write_text("[groom]\ncount = 20\n")
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    target = blocker / f"hair{suffix}"  # its parent is a file: the OS refuses
    result = CliRunner().invoke(main, ["grow", str(scene), "-o", str(target)])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and str(blocker) in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "s.toml"]


def _inputs_folder(tmp_path):
    """A scene whose mesh, guides and textures are files beside it: (folder, their bytes)."""
    from follicle.groom.builtin_guides import builtin_guides
    from follicle.io.mesh_save import save_mesh

    save_mesh(follicle.load_mesh("builtin:head"), tmp_path / "head.obj")
    follicle.save(builtin_guides("short"), tmp_path / "guides.npz")
    ramp = np.linspace(1, 255, 16 * 16).reshape(16, 16).astype(np.uint8)
    Image.fromarray(ramp).save(tmp_path / "density.png")
    Image.fromarray(np.dstack([ramp, ramp, ramp])).save(tmp_path / "color.png")
    (tmp_path / "s.toml").write_text(
        '[mesh]\npath = "head.obj"\n[guides]\npath = "guides.npz"\n'
        '[groom]\ncount = 200\ndensity = "density.png"\nroot_color = "color.png"\n'
        "[render]\nsize = [32, 32]\n"
    )
    (tmp_path / "link.obj").symlink_to(tmp_path / "head.obj")
    return {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}


@pytest.mark.parametrize(
    ("args", "names"),
    [
        (["grow", "s.toml", "-o", "head.obj"], ["head.obj", "[mesh].path"]),
        (["grow", "s.toml", "-o", "guides.npz"], ["guides.npz", "[guides].path"]),
        (["grow", "s.toml", "-o", "link.obj"], ["link.obj", "[mesh].path"]),
        (["render", "s.toml", "-o", "density.png"], ["density.png", "[groom].density"]),
        (["render", "s.toml", "-o", "color.png"], ["color.png", "[groom].root_color"]),
        (["simulate", "s.toml", "--frames", "2", "-o", "guides.npz"], ["[guides].path"]),
        (["export", "guides.npz", "-o", "guides.npz"], ["guides.npz", "its own input"]),
        (["export", "head.obj", "-o", "link.obj"], ["link.obj", "its own input"]),
    ],
)
@pytest.mark.slow
def test_an_output_never_replaces_an_input_of_the_same_run(tmp_path, args, names):
    """`-o` naming the scene's mesh, guides or a texture, or a link to one, is one line
    naming the input, before anything is read or written: every file stays as it was."""
    from hostile import assert_cli_refused, run_cli, warm

    before = _inputs_folder(tmp_path)
    warm()
    out = run_cli(*args, cwd=tmp_path)
    line = assert_cli_refused(out, *names)
    assert "would replace" in line
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()} == before


@pytest.mark.slow
def test_an_output_that_is_an_input_is_refused_on_a_terminal_too(tmp_path):
    from hostile import run_cli, warm

    before = _inputs_folder(tmp_path)
    warm()
    for args in (["grow", "s.toml", "-o", "head.obj"], ["render", "s.toml", "-o", "color.png"]):
        out = run_cli(*args, cwd=tmp_path, tty=True)
        assert out.rc == 2 and "Traceback" not in out.stdout, out.stdout
        assert "would replace the scene's" in out.stdout and args[-1] in out.stdout
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()} == before


@pytest.mark.slow
def test_python_dash_m_follicle_is_the_command(tmp_path):
    """`python -m follicle` runs the `follicle` command, for where its script is not on
    PATH: the same help, and a bad input the same one line and exit 2."""
    helped = subprocess.run(
        [sys.executable, "-m", "follicle", "--help"], capture_output=True, text=True, check=False
    )
    assert helped.returncode == 0 and helped.stdout.startswith("Usage: follicle ")
    bad = subprocess.run(
        [sys.executable, "-m", "follicle", "info", "nothing.abc"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        check=False,
    )
    assert (bad.returncode, bad.stderr) == (2, "error: nothing.abc: no such file\n")
