import numpy as np
import pytest

from follicle import HairCurves, InputError
from follicle.pipeline import render_scene
from follicle.render import frame
from follicle.scene import RenderParams

HAIR = HairCurves.from_array(
    np.stack([np.linspace([x, 0, 0], [x, 0.1, 0], 4) for x in np.linspace(-0.05, 0.05, 30)]),
    point_data={"width": np.full(120, 2e-3, np.float32)},
)
BLACK = dict(background_top=(0, 0, 0), background_bottom=(0, 0, 0), msaa=0)


def _framed_camera(monkeypatch, params):
    """Render through the pipeline and return the camera the renderer framed."""
    framed = []

    def spy(*args, **kwargs):
        framed.append(frame_scene(*args, **kwargs))
        return framed[-1]

    frame_scene = frame.frame_scene
    monkeypatch.setattr(frame, "frame_scene", spy)
    render_scene(HAIR, None, params)
    return framed[0] if framed else None


@pytest.mark.parametrize("fov", [20.0, 45.0])
def test_automatic_framing_uses_the_scene_fov_and_fits_the_hair(monkeypatch, fov):
    cam = _framed_camera(monkeypatch, RenderParams(fov=fov, size=(200, 100), **BLACK))
    assert cam.fov_y == fov
    xy, depth = cam.project(HAIR.points, (200, 100))
    assert np.all(depth > 0)
    assert xy[:, 0].min() >= 0 and xy[:, 0].max() <= 200
    assert xy[:, 1].min() >= 0 and xy[:, 1].max() <= 100
    assert xy[:, 1].max() - xy[:, 1].min() > 85  # fills the height to 1 / margin


def test_explicit_camera_and_nothing_to_frame(monkeypatch):
    params = RenderParams(eye=(0, 0.05, 2.0), target=(0, 0.05, 0), fov=20, size=(64, 64), **BLACK)
    assert _framed_camera(monkeypatch, params) is None  # the scene's camera is used as given
    with pytest.raises(InputError, match="nothing to draw"):
        render_scene(None, None, RenderParams())


def test_render_scene_draws_hair_on_the_background():
    img = render_scene(HAIR, None, RenderParams(size=(64, 64), **BLACK))
    assert img.shape == (64, 64, 4)
    assert 0.05 < np.mean(img[..., :3].max(axis=-1) > 20) < 0.9


def _grow_with(tmp_path, **sections) -> tuple:
    from follicle.pipeline import groom_scene
    from follicle.scene import parse_scene

    scene = parse_scene(sections, "scene.toml", base_dir=tmp_path)
    groom = groom_scene(scene)
    return groom, groom.generate(count=3000)


@pytest.mark.slow
def test_groom_density_from_an_image_path_builtin_and_number(tmp_path):
    from PIL import Image

    from follicle.mesh.bust import builtin_bust

    scalp_texture = builtin_bust().textures["scalp"].sample  # the default skin's scalp map
    # density only in the right half of UV space (u > 0.5), as an 8-bit image
    data = np.zeros((8, 8), np.uint8)
    data[:, 4:] = 255
    Image.fromarray(data).save(tmp_path / "right.png")
    groom, curves = _grow_with(tmp_path, groom={"density": "right.png", "count": 10})
    assert groom.sampler.density.name == "right"
    u = curves.curve_data["root_uv"][:, 0]
    # none in the bare half (the texture repeats, so u < 1/16 blends with the dense u > 15/16)
    assert not np.any((u > 1 / 8) & (u < 3 / 8))
    assert np.mean(u > 0.5) > 0.9
    _, scalp = _grow_with(tmp_path, groom={"density": "builtin:scalp"})
    assert scalp_texture(scalp.curve_data["root_uv"]).min() > 0.0
    _, default = _grow_with(tmp_path)  # unset on the built-in bust: its scalp map
    np.testing.assert_array_equal(default.points, scalp.points)
    _, uniform = _grow_with(tmp_path, groom={"density": 2.0})
    assert scalp_texture(uniform.curve_data["root_uv"]).min() == 0.0  # face, neck


@pytest.mark.slow
def test_displacement_moves_roots_along_the_normal(tmp_path):
    from PIL import Image

    Image.fromarray(np.full((4, 4), 255, np.uint8)).save(tmp_path / "bump.png")
    mesh = {"displacement": "bump.png", "displacement_scale": 0.004}
    groom, lifted = _grow_with(tmp_path, mesh=mesh)
    _, flat = _grow_with(tmp_path)
    roots = flat.curve_data["root_triangle"], flat.curve_data["root_bary"]
    normal = groom.mesh.evaluate(*roots).normal
    np.testing.assert_allclose(
        lifted.points[lifted.offsets[:-1]],
        flat.points[flat.offsets[:-1]] + 0.004 * normal,
        atol=1e-5,
    )


@pytest.mark.slow
def test_the_python_quick_start_grows_the_default_scenes_groom(tmp_path):
    """README § Python, line for line, and `follicle grow` of the default scene: the
    same bytes (the built-in guides part along the built-in bust's parting in both)."""
    from click.testing import CliRunner

    import follicle
    from follicle.cli import main

    mesh = follicle.load_mesh("builtin:bust")
    guides = follicle.load_guides("builtin:long", mesh)
    groom = follicle.Groom(mesh, guides)
    follicle.save(groom.generate(20000), tmp_path / "python.npz")
    (tmp_path / "default.toml").write_text("")  # every key at its default
    run = CliRunner().invoke(
        main, ["grow", str(tmp_path / "default.toml"), "-o", str(tmp_path / "cli.npz")]
    )
    assert run.exit_code == 0, run.output
    assert (tmp_path / "python.npz").read_bytes() == (tmp_path / "cli.npz").read_bytes()
    assert sorted(guides.groups.colors.tolist()) == [[0, 0, 255], [255, 0, 0]]  # the parting


@pytest.mark.slow
def test_the_python_quick_start_renders_the_scenes_picture(tmp_path):
    """`follicle.render_image(hair, mesh=mesh, size=…)` with every other setting at its default
    draws what `follicle render` of the same scene draws: one field of view, one
    background, one light rig (it framed at 35° on a darker background before)."""
    from click.testing import CliRunner

    import follicle
    from follicle.cli import main

    (tmp_path / "small.toml").write_text("[groom]\ncount = 2000\n[render]\nsize = [160, 120]\n")
    run = CliRunner().invoke(
        main, ["render", str(tmp_path / "small.toml"), "-o", str(tmp_path / "cli.png")]
    )
    assert run.exit_code == 0, run.output
    mesh = follicle.load_mesh("builtin:bust")
    hair = follicle.Groom(mesh, follicle.load_guides("builtin:long", mesh)).generate(2000)
    image = follicle.render_image(hair, mesh=mesh, size=(160, 120), out=tmp_path / "python.png")
    assert image.shape == (120, 160, 4)
    assert (tmp_path / "python.png").read_bytes() == (tmp_path / "cli.png").read_bytes()
