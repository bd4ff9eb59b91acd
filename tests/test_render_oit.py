"""Order-independent transparency and coverage: the image does not depend on the order
of the curves, and hair covers what its geometry says, down to sub-pixel widths."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.curves import HairCurves
from follicle.render import Camera, Light, opengl, render_image
from follicle.render.cpu import engine as cpu_engine
from follicle.render.image import srgb_to_linear
from follicle.render.settings import RenderParams
from follicle.render.strands import vertex_tangents
from glmark import gl

pytestmark = pytest.mark.usefixtures("each_engine")  # each test on both engines

FRONT = Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0), fov_y=35.0)
SIZE = (200, 200)
WHITE_FLAT = dict(
    camera=FRONT,
    size=SIZE,
    background=(0, 0, 0),
    hair_color=(1, 1, 1),
    msaa=0,
    lights=[Light.ambient(intensity=1.0)],
    shading_params={"root_occlusion": 0.0, "roundness": 0.0},
)
# measured: weighted blended OIT gives the same bytes in any order here (float sums may
# round differently elsewhere); unsorted "over" blending differs by ~4/255 on average
# and up to ~130/255, so these limits tell the two apart by a wide margin
MEAN_LIMIT, MAX_LIMIT = 0.1, 2


def crossing_strands(count: int = 2000, seed: int = 1, width: float = 4e-3) -> HairCurves:
    """Random, overlapping, half-transparent strands of random colours."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(-0.1, 0.1, (count, 3))
    d = rng.normal(size=(count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pts = start[:, None] + np.linspace(0.0, 0.12, 8)[None, :, None] * d[:, None]
    n = count * 8
    return HairCurves.from_array(
        pts,
        point_data={
            "width": np.full(n, width),
            "opacity": np.full(n, 0.8),
            "color": np.repeat(rng.uniform(0, 1, (count, 3)), 8, axis=0),
        },
    )


def order_difference(curves: HairCurves, **kw) -> tuple[float, int]:
    """(mean, max) |difference| in 8-bit levels between the curves in order and shuffled."""
    shuffled = curves[np.random.default_rng(2).permutation(curves.curve_count)]
    a = render_image(curves, **kw).astype(int)[..., :3]
    b = render_image(shuffled, **kw).astype(int)[..., :3]
    return float(np.abs(a - b).mean()), int(np.abs(a - b).max())


@pytest.mark.parametrize("msaa", [0, 4])
@pytest.mark.slow
def test_curve_order_does_not_change_the_image(msaa, monkeypatch):
    curves = crossing_strands()
    kw = dict(size=(128, 128), msaa=msaa, background=(0.1, 0.1, 0.1))
    mean, biggest = order_difference(curves, **kw)
    assert mean < MEAN_LIMIT and biggest <= MAX_LIMIT, (mean, biggest)
    # the limits catch order-dependent blending: "over" without the back-to-front sort
    monkeypatch.setattr(opengl, "back_to_front", lambda segments, points, camera: segments)
    unsorted = lambda steps, start: np.arange(len(start) - 1)  # noqa: E731
    monkeypatch.setattr(cpu_engine, "_back_to_front", unsorted)
    # and the curves in their own order (the CPU engine's space order, by the roots'
    # place, would give both orders the same drawing order)
    in_order = lambda points, offsets, bits: np.arange(len(offsets) - 1)  # noqa: E731
    monkeypatch.setattr(cpu_engine, "space_order", in_order)
    mean, biggest = order_difference(curves, oit=False, **kw)
    assert mean > 10 * MEAN_LIMIT and biggest > 10 * MAX_LIMIT, (mean, biggest)


def test_oit_off_sorts_back_to_front():
    """The foundation's path stays available: sorted "over" blending is order-free too."""
    mean, biggest = order_difference(crossing_strands(500), size=(96, 96), msaa=0, oit=False)
    assert mean < MEAN_LIMIT and biggest <= MAX_LIMIT


def parallel_strands(width: float, spacing: float, rows: int = 12) -> HairCurves:
    """Horizontal strands at depth 1, ``spacing`` apart, centred on the view."""
    ys = (np.arange(rows) - (rows - 1) / 2) * spacing
    pts = np.stack([np.linspace([-0.1, y, 0.0], [0.1, y, 0.0], 6) for y in ys])
    return HairCurves.from_array(pts, point_data={"width": np.full(rows * 6, width)})


def region(spacing: float, rows: int = 12) -> tuple[slice, slice]:
    """Image rows and columns spanned by the strands: whole spacings, no border."""
    px = FRONT.pixel_scale(SIZE[1])
    half_h, half_w = rows * spacing / 2 / px, 0.09 / px
    return (
        slice(int(100 - half_h + 0.5), int(100 + half_h + 0.5)),
        slice(int(100 - half_w), int(100 + half_w)),
    )


def test_wide_hair_covers_its_geometric_share_of_pixels():
    px = FRONT.pixel_scale(SIZE[1])  # metres per pixel at depth 1
    width, spacing = 3.3 * px, 10.0 * px
    img = render_image(parallel_strands(width, spacing), **WHITE_FLAT)
    rows, cols = region(spacing)
    covered = (img[rows, cols, 0] > 0).mean()
    # each strand lights its width in rows, give or take one row at its edges
    assert (3.3 - 1) / 10 <= covered <= (3.3 + 1) / 10, covered


@pytest.mark.parametrize("msaa", [0, 4])
@pytest.mark.parametrize("width_px", [0.1, 0.25, 0.6])
def test_sub_pixel_hair_covers_by_opacity(width_px, msaa):
    """Hair thinner than a pixel is drawn one pixel wide with opacity width / pixel: the
    mean linear value of a region is the share of it the hair covers."""
    px = FRONT.pixel_scale(SIZE[1])
    spacing = 4.0 * px
    img = render_image(parallel_strands(width_px * px, spacing), **{**WHITE_FLAT, "msaa": msaa})
    rows, cols = region(spacing)
    mean = srgb_to_linear(img[rows, cols, 0] / 255.0).mean()
    assert mean == pytest.approx(width_px / 4.0, rel=0.08), mean
    # soft: no pixel is brighter than one strand's coverage (and a little rounding)
    assert srgb_to_linear(img[rows, cols, 0] / 255.0).max() <= width_px * 1.05 + 0.01


@pytest.mark.parametrize("msaa", [0, 4])
@pytest.mark.parametrize("degrees", [20.0, 45.0, 70.0])
def test_sub_pixel_coverage_holds_at_any_angle(degrees, msaa):
    """A slanted one-pixel line has one fragment per pixel of its major axis: each must
    carry length / max(|dx|, |dy|) of the hair (multisampled lines need no correction)."""
    px = FRONT.pixel_scale(SIZE[1])
    a = np.radians(degrees)
    along, across = np.array([np.cos(a), np.sin(a), 0.0]), np.array([-np.sin(a), np.cos(a), 0.0])
    spacing, width = 4.0 * px, 0.3 * px
    pts = np.stack(
        [
            k * spacing * across + np.linspace(-0.25, 0.25, 6)[:, None] * along
            for k in range(-16, 17)
        ]
    )
    curves = HairCurves.from_array(pts, point_data={"width": np.full(pts.shape[0] * 6, width)})
    img = render_image(curves, **{**WHITE_FLAT, "msaa": msaa})
    box = srgb_to_linear(img[70:131, 70:131, 0] / 255.0)
    assert box.mean() == pytest.approx(0.3 / 4.0, rel=0.08), box.mean()


def test_vertex_tangents_are_the_geometry_shaders_step_tangents():
    pts = np.array(
        [
            [0, 0, 0],
            [1, 0, 0],
            [3, 0, 0],
            [3, 2, 0],  # a curve of 4
            [5, 5, 5],  # a lone vertex
            [0, 0, 0],
            [1, 0, 0],
            [0, 0, 0],
        ],
        float,
    )  # a hairpin: P2 − P0 = 0 at P1
    got = vertex_tangents(pts, np.array([0, 4, 5, 8]))
    want = [
        [0.5, 0, 0],
        [1.5, 0, 0],
        [1, 1, 0],
        [0, 1, 0],
        [0, 0, 0],
        [0.5, 0, 0],
        [-1, 0, 0],
        [-0.5, 0, 0],
    ]
    np.testing.assert_allclose(got, want, atol=1e-7)
    assert got.dtype == np.float32


@gl  # an OpenGL Renderer of its own, whatever the engine
@pytest.mark.parametrize("shading", ["kajiya-kay", "marschner"])
def test_one_step_lines_without_a_geometry_shader_draw_its_picture(shading, monkeypatch):
    """At subdivisions 1 thin hair skips the geometry shader: the same primitives, and
    the picture of the geometry shader's lines to within one level."""
    thin = crossing_strands(800, width=3e-4)
    pictures, drawn = [], []
    for plain in (True, False):  # False: through the geometry shader
        monkeypatch.setattr(opengl, "PLAIN_LINES", plain)
        with opengl.Renderer(size=(160, 160), msaa=0, background=(0.1, 0.1, 0.1)) as r:
            query = r.ctx.query(primitives=True)
            with query:
                settings = RenderParams(subdivisions=1, shading=shading, shadows=False)
                pictures.append(r.draw(thin, settings=settings).astype(int))
            drawn.append(query.primitives)
    segments = thin.point_count - thin.curve_count  # + the background and composite triangles
    assert drawn[0] == drawn[1] == segments + 2
    difference = np.abs(pictures[0] - pictures[1])
    assert (pictures[0][..., :3] > 40).mean() > 0.05  # hair drawn
    assert difference.max() <= 1 and difference.mean() < 0.01, difference.mean()
