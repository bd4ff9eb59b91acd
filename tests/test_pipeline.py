import numpy as np
import pytest

from follicle import HairCurves, InputError
from follicle.pipeline import render_scene, scene_camera
from follicle.scene import RenderParams

HAIR = HairCurves.from_array(
    np.stack([np.linspace([x, 0, 0], [x, 0.1, 0], 4) for x in np.linspace(-0.05, 0.05, 30)]),
    point_data={"width": np.full(120, 2e-3, np.float32)},
)


@pytest.mark.parametrize("fov", [20.0, 45.0])
def test_automatic_framing_uses_the_scene_fov_and_fits_the_hair(fov):
    params = RenderParams(fov=fov, size=(200, 100))
    cam = scene_camera(HAIR, None, params)
    assert cam.fov_y == fov
    xy, depth = cam.project(HAIR.points, (200, 100))
    assert np.all(depth > 0)
    assert xy[:, 0].min() >= 0 and xy[:, 0].max() <= 200
    assert xy[:, 1].min() >= 0 and xy[:, 1].max() <= 100
    assert xy[:, 1].max() - xy[:, 1].min() > 60  # fills most of the height


def test_explicit_camera_and_nothing_to_frame():
    params = RenderParams(eye=(0, 0.05, 2.0), target=(0, 0.05, 0), fov=20)
    cam = scene_camera(HAIR, None, params)
    np.testing.assert_allclose(cam.eye, [0, 0.05, 2.0])
    with pytest.raises(InputError, match="nothing to draw"):
        scene_camera(None, None, RenderParams())


def test_render_scene_draws_hair_on_the_background():
    black = dict(background_top=(0, 0, 0), background_bottom=(0, 0, 0))
    img = render_scene(HAIR, None, RenderParams(size=(64, 64), msaa=0, **black))
    assert img.shape == (64, 64, 4)
    assert 0.05 < np.mean(img[..., :3].max(axis=-1) > 20) < 0.9
