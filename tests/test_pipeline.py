import numpy as np
import pytest

from follicle import HairCurves, InputError
from follicle.pipeline import render_scene
from follicle.render import opengl
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
        framed.append(frame_camera(*args, **kwargs))
        return framed[-1]

    frame_camera = opengl.frame_camera
    monkeypatch.setattr(opengl, "frame_camera", spy)
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
    assert xy[:, 1].max() - xy[:, 1].min() > 60  # fills most of the height


def test_explicit_camera_and_nothing_to_frame(monkeypatch):
    params = RenderParams(eye=(0, 0.05, 2.0), target=(0, 0.05, 0), fov=20, size=(64, 64), **BLACK)
    assert _framed_camera(monkeypatch, params) is None  # the scene's camera is used as given
    with pytest.raises(InputError, match="nothing to draw"):
        render_scene(None, None, RenderParams())


def test_render_scene_draws_hair_on_the_background():
    img = render_scene(HAIR, None, RenderParams(size=(64, 64), **BLACK))
    assert img.shape == (64, 64, 4)
    assert 0.05 < np.mean(img[..., :3].max(axis=-1) > 20) < 0.9
