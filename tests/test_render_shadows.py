"""Deep opacity map shadows from the key light: hair on hair, hair on skin, skin on hair,
and no self-shadowing of a lone strand or of the lit side of the skin."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from follicle.curves import HairCurves
from follicle.render import Camera, Light, Renderer, render_image
from follicle.render.image import srgb_to_linear
from follicle.render.settings import RenderParams
from follicle.render.shadows import automatic_layer, light_projection
from glmark import gl
from test_render import StandInMesh, sphere

pytestmark = pytest.mark.usefixtures("each_engine")  # each test on both engines

SIZE = (201, 201)
FRONT = Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0), fov_y=35.0)
BLACK = (0.0, 0.0, 0.0)
PLAIN = {"root_occlusion": 0.0, "roundness": 0.0, "specular": 0.0, "specular2": 0.0}


def side_light(direction) -> list[Light]:
    return [Light(direction, space="world"), Light.ambient(intensity=0.03)]


def sheet(x0: float, x1: float, count: int, seed: int, y=(-0.06, 0.06), width=1e-3) -> HairCurves:
    """Vertical strands at random x in [x0, x1] and z in [-0.03, 0.03]."""
    rng = np.random.default_rng(seed)
    xz = np.column_stack([rng.uniform(x0, x1, count), rng.uniform(-0.03, 0.03, count)])
    ys = np.linspace(y[1], y[0], 6)  # root at the top
    pts = np.empty((count, 6, 3))
    pts[..., 0], pts[..., 1], pts[..., 2] = xz[:, None, 0], ys[None], xz[:, None, 1]
    return HairCurves.from_array(pts, point_data={"width": np.full(count * 6, width)})


def brightness(img: np.ndarray, rows: slice, cols: slice) -> float:
    """Mean linear luminance-ish (mean of RGB) of an image region."""
    return float(srgb_to_linear(img[rows, cols, :3] / 255.0).mean())


def columns(x0: float, x1: float) -> slice:
    xy, _ = FRONT.project([(x0, 0, 0), (x1, 0, 0)], SIZE)
    return slice(int(np.ceil(xy[0, 0])), int(xy[1, 0]))


# ---------------------------------------------------------------- no GL
def test_light_projection_fits_the_box_with_linear_depth():
    lo, hi = np.array([-0.1, -0.2, -0.05]), np.array([0.1, 0.2, 0.05])
    m, texel, depth_range = light_projection(np.array([0.0, 0.0, 1.0]), lo, hi, 512)
    corners = np.array(
        [[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    clip = corners @ m.T
    assert np.all(np.abs(clip[:, :3]) < 1.0) and np.allclose(clip[:, 3], 1.0)
    assert np.abs(clip[:, :2]).max() > 0.98  # the longer side fills the map
    # the light is at +z looking down -z: nearer the light is smaller depth
    assert clip[corners[:, 2] > 0, 2].max() < clip[corners[:, 2] < 0, 2].min()
    assert texel == pytest.approx(0.4 / 512, rel=0.02) and depth_range == pytest.approx(0.1, 0.1)
    assert automatic_layer(lo, hi) == pytest.approx(np.linalg.norm(hi - lo) / 100)


# ---------------------------------------------------------------- GL
def test_hair_behind_dense_hair_is_darker_with_shadows():
    """The light comes from +x through a dense sheet onto a second sheet at -x."""
    curves = HairCurves.concatenate([sheet(0.03, 0.08, 400, 1), sheet(-0.08, -0.03, 400, 2)])
    kw = dict(
        camera=FRONT,
        size=SIZE,
        background=BLACK,
        msaa=0,
        hair_color=(0.5, 0.4, 0.3),
        lights=side_light((1.0, 0.0, 0.0)),
        shading_params=PLAIN,
    )
    lit, shadowed = (
        render_image(curves, shadows=False, **kw),
        render_image(curves, shadows=True, **kw),
    )
    rows = slice(90, 111)
    behind = columns(-0.075, -0.035)
    assert brightness(shadowed, rows, behind) < 0.25 * brightness(lit, rows, behind)
    # the side facing the light keeps most of it (only its deeper strands darken)
    front = columns(0.065, 0.078)
    assert brightness(shadowed, rows, front) > 0.5 * brightness(lit, rows, front)


@pytest.mark.parametrize("model", ["kajiya-kay", "scheuermann", "marschner", "physical"])
@pytest.mark.parametrize("width_px", [6.0, 0.5])
def test_a_lone_strand_does_not_shadow_itself(model, width_px):
    width = width_px * FRONT.pixel_scale(SIZE[1])
    pts = np.linspace([-0.15, 0.02, 0.0], [0.15, -0.02, 0.0], 8)
    curves = HairCurves.from_array(pts[None], point_data={"width": np.full(8, width)})
    kw = dict(
        camera=FRONT,
        size=SIZE,
        background=BLACK,
        msaa=0,
        shading=model,
        lights=[Light((0.3, 0.6, 0.74))],
        hair_color=(0.5, 0.3, 0.15),
    )
    a = render_image(curves, shadows=False, **kw).astype(int)
    b = render_image(curves, shadows=True, **kw).astype(int)
    assert a.max() > 40
    assert np.abs(a - b).max() <= 2


def test_hair_shadows_the_skin_and_the_skin_shadows_hair():
    mesh = sphere(0.1)
    # a dense patch lying flat above the sphere (strands along z), lit from straight above
    rng = np.random.default_rng(3)
    xy = np.column_stack([rng.uniform(-0.05, 0.05, 500), rng.uniform(0.125, 0.14, 500)])
    pts = np.empty((500, 6, 3))
    pts[..., 0], pts[..., 1] = xy[:, None, 0], xy[:, None, 1]
    pts[..., 2] = np.linspace(-0.06, 0.08, 6)[None]
    cap = HairCurves.from_array(pts, point_data={"width": np.full(3000, 1e-3)})
    kw = dict(
        camera=FRONT,
        size=SIZE,
        background=BLACK,
        msaa=0,
        skin_color=(0.6, 0.6, 0.6),
        lights=side_light((0.0, 1.0, 0.0)),
        shading_params={**PLAIN, "skin_wrap": 0.0},
    )
    lit, shadowed = (
        render_image(cap, mesh, shadows=False, **kw),
        render_image(cap, mesh, shadows=True, **kw),
    )
    xy, _ = FRONT.project([(0.0, 0.085, 0.05)], SIZE)  # on the sphere, under the patch
    r, c = int(xy[0, 1]), int(xy[0, 0])
    under = (slice(r - 2, r + 3), slice(c - 2, c + 3))
    assert brightness(shadowed, *under) < 0.5 * brightness(lit, *under)
    xy, _ = FRONT.project([(0.08, 0.04, 0.05)], SIZE)  # on the sphere, beside the patch's shadow
    r, c = int(xy[0, 1]), int(xy[0, 0])
    beside = (slice(r - 2, r + 3), slice(c - 2, c + 3))
    assert brightness(shadowed, *beside) == pytest.approx(brightness(lit, *beside), rel=0.05)

    # strands left of the sphere, lit from +x: the ones level with it are in its shadow
    strands = HairCurves.concatenate(
        [sheet(-0.16, -0.13, 60, 4, y=(-0.05, 0.05)), sheet(-0.16, -0.13, 60, 5, y=(0.15, 0.25))]
    )
    kw["lights"] = side_light((1.0, 0.0, 0.0))
    lit, shadowed = (
        render_image(strands, mesh, shadows=False, **kw),
        render_image(strands, mesh, **kw),
    )
    cols = columns(-0.155, -0.135)
    level = slice(95, 106)
    above = slice(*sorted(int(FRONT.project([(0, y, 0)], SIZE)[0][0, 1]) for y in (0.22, 0.18)))
    assert brightness(shadowed, level, cols) < 0.25 * brightness(lit, level, cols)
    assert brightness(shadowed, above, cols) > 0.8 * brightness(lit, above, cols)


def test_the_lit_side_of_the_skin_has_no_shadow_acne():
    kw = dict(
        camera=FRONT,
        size=SIZE,
        background=BLACK,
        msaa=0,
        skin_color=(0.6, 0.6, 0.6),
        lights=[Light((0.4, 0.5, 0.77), space="world")],
        shading_params={"skin_wrap": 0.0},
    )
    a = render_image(None, sphere(0.1), shadows=False, **kw).astype(int)
    b = render_image(None, sphere(0.1), shadows=True, **kw).astype(int)
    lit = a[..., 0] > 60  # away from the terminator
    # and a pixel in from the silhouette, where two-sided shading flips grazing normals
    inner = lit[1:-1, 1:-1] & lit[:-2, 1:-1] & lit[2:, 1:-1] & lit[1:-1, :-2] & lit[1:-1, 2:]
    assert inner.sum() > 2000
    assert np.abs(a - b)[1:-1, 1:-1][inner].max() <= 2


@pytest.mark.slow
def test_shadow_density_and_layer_parameters():
    curves = HairCurves.concatenate([sheet(0.03, 0.08, 400, 1), sheet(-0.08, -0.03, 400, 2)])
    kw = dict(
        camera=FRONT,
        size=SIZE,
        background=BLACK,
        msaa=0,
        hair_color=(0.5, 0.4, 0.3),
        lights=side_light((1.0, 0.0, 0.0)),
    )
    rows, behind = slice(90, 111), columns(-0.075, -0.035)
    none = render_image(curves, shadows=False, **kw)
    zero = render_image(curves, shading_params={**PLAIN, "shadow_density": 0.0}, **kw)
    light = render_image(curves, shading_params={**PLAIN, "shadow_density": 0.05}, **kw)
    dense = render_image(curves, shading_params={**PLAIN, "shadow_density": 2.0}, **kw)
    np.testing.assert_array_equal(
        render_image(curves, shadows=False, shading_params=PLAIN, **kw),
        render_image(curves, shading_params={**PLAIN, "shadow_density": 0.0}, **kw),
    )
    values = [brightness(img, rows, behind) for img in (zero, light, dense)]
    assert values[0] > values[1] > values[2]
    assert none.shape == zero.shape
    # in one thick layer a strand sees only a sliver of the opacity in front of it
    thin = render_image(curves, shading_params={**PLAIN, "shadow_layer": 0.002}, **kw)
    thick = render_image(curves, shading_params={**PLAIN, "shadow_layer": 0.5}, **kw)
    assert brightness(thick, rows, behind) > 2 * brightness(thin, rows, behind)


@gl  # an OpenGL Renderer of its own, whatever the engine
@pytest.mark.parametrize("size", [(48, 40), (700, 600)])  # smaller / larger than the maps
def test_a_reused_renderer_draws_what_a_fresh_one_does(size):
    """Nothing of one frame (viewports, maps) leaks into the next, nor does a viewport
    set by whoever shares the context (a window)."""
    a = sheet(0.03, 0.08, 300, 1)
    b = HairCurves.concatenate([sheet(0.03, 0.08, 300, 1), sheet(-0.08, -0.03, 300, 2)])
    kw = dict(camera=FRONT, settings=RenderParams(lights=side_light((1.0, 0.0, 0.0))))
    with Renderer(size=size, msaa=0) as r:
        first = r.draw(b, sphere(0.02), **kw)
        r.draw(a, **kw)
        r.ctx.viewport = (0, 0, 7, 5)  # moderngl: the bound framebuffer's viewport
        again = r.draw(b, sphere(0.02), **kw)
    with Renderer(size=size, msaa=0) as r:
        fresh = r.draw(b, sphere(0.02), **kw)
    np.testing.assert_array_equal(first, fresh)
    np.testing.assert_array_equal(again, fresh)


def plate_over_floor() -> StandInMesh:
    """A floor at z = 0 and, 4 cm above it, a plate over x < -0.05 (thin boxes)."""
    floor = trimesh.creation.box(extents=(0.3, 0.3, 0.002))
    floor.apply_translation((0.0, 0.0, -0.001))
    plate = trimesh.creation.box(extents=(0.2, 0.3, 0.002))
    plate.apply_translation((-0.15, 0.0, 0.04))
    return StandInMesh(trimesh.util.concatenate([floor, plate]))


@pytest.mark.parametrize("softness", [0.0, 0.01])
def test_the_skin_shadow_edge_is_as_soft_as_skin_softness(softness):
    """The plate's shadow falls on the floor 3 cm past its edge (light from −x, 37° off
    the normal); across the edge the floor's brightness ramps from the shadow to the
    light over about ``skin_softness`` (a box filter: 10–90 % over 0.8 of its width),
    and over a shadow-map texel or two with 0."""
    camera = Camera(eye=(0.0, 0.0, 0.6), target=(0.0, 0.0, 0.0), fov_y=12.0)
    size = (401, 401)
    kw = dict(
        camera=camera,
        size=size,
        background=BLACK,
        msaa=0,
        skin_color=(0.6, 0.6, 0.6),
        lights=[Light((-0.6, 0.0, 0.8), space="world")],
        shading_params={"skin_wrap": 0.0, "skin_softness": softness},
    )
    img = render_image(None, plate_over_floor(), shadows=True, **kw)
    xs = np.linspace(-0.045, 0.04, 341)
    xy, _ = camera.project(np.column_stack([xs, np.zeros_like(xs), np.zeros_like(xs)]), size)
    row = srgb_to_linear(img[200, :, 0] / 255.0)
    profile = row[np.floor(xy[:, 0]).astype(int)]
    dark, lit = profile[xs < -0.035].mean(), profile[xs > 0.02].mean()
    assert lit > 4 * dark + 0.05  # a real shadow, and the floor beyond it fully lit
    share = (profile - dark) / (lit - dark)
    x10, x90 = xs[np.argmax(share > 0.1)], xs[np.argmax(share > 0.9)]
    assert -0.04 < x10 < x90 < 0.0  # around the geometric edge at x = -0.02
    width = x90 - x10
    if softness:
        assert 0.5 * 0.8 * softness < width < 1.5 * 0.8 * softness, width
    else:
        assert width < 2.5e-3, width
