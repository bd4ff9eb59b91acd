"""Camera, projection, framing and lights (no OpenGL needed)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from follicle.errors import InputError
from follicle.render import Camera, Light, fit_camera, frame_camera
from follicle.render.camera import default_lights


def _ndc(camera: Camera, points: np.ndarray, aspect: float) -> np.ndarray:
    m = camera.projection_matrix(aspect) @ camera.view_matrix()
    h = np.c_[points, np.ones(len(points))] @ m.T
    return h[:, :3] / h[:, 3:]


def test_target_projects_to_image_centre():
    cam = Camera(eye=(0.3, 0.2, 1.5), target=(0.05, -0.02, 0.1))
    xy, depth = cam.project([cam.target], (640, 480))
    np.testing.assert_allclose(xy[0], (320.0, 240.0), atol=1e-9)
    assert depth[0] == pytest.approx(cam.distance)


def test_view_matrix_looks_down_minus_z():
    cam = Camera(eye=(1.0, 2.0, 3.0), target=(0.0, 0.5, 0.0))
    v = cam.view_matrix()
    np.testing.assert_allclose(v @ [*cam.eye, 1.0], [0, 0, 0, 1], atol=1e-12)
    t = v @ [*cam.target, 1.0]
    np.testing.assert_allclose(t[:3], [0, 0, -cam.distance], atol=1e-12)
    np.testing.assert_allclose(v[:3, :3] @ v[:3, :3].T, np.eye(3), atol=1e-12)


def test_projection_maps_near_and_far_planes():
    cam = Camera(eye=(0, 0, 5), target=(0, 0, 0), near=0.5, far=20.0)
    ndc = _ndc(cam, np.array([[0, 0, 4.5], [0, 0, -15.0]]), 1.0)
    np.testing.assert_allclose(ndc[:, 2], [-1.0, 1.0], atol=1e-9)


def test_project_agrees_with_matrices_and_puts_origin_top_left():
    cam = Camera(eye=(0.2, 0.4, 2.0), target=(0, 0, 0), fov_y=40.0)
    rng = np.random.default_rng(3)
    pts = rng.uniform(-0.3, 0.3, size=(50, 3))
    w, h = 800, 600
    xy, depth = cam.project(pts, (w, h))
    ndc = _ndc(cam, pts, w / h)
    np.testing.assert_allclose(xy[:, 0], (ndc[:, 0] + 1) / 2 * w, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(xy[:, 1], (1 - ndc[:, 1]) / 2 * h, rtol=1e-9, atol=1e-9)
    assert np.all(depth > 0)
    # a point above the target is higher in the image: smaller y
    up_xy, _ = cam.project([(0, 0.1, 0)], (w, h))
    assert up_xy[0, 1] < h / 2


def test_pixel_scale_matches_projection():
    cam = Camera(eye=(0, 0, 2), target=(0, 0, 0), fov_y=30.0)
    xy, _ = cam.project([(0, 0, 0), (0, cam.pixel_scale(400) * 2.0, 0)], (400, 400))
    assert abs(xy[0, 1] - xy[1, 1]) == pytest.approx(1.0, rel=1e-9)


@pytest.mark.parametrize("aspect", [1.0, 1.6, 0.5])
@pytest.mark.parametrize("direction", [(0.35, 0.15, 1.0), (1, 0, 0), (0, 1, 0.001), (-1, -1, -1)])
def test_frame_camera_fits_box_and_fills_view(aspect, direction):
    lo, hi = np.array([-0.1, 0.2, -0.05]), np.array([0.3, 0.5, 0.1])
    cam = frame_camera(lo, hi, direction=direction, aspect=aspect, margin=1.1)
    w, h = int(round(400 * aspect)), 400
    corners = np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    xy, depth = cam.project(corners, (w, h))
    assert np.all(depth > cam.near) and np.all(depth < cam.far)
    assert np.all(xy >= 0) and np.all(xy[:, 0] <= w) and np.all(xy[:, 1] <= h)
    # the fuller axis is filled to 1 / margin (but for the 1e-3 pad of every point)
    fill = max((xy[:, 0].max() - xy[:, 0].min()) / w, (xy[:, 1].max() - xy[:, 1].min()) / h)
    assert fill == pytest.approx(1 / 1.1, abs=0.01)
    # centred: the corners' picture has equal margins left and right, top and bottom
    np.testing.assert_allclose(xy.min(axis=0), (w, h) - xy.max(axis=0), atol=1e-6)


@pytest.mark.parametrize("aspect", [1.0, 1.6])
def test_fit_camera_frames_a_round_silhouette_tighter_than_its_box(aspect):
    """A ball of points fills the view to 1 / margin; its box's corners stick out of the
    ball's silhouette, so framing them (the old way) leaves the ball smaller."""
    rng = np.random.default_rng(3)
    d = rng.normal(size=(4000, 3))
    ball = 0.1 * d / np.linalg.norm(d, axis=1, keepdims=True) + (0.2, 1.5, -0.3)
    w, h = int(round(300 * aspect)), 300
    fitted = fit_camera(ball, aspect=aspect, margin=1.1)
    boxed = frame_camera(ball.min(axis=0), ball.max(axis=0), aspect=aspect, margin=1.1)

    def fill(cam):
        xy, depth = cam.project(ball, (w, h))
        assert np.all(depth > cam.near) and np.all(depth < cam.far)
        assert np.all(xy >= 0) and np.all(xy[:, 0] <= w) and np.all(xy[:, 1] <= h)
        return max(np.ptp(xy[:, 0]) / w, np.ptp(xy[:, 1]) / h)

    assert fill(fitted) == pytest.approx(1 / 1.1, abs=0.01)
    assert fill(boxed) < 0.8 * fill(fitted)


def test_fit_camera_keeps_balls_of_radius_inside():
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    cam = fit_camera(points, direction=(0, 0, 1), radius=0.25, margin=1.0)
    # the balls' silhouettes touch the image edges: the image spans x from -0.25 to 1.25
    xy, _ = cam.project([(-0.25, 0.0, 0.0), (1.25, 0.0, 0.0)], (400, 400))
    assert xy[0, 0] >= -1e-6 and xy[1, 0] <= 400 + 1e-6
    assert xy[1, 0] - xy[0, 0] > 390
    with pytest.raises(InputError):
        fit_camera(np.zeros((0, 3)))
    with pytest.raises(InputError):
        fit_camera([[0.0, 0.0, math.inf]])
    with pytest.raises(InputError):
        fit_camera(points, radius=-1)


def test_frame_camera_point_box():
    cam = frame_camera((1, 1, 1), (1, 1, 1))
    assert np.isfinite(cam.eye).all() and cam.distance > 0


@pytest.mark.parametrize(
    "kwargs",
    [
        {"eye": (0, 0, 0), "target": (0, 0, 0)},
        {"eye": (0, 0, 1), "target": (0, 0, 0), "fov_y": 0.0},
        {"eye": (0, 0, 1), "target": (0, 0, 0), "fov_y": 180.0},
        {"eye": (0, 0, 1), "target": (0, 0, 0), "near": -1.0},
        {"eye": (0, 0, 1), "target": (0, 0, 0), "near": 2.0, "far": 1.0},
        {"eye": (0, 0, math.nan), "target": (0, 0, 0)},
        {"eye": (0, 0), "target": (0, 0, 0)},
    ],
)
def test_camera_rejects_bad_arguments(kwargs):
    with pytest.raises(InputError):
        Camera(**kwargs)


def test_frame_camera_rejects_bad_arguments():
    with pytest.raises(InputError):
        frame_camera((1, 1, 1), (0, 0, 0))
    with pytest.raises(InputError):
        frame_camera((0, 0, 0), (1, 1, 1), direction=(0, 0, 0))
    with pytest.raises(InputError):
        frame_camera((0, 0, 0), (1, 1, 1), margin=0.5)


def test_camera_up_parallel_to_view_is_handled():
    cam = Camera(eye=(0, 3, 0), target=(0, 0, 0))
    right, up, forward = cam.basis()
    np.testing.assert_allclose(np.cross(right, up), -forward, atol=1e-12)


def test_light_directions():
    cam = Camera(eye=(0, 0, 5), target=(0, 0, 0))
    key = Light((1, 1, 1), space="camera")
    np.testing.assert_allclose(key.world_direction(cam), np.ones(3) / math.sqrt(3))
    # camera looking along +x: camera-space +z (towards the viewer) is world -x
    side = Camera(eye=(-5, 0, 0), target=(0, 0, 0))
    np.testing.assert_allclose(
        Light((0, 0, 1), space="camera").world_direction(side), (-1, 0, 0), atol=1e-12
    )
    np.testing.assert_allclose(Light((0, 2, 0)).world_direction(side), (0, 1, 0))
    amb = Light.ambient(intensity=0.5)
    assert amb.is_ambient
    np.testing.assert_allclose(amb.radiance, (0.5, 0.5, 0.5))
    lights = default_lights()
    assert sum(light.is_ambient for light in lights) == 1 and len(lights) == 4
    with pytest.raises(InputError):
        Light((0, 0, 0))
    with pytest.raises(InputError):
        Light((0, 1, 0), intensity=-1)
    with pytest.raises(InputError):
        Light((0, 1, 0), space="screen")


@pytest.mark.parametrize("eye", ["abc", {"x": 1}, [[0, 0], [1]], [0, "one", 2], 1j, object()])
def test_a_camera_or_light_of_the_wrong_kind_is_an_input_error_naming_it(eye):
    """Not NumPy's ValueError or TypeError (`Camera(eye="abc")`)."""
    with pytest.raises(InputError, match="^camera eye: expected an array of numbers"):
        Camera(eye=eye, target=(0, 0, 0))
    with pytest.raises(InputError, match="^light direction: expected an array of numbers"):
        Light(direction=eye)
    with pytest.raises(InputError, match="^fit_camera points: expected an array of numbers"):
        fit_camera(eye)
