"""The default groom's look, judged as a viewer would: dark hair keeps its colour where
its highlight is seen at grazing angles, the crown hides the scalp from above, and the
automatic framing fills the picture. Each test runs on both raster engines."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.pipeline import grow
from follicle.render import render_image
from follicle.render.camera import frame_scene
from follicle.scene import Scene

pytestmark = pytest.mark.usefixtures("each_engine")  # each test on both engines

SIZE = (240, 240)
TOP = dict(eye=(0.0, 0.6, 0.25), target=(0.0, 0.05, 0.0))  # above the crown, a little forward


@pytest.fixture(scope="module")
def default_groom():
    scene = Scene()
    mesh, curves = grow(scene)
    return scene, mesh, curves


def draw(scene, curves, mesh, **changes) -> np.ndarray:
    return render_image(curves, mesh, settings=scene.render.replace(size=SIZE, **changes))[..., :3]


def saturation(rgb: np.ndarray) -> np.ndarray:
    f = rgb.astype(np.float64)
    return (f.max(-1) - f.min(-1)) / np.maximum(f.max(-1), 1.0)


@pytest.mark.slow
def test_dark_hair_keeps_its_colour_at_grazing_angles(default_groom):
    """Where the hair covers the picture (opaque over black and over white), hardly a
    pixel of the dark brown default groom is grey (saturation < 0.2); with a white
    primary highlight (specular_tint 0), the crown's silhouette, seen at grazing
    angles, turns grey — as it did before the tint (12 % of the pixels at 320²)."""
    scene, mesh, curves = default_groom
    cam = frame_scene(curves, mesh, scene.render.fov, 1.0)
    view = dict(eye=tuple(cam.eye), target=tuple(cam.target))
    black = draw(scene, curves, None, background_top=(0, 0, 0), background_bottom=(0, 0, 0), **view)
    white = draw(scene, curves, None, background_top=(1, 1, 1), background_bottom=(1, 1, 1), **view)
    dense = (white.astype(int) - black).mean(-1) < 0.03 * 255
    assert dense.sum() > 2000
    tinted = saturation(draw(scene, curves, mesh, **view))[dense]
    white_lobe = saturation(
        draw(scene, curves, mesh, shading_params={"specular_tint": 0.0}, **view)
    )[dense]
    assert np.mean(tinted < 0.2) < 0.01
    assert np.mean(white_lobe < 0.2) > 0.04


def scalp_showing(scene, mesh, curves) -> float:
    """Share of a green scalp's green excess that shows through the hair from above,
    over the pixels where both the scalp and the hair are: the hair's own cover, the
    scalp not tinted ([render].scalp_tint 0; tests/test_scalp.py measures the tint)."""
    green = dict(skin_color=(0.0, 0.6, 0.0), scalp_tint=0.0, **TOP)

    def excess(rgb):
        f = rgb.astype(np.float64)
        return np.clip(f[..., 1] - np.maximum(f[..., 0], f[..., 2]), 0.0, None)

    skin = excess(draw(scene, None, mesh, **green))
    full = excess(draw(scene, curves, mesh, **green))
    hair = draw(scene, curves, None, **TOP).astype(int)
    covered = np.abs(hair - hair[:, :1]).sum(-1) > 30  # differs from the background row
    m = (skin > 20) & covered
    assert m.sum() > 5000
    return float(full[m].sum() / skin[m].sum())


@pytest.mark.slow
def test_the_crown_hides_the_scalp_from_above(default_groom):
    """The default widths (3× a real hair's, for 20,000 hairs, a fifth of a head) let
    about a sixth of the scalp show from above, mostly the parting (0.175 at 320²; the
    Mitsuba reference 0.131); real widths (80/30 µm) showed nearly half (0.45)."""
    scene, mesh, curves = default_groom
    assert scalp_showing(scene, mesh, curves) < 0.25
    thin = scene.replace(groom=scene.groom.replace(root_width=80e-6, tip_width=30e-6))
    _, thin_curves = grow(thin)
    assert scalp_showing(thin, mesh, thin_curves) > 0.35


@pytest.mark.slow
def test_automatic_framing_fills_the_picture(default_groom):
    """The head and hair fill the fuller axis of the picture to 1 / 1.1, centred."""
    scene, mesh, curves = default_groom
    img = draw(scene, curves, mesh)
    rows = np.abs(img.astype(int) - img[:, :1]).sum(-1).max(axis=1) > 12
    cols = np.abs(img.astype(int) - img[:, :1]).sum(-1).max(axis=0) > 12
    top, bottom = np.argmax(rows), len(rows) - np.argmax(rows[::-1])
    left, right = np.argmax(cols), len(cols) - np.argmax(cols[::-1])
    fill = max(bottom - top, right - left) / SIZE[1]
    assert fill > 0.85


@pytest.mark.slow
def test_marschner_dark_hair_is_not_grey(default_groom):
    """Marschner's R lobe is white, as in the physical model, at a smooth fibre's
    Fresnel strength (r = 1): under 10 % of the opaque-hair pixels are grey (6.6 % at
    320², the path-traced reference 3 %); at twice that (the foundation's r = 2), 23 %."""
    scene, mesh, curves = default_groom
    cam = frame_scene(curves, mesh, scene.render.fov, 1.0)
    view = dict(eye=tuple(cam.eye), target=tuple(cam.target), shading="marschner")
    black = draw(scene, curves, None, background_top=(0, 0, 0), background_bottom=(0, 0, 0), **view)
    white = draw(scene, curves, None, background_top=(1, 1, 1), background_bottom=(1, 1, 1), **view)
    dense = (white.astype(int) - black).mean(-1) < 0.03 * 255
    grey = np.mean(saturation(draw(scene, curves, mesh, **view))[dense] < 0.2)
    strong = draw(scene, curves, mesh, shading_params={"r": 2.0}, **view)
    assert grey < 0.1
    assert np.mean(saturation(strong)[dense] < 0.2) > 0.15
