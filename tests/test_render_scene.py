"""The [render] section: shading model and parameters, shadows, [[render.lights]]."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from follicle import HairCurves
from follicle.errors import ConfigError
from follicle.pipeline import render_scene
from follicle.render import Light
from follicle.scene import RenderParams, Scene, parse_scene, scene_to_toml
from glmark import gl

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

HAIR = HairCurves.from_array(
    np.stack([np.linspace([x, 0, 0], [x, 0.1, 0], 4) for x in np.linspace(-0.05, 0.05, 30)]),
    point_data={"width": np.full(120, 2e-3, np.float32)},
)
BLACK = dict(background_top=(0, 0, 0), background_bottom=(0, 0, 0), msaa=0, size=(64, 64))


def test_lights_and_shading_round_trip_through_toml():
    scene = parse_scene(
        {
            "render": {
                "shading": "marschner",
                "shading_params": {"alpha": -5.0, "tt": 2.0},
                "shadows": False,
                "lights": [
                    {"direction": [1, 1, 0], "space": "world", "intensity": 2.0},
                    {"type": "ambient", "color": [0.9, 0.9, 1.0], "intensity": 0.1},
                ],
            }
        }
    )
    again = parse_scene(tomllib.loads(scene_to_toml(scene)))
    assert again.render == scene.render
    key, ambient = again.render.light_list()
    assert isinstance(key, Light) and key.space == "world"
    np.testing.assert_allclose(key.direction, np.array([1, 1, 0]) / np.sqrt(2))
    np.testing.assert_allclose(key.radiance, (2, 2, 2))
    assert ambient.is_ambient
    np.testing.assert_allclose(ambient.radiance, (0.09, 0.09, 0.1))
    assert Scene().render.light_list() is None  # no [[render.lights]]: the default rig


@pytest.mark.parametrize(
    ("render", "message"),
    [
        ({"shading": "phong"}, r"\[render\]\.shading: Input should be 'kajiya-kay', 'scheuermann'"),
        (
            {"shading": "marschner", "shading_params": {"shininess": 9}},
            r"\[render\]: shading_params: unknown key 'shininess' for shading 'marschner'",
        ),
        ({"shading_params": {"specular": 99}}, r"shading_params\['specular'\]: must be in"),
        ({"lights": [{"type": "spot"}]}, r"\[render\]\.lights\.0\.type: Input should be"),
        ({"lights": [{"direction": [0, 0, 0]}]}, r"a directional light needs a non-zero"),
        ({"lights": [{"intensity": -1}]}, r"\[render\]\.lights\.0\.intensity"),
    ],
)
def test_bad_render_settings_name_the_key(render, message):
    with pytest.raises(ConfigError, match=message):
        parse_scene({"render": render}, "scene.toml")


@gl
def test_scene_lights_reach_the_renderer():
    red = RenderParams(lights=[{"color": [1, 0, 0], "direction": [0, 0, 1]}], **BLACK)
    blue = RenderParams(lights=[{"color": [0, 0, 1], "direction": [0, 0, 1]}], **BLACK)
    r, b = render_scene(HAIR, None, red)[..., :3], render_scene(HAIR, None, blue)[..., :3]
    hair = r.max(axis=2) > 20
    assert hair.mean() > 0.05
    assert r[hair, 0].mean() > 5 * r[hair, 2].mean() + 1
    assert b[hair, 2].mean() > 5 * b[hair, 0].mean() + 1


@gl
def test_scene_shading_and_shadows_reach_the_renderer():
    images = {
        m: render_scene(HAIR, None, RenderParams(shading=m, **BLACK))
        for m in ("kajiya-kay", "scheuermann", "marschner")
    }
    assert len({img.tobytes() for img in images.values()}) == 3
    tuned = RenderParams(
        shading="marschner",
        shading_params={"diffuse": 0.0, "r": 0.0, "tt": 0.0, "trt": 0.0},
        **BLACK,
    )
    dark = render_scene(HAIR, None, tuned)[..., :3]
    assert dark.mean() < images["marschner"][..., :3].mean()
    unshadowed = render_scene(HAIR, None, RenderParams(shadows=False, **BLACK))
    assert unshadowed.shape == images["kajiya-kay"].shape
