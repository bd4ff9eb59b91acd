"""OpenGL renderer on headless EGL (Mesa llvmpipe in CI): real pixels, no timing."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from follicle.curves import HairCurves
from follicle.errors import ConfigError, InputError
from follicle.render import Camera, Light, Renderer, render_image, save_png
from follicle.render.engines import make_renderer
from follicle.render.image import encode_srgb8, linear_to_srgb, srgb_to_linear
from follicle.render.settings import RenderParams
from follicle.render.strands import back_to_front, segment_indices, strand_seeds
from glmark import gl

pytestmark = pytest.mark.usefixtures("each_engine")  # each test on both engines


class StandInMesh:
    """The slice of SkinMesh the renderer uses."""

    def __init__(self, tm: trimesh.Trimesh) -> None:
        self.vertices = np.asarray(tm.vertices, dtype=np.float64)
        self.faces = np.asarray(tm.faces, dtype=np.int64)
        self._normals = np.asarray(tm.vertex_normals, dtype=np.float64)

    def vertex_normals(self, which: str = "current") -> np.ndarray:
        return self._normals

    def bounds(self, which: str = "current"):
        return self.vertices.min(axis=0), self.vertices.max(axis=0)


def sphere(radius: float = 0.1, center=(0.0, 0.0, 0.0)) -> StandInMesh:
    tm = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    tm.apply_translation(center)
    return StandInMesh(tm)


FRONT = Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0), fov_y=35.0)
BLACK = (0.0, 0.0, 0.0)
FLAT = {"specular": 0.0, "specular2": 0.0, "root_occlusion": 0.0, "roundness": 0.0}


def px(point, size, camera=FRONT) -> tuple[float, float]:
    """Pixel (x, y) of a world point, origin at the top-left image corner."""
    xy, _ = camera.project([point], size)
    return float(xy[0, 0]), float(xy[0, 1])


def strand(a, b, n: int = 8, width: float | None = None) -> HairCurves:
    pts = np.linspace(a, b, n)
    pd = {} if width is None else {"width": np.full(n, width)}
    return HairCurves.from_array(pts[None], point_data=pd)


# ---------------------------------------------------------------------------- no GL
def test_segment_indices_clamp_end_points():
    idx = segment_indices(np.array([0, 2, 5]))
    np.testing.assert_array_equal(idx, [[0, 0, 1, 1], [2, 2, 3, 4], [2, 3, 4, 4]])
    assert idx.dtype == np.uint32


def test_segment_indices_many_curves():
    offsets = np.arange(20001, dtype=np.int64) * 16
    idx = segment_indices(offsets)
    assert idx.shape == (20000 * 15, 4)
    np.testing.assert_array_equal(idx[15], [16, 16, 17, 18])
    np.testing.assert_array_equal(idx[-1], [319997, 319998, 319999, 319999])


def test_back_to_front_orders_segments_by_view_depth():
    pts = np.array([[0, 0, 0.5], [0, 0.1, 0.5], [0, 0, -0.5], [0, 0.1, -0.5]], np.float32)
    segs = segment_indices(np.array([0, 2, 4]))
    ordered = back_to_front(segs, pts, FRONT)  # camera at +Z looking to -Z
    np.testing.assert_array_equal(ordered[:, 1], [2, 0])  # the far (z=-0.5) one first


def test_strand_seeds_are_constant_per_curve_and_spread():
    seeds = strand_seeds(np.array([0, 3, 5, 9]))
    assert seeds.dtype == np.float32 and seeds.shape == (9,)
    np.testing.assert_array_equal(seeds[:3], seeds[0])
    np.testing.assert_array_equal(seeds[5:], seeds[5])
    assert len(set(seeds.tolist())) == 3 and np.all((seeds >= 0) & (seeds < 1))


def test_thin_strands_accumulate_coverage():
    """Sub-pixel strands add up: 8 stacked ones cover far more than one. Each lies along
    the middle of a pixel row (an engine with area coverage splits a strand on a row
    boundary between the two rows)."""
    size = (48, 48)

    def centred(z: float) -> HairCurves:
        y = -0.5 * FRONT.pixel_scale(size[1]) * (1.0 - z)  # half a pixel down at depth 1 - z
        return strand((-0.1, y, z), (0.1, y, z), width=2e-4)

    one = centred(0.0)
    many = HairCurves.concatenate([centred(-0.01 * k) for k in range(8)])
    kw = dict(
        camera=FRONT,
        size=size,
        background=BLACK,
        msaa=0,
        shading_params=FLAT,
        hair_color=(1.0, 1.0, 1.0),
        lights=[Light.ambient(intensity=1.0)],
    )
    row = int(px((0, -0.5 * FRONT.pixel_scale(size[1]), 0), size)[1])
    lum_one = render_image(one, **kw)[row, 24, 0].astype(int)
    lum_many = render_image(many, **kw)[row, 24, 0].astype(int)
    assert 0 < lum_one < 200
    assert lum_many > lum_one + 60


def test_nearer_strand_stays_on_top_whatever_the_input_order():
    size = (48, 48)
    near = strand((-0.1, 0.0, 0.05), (0.1, 0.0, 0.05), width=0.02)
    far = strand((-0.1, 0.0, -0.05), (0.1, 0.0, -0.05), width=0.02)
    near.point_data["color"] = np.tile([0.0, 1.0, 0.0], (8, 1)).astype(np.float32)
    far.point_data["color"] = np.tile([1.0, 0.0, 0.0], (8, 1)).astype(np.float32)
    kw = dict(
        camera=FRONT,
        size=size,
        background=BLACK,
        shading_params=FLAT,
        lights=[Light.ambient(intensity=1.0)],
    )
    for parts in ([near, far], [far, near]):
        img = render_image(HairCurves.concatenate(parts), **kw)
        r, g = img[24, 24, 0], img[24, 24, 1]
        assert g > 200 and r < 30


def test_srgb_round_trip_and_encoding():
    x = np.linspace(0, 1, 101)
    np.testing.assert_allclose(srgb_to_linear(linear_to_srgb(x)), x, atol=1e-12)
    assert linear_to_srgb(0.5) == pytest.approx(0.7354, abs=1e-4)
    rgba = np.array([[0.0, 0.5, 1.0, 0.5]])
    np.testing.assert_array_equal(encode_srgb8(rgba), [[0, 188, 255, 128]])
    np.testing.assert_array_equal(encode_srgb8(rgba.astype(np.float16)), [[0, 188, 255, 128]])


# ---------------------------------------------------------------------------- GL
def test_strand_covers_expected_row_band():
    size, width = (200, 200), 0.02
    y0 = 0.05
    curves = strand((-0.15, y0, 0.0), (0.15, y0, 0.0), width=width)
    img = render_image(
        curves,
        camera=FRONT,
        size=size,
        background=BLACK,
        hair_color=(1, 1, 1),
        msaa=0,
        lights=[Light.ambient(intensity=1.0)],
        shading_params=FLAT,
    )
    x0, py = px((-0.15, y0, 0.0), size)
    x1, _ = px((0.15, y0, 0.0), size)
    half_px = width / FRONT.pixel_scale(size[1]) / 2  # ≈ 3.2 px
    hair = img[..., :3].max(axis=2) > 0
    rows, cols = np.nonzero(hair)
    assert rows.size > 0
    # pixel (i, j) has its centre at (j + 0.5, i + 0.5)
    assert np.all(np.abs(rows + 0.5 - py) <= half_px + 1.0)
    assert np.all((cols + 0.5 >= x0 - 1.0) & (cols + 0.5 <= x1 + 1.0))
    # the band is filled at the middle column, and solid white at its centre row
    mid = size[0] // 2
    band = np.nonzero(hair[:, mid])[0]
    assert band.size >= int(2 * half_px) - 1
    assert img[int(py), mid, 0] == 255


def test_thin_hair_is_faded_not_aliased():
    size = (200, 200)
    thin = strand((-0.15, 0.0, 0.0), (0.15, 0.0, 0.0), width=1e-5)  # ~0.003 px wide
    kwargs = dict(
        camera=FRONT,
        size=size,
        background=BLACK,
        hair_color=(1, 1, 1),
        lights=[Light.ambient(intensity=1.0)],
        shading_params=FLAT,
    )
    img = render_image(thin, **kwargs)
    column = img[:, 100, 0]
    assert 0 < column.max() < 128  # visible, but with its low coverage


def test_kajiya_kay_diffuse_follows_tangent_light_angle():
    size = (200, 200)
    light = [Light((0.0, 1.0, 0.0))]
    perpendicular = strand((-0.15, 0.05, 0.0), (-0.02, 0.05, 0.0), width=0.01)  # along x
    parallel = strand((0.08, -0.08, 0.0), (0.08, 0.1, 0.0), width=0.01)  # along y, the light
    curves = HairCurves.concatenate([perpendicular, parallel])
    kw = dict(
        camera=FRONT,
        size=size,
        background=BLACK,
        hair_color=(0.5, 0.5, 0.5),
        lights=light,
        shading_params=FLAT,
    )
    img = render_image(curves, **kw).astype(int)
    xa, ya = px((-0.085, 0.05, 0.0), size)
    xb, yb = px((0.08, 0.01, 0.0), size)
    a = img[int(ya), int(xa), 0]
    b = img[int(yb), int(xb), 0]
    assert a > b + 80, (a, b)
    # tilted 45°: sin = 0.71, in between
    tilted = strand((-0.1, -0.1, 0.0), (0.1, 0.1, 0.0), width=0.01)
    img45 = render_image(tilted, **kw)
    c = int(img45[100, 100, 0])
    assert b + 20 < c < a - 10, (a, b, c)


def test_mesh_sphere_disc_and_skin_colour():
    size = (160, 160)
    bg = (0.0, 0.0, 0.3)
    img = render_image(None, sphere(0.1), camera=FRONT, size=size, background=bg)
    bg8 = encode_srgb8(np.array([*bg, 1.0]))[:3]
    yy, xx = np.mgrid[0:160, 0:160] + 0.5
    # apparent radius of a sphere seen from distance 1
    r_px = np.tan(np.arcsin(0.1)) / np.tan(np.radians(17.5)) * 80
    dist = np.hypot(xx - 80, yy - 80)
    is_bg = np.all(img[..., :3] == bg8, axis=2)
    assert not is_bg[dist < r_px - 1.5].any()
    assert is_bg[dist > r_px + 1.5].all()
    r, g, b = img[80, 80, :3].astype(int)
    assert r > g > b and r > 100  # skin, not background
    assert np.all(img[..., 3] == 255)


def test_empty_curves_with_mesh_renders_mesh_only():
    mesh = sphere(0.1)
    empty = HairCurves(np.zeros((0, 3)), [0])
    a = render_image(empty, mesh, size=(64, 64))
    b = render_image(None, mesh, size=(64, 64))
    np.testing.assert_array_equal(a, b)


def test_hair_in_front_of_mesh_is_visible():
    size = (160, 160)
    mesh = sphere(0.1)
    curves = strand((-0.05, 0.0, 0.15), (0.05, 0.0, 0.15), width=0.004)
    with_hair = render_image(
        curves, mesh, camera=FRONT, size=size, hair_color=(0, 1, 0), shading_params=FLAT
    )
    without = render_image(None, mesh, camera=FRONT, size=size)
    # the hair moves the light's shadow-map grid: the skin's soft shadow edges (the
    # terminator) may change by a level
    diff = np.any(np.abs(with_hair.astype(int) - without) > 2, axis=2)
    rows = np.nonzero(diff)[0]
    assert rows.size and abs(rows.mean() + 0.5 - 80) < 2
    assert with_hair[80, 80, 1] > with_hair[80, 80, 0]  # green hair over the skin


def test_background_gradient_top_and_bottom():
    top, bottom = (0.8, 0.1, 0.1), (0.05, 0.1, 0.6)
    curves = strand((-0.01, 0.0, 0.0), (0.01, 0.0, 0.0))
    img = render_image(curves, camera=FRONT, size=(64, 64), background=(top, bottom)).astype(int)
    top8 = encode_srgb8(np.array([*top, 1.0]))[:3].astype(int)
    bottom8 = encode_srgb8(np.array([*bottom, 1.0]))[:3].astype(int)
    assert np.abs(img[0, 5, :3] - top8).max() <= 6
    assert np.abs(img[-1, 5, :3] - bottom8).max() <= 6
    assert img[0, 5, 0] > img[-1, 5, 0] and img[0, 5, 2] < img[-1, 5, 2]
    flat = render_image(curves, camera=FRONT, size=(64, 64), background=top)
    assert np.all(flat[0, :, :3] == flat[-1, :, :3])


def test_msaa_produces_intermediate_edge_values():
    mesh = sphere(0.1)
    kwargs = dict(
        camera=FRONT,
        size=(96, 96),
        background=BLACK,
        skin_color=(1, 1, 1),
        lights=[Light.ambient(intensity=1.0)],
    )
    aliased = render_image(None, mesh, msaa=0, **kwargs)[..., 0]
    smooth = render_image(None, mesh, msaa=4, **kwargs)[..., 0]
    assert set(np.unique(aliased)) <= {0, 255}
    intermediate = (smooth > 10) & (smooth < 245)
    assert intermediate.sum() > 50


def test_png_matches_returned_array(tmp_path):
    from PIL import Image

    out = tmp_path / "sub" / "hair.png"
    curves = strand((-0.1, 0.0, 0.0), (0.1, 0.05, 0.0), width=0.003)
    img = render_image(curves, sphere(0.05, (0, 0, -0.1)), size=(80, 60), out=out)
    assert img.shape == (60, 80, 4) and img.dtype == np.uint8
    with Image.open(out) as png:
        assert png.mode == "RGBA"
        np.testing.assert_array_equal(np.asarray(png), img)
    assert [p.name for p in out.parent.iterdir()] == ["hair.png"]  # no temporary left
    save_png(img[..., :3], tmp_path / "rgb.png")
    with Image.open(tmp_path / "rgb.png") as png:
        np.testing.assert_array_equal(np.asarray(png), img[..., :3])


def test_render_is_deterministic():
    rng = np.random.default_rng(7)
    roots = rng.uniform(-0.1, 0.1, size=(300, 3))
    pts = roots[:, None, :] + np.linspace(0, 1, 6)[None, :, None] * rng.normal(
        scale=0.05, size=(300, 1, 3)
    )
    curves = HairCurves.from_array(pts, point_data={"width": np.full(1800, 2e-4)})
    mesh = sphere(0.08)
    a = render_image(curves, mesh, size=(128, 128))
    b = render_image(curves, mesh, size=(128, 128))
    assert a.tobytes() == b.tobytes()


@gl  # an OpenGL Renderer of its own, whatever the engine
def test_renderer_reuse_and_per_vertex_attributes():
    curves = strand((-0.1, 0.0, 0.0), (0.1, 0.0, 0.0), n=4)
    red = HairCurves(
        curves.points,
        curves.offsets,
        {
            "width": np.full(4, 0.05),
            "color": np.tile([1.0, 0.0, 0.0], (4, 1)),
            "opacity": np.ones(4),
        },
    )
    flat = RenderParams(lights=[Light.ambient(intensity=1.0)], shading_params=FLAT)
    with Renderer(size=(64, 64), msaa=4, background=BLACK) as r:
        a = r.draw(red, camera=FRONT, settings=flat)
        b = r.draw(red, camera=FRONT, settings=flat.replace(subdivisions=16))
    assert a[32, 32, 0] == 255 and a[32, 32, 1] == 0
    np.testing.assert_array_equal(a, b)  # a straight strand does not change with smoothing


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"size": (0, 10)}, r"\[render\]\.size\.0: Input should be greater than or equal to 1"),
        ({"size": (10.5, 10)}, r"\[render\]\.size\.0: Input should be a valid integer"),
        ({"size": (9000, 10)}, r"\[render\]\.size\.0: Input should be less than or equal to 8192"),
        ({"size": (10,)}, r"\[render\]\.size\.1: Field required"),
        ({"shading": "phong"}, r"\[render\]\.shading: Input should be 'kajiya-kay'"),
        ({"msaa": -1}, r"\[render\]\.msaa: Input should be 0, 1, 2, 4, 8 or 16"),
        ({"subdivisions": 0}, r"\[render\]\.subdivisions: Input should be greater than"),
        ({"subdivisions": 17}, r"\[render\]\.subdivisions: Input should be less than"),
        ({"background": (1, 2)}, r"\[render\]\.background_top: Input should be a valid tuple"),
        ({"background": 3}, r"background: expected one linear RGB colour"),
        ({"shading_params": {"glossiness": 3}}, r"\[render\]: shading_params: unknown key"),
        ({"hair_width": -1.0}, r"\[render\]\.hair_width: Input should be greater than 0"),
        ({"lights": ["sun"]}, r"\[render\]\.lights\.0: Input should be a valid dictionary"),
        ({"glossiness": 3}, r"\[render\]\.glossiness: unknown key; allowed keys: size,"),
    ],
)
def test_bad_settings_are_config_errors_naming_the_key(kwargs, message):
    """Keyword overrides go through RenderParams.replace: a bad one is the ConfigError a
    scene file's [render] gets, before any framebuffer is made."""
    curves = strand((-0.1, 0.0, 0.0), (0.1, 0.0, 0.0))
    with pytest.raises(ConfigError, match=rf"^render: .*{message}"):
        render_image(curves, **{"size": (32, 32), **kwargs})


def test_settings_and_overrides_draw_as_one_object(each_engine):
    """``render_image(settings=p, key=v)`` draws what
    ``render_image(settings=p.replace(key=v))`` does, and what the settings' engine's
    renderer drawing those settings does."""
    curves = strand((-0.1, 0.0, 0.0), (0.1, 0.0, 0.0))
    base = RenderParams(
        engine=each_engine, size=(48, 32), msaa=0, hair_color=(0.05, 0.8, 0.05), hair_width=0.05
    )
    given = render_image(curves, camera=FRONT, settings=base, shading="marschner", shadows=False)
    changed = base.replace(shading="marschner", shadows=False)
    np.testing.assert_array_equal(given, render_image(curves, camera=FRONT, settings=changed))
    with make_renderer(changed) as r:
        assert type(r).__name__ == ("Renderer" if each_engine == "opengl" else "CpuRenderer")
        np.testing.assert_array_equal(given, r.draw(curves, camera=FRONT, settings=changed))
    assert given[16, 24, 1] > given[16, 24, 0] + 40  # the settings' green hair
    with pytest.raises(InputError, match="settings: expected RenderParams"):
        render_image(curves, settings={"size": (8, 8)})


def test_nothing_to_draw_raises():
    with pytest.raises(InputError, match="nothing to draw"):
        render_image(None)
    with pytest.raises(InputError, match="nothing to draw"):
        render_image(HairCurves(np.zeros((0, 3)), [0]))
    with pytest.raises(
        ConfigError, match="should be 'kajiya-kay', 'scheuermann', 'marschner' or 'physical'"
    ):
        render_image(None, sphere(), shading="phong")
    with pytest.raises(InputError):
        render_image(np.zeros((4, 3)))  # not HairCurves


def test_follicle_render_image_works_after_a_submodule_import():
    import follicle
    import follicle.render.camera  # noqa: F401  binds the package to follicle.render

    img = follicle.render_image(strand((-0.1, 0.0, 0.0), (0.1, 0.0, 0.0)), size=(16, 16))
    assert img.shape == (16, 16, 4) and follicle.render.render_image is follicle.render_image
