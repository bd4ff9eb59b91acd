"""Mitsuba 3 reference renderer: same framing and hair coverage as the GL render, colour
from absorption, reproducible images, clear errors, `follicle render --engine mitsuba`."""

import sys

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image
from scipy.ndimage import binary_dilation

from follicle.cli import main
from follicle.curves import HairCurves
from follicle.errors import ConfigError, InputError, ResourceError
from follicle.io.mitsuba import load_mitsuba
from follicle.melanin import absorption_from_color
from follicle.pipeline import groom_scene
from follicle.render import Camera, Light, mitsuba, render_image, srgb_to_linear
from follicle.render.mitsuba import render_mitsuba
from follicle.scene import Scene
from glmark import gl

# Mitsuba is the optional pbr extra; the test extra installs it, so CI runs these tests
pytest.importorskip("mitsuba")

SIZE = (64, 64)


@pytest.fixture(scope="module")
def head():
    """The built-in head and 300 long hairs grown on it."""
    groom = groom_scene(Scene())
    return groom.mesh, groom.generate(300)


def thick(hair: HairCurves, width: float = 1e-3, color=None) -> HairCurves:
    """The hair 1 mm thick (a fair share of a 9 mm pixel at 64²), optionally recoloured."""
    pd = {"width": np.full(hair.point_count, width, np.float32)}
    pd["color"] = (
        hair.point_data["color"]
        if color is None
        else np.broadcast_to(np.float32(color), (hair.point_count, 3))
    )
    return HairCurves(hair.points, hair.offsets, pd)


def coverage(draw, curves, **kw) -> np.ndarray:
    """Per-pixel share (H, W) covered by the hair: 1 − (image on white − image on black)."""
    on_black = srgb_to_linear(draw(curves, size=SIZE, background=(0, 0, 0), **kw)[..., :3] / 255)
    on_white = srgb_to_linear(draw(curves, size=SIZE, background=(1, 1, 1), **kw)[..., :3] / 255)
    return 1.0 - (on_white - on_black).mean(axis=2)


def luminance(image: np.ndarray) -> np.ndarray:
    return srgb_to_linear(image[..., :3] / 255) @ np.array([0.2126, 0.7152, 0.0722])


@pytest.mark.slow
def test_renders_hair_on_the_head(head):
    mesh, hair = head
    image = render_mitsuba(hair, mesh, size=SIZE, spp=4)
    assert image.shape == (64, 64, 4) and image.dtype == np.uint8
    assert np.all(image[..., 3] == 255)
    background = render_mitsuba(hair[:1], None, size=SIZE, spp=4)  # one hair: ~ all background
    changed = np.abs(image[..., :3].astype(int) - background[..., :3]).max(axis=2) > 8
    assert 0.05 < changed.mean() < 0.5  # the head (11 %), framed with its hair around it


@pytest.mark.slow
def test_same_seed_same_bytes(head):
    mesh, hair = head
    a = render_mitsuba(hair, mesh, size=SIZE, spp=4, seed=3)
    b = render_mitsuba(hair, mesh, size=SIZE, spp=4, seed=3)
    c = render_mitsuba(hair, mesh, size=SIZE, spp=4, seed=4)
    assert a.tobytes() == b.tobytes()
    assert a.tobytes() != c.tobytes()


@gl
@pytest.mark.slow
def test_hair_where_the_gl_render_has_hair(head):
    """Hair coverage per pixel: Mitsuba's alpha (4 rays per pixel) against the GL render's
    (found by rendering on black and on white). Measured: 97.6 % of the GL pixels more
    than half covered get a Mitsuba hit, all Mitsuba hits fall on GL hair, and the mean
    coverage agrees within 3 %."""
    _, hair = head
    hair = thick(hair)
    gl_cover = coverage(render_image, hair)
    mi_cover = coverage(render_mitsuba, hair, spp=4)
    solid = gl_cover > 0.5
    hit = mi_cover > 0.0
    assert solid.sum() > 200
    assert (solid & hit).sum() / solid.sum() > 0.9
    assert (hit & (gl_cover > 0.02)).sum() / hit.sum() > 0.95
    assert mi_cover.mean() == pytest.approx(gl_cover.mean(), rel=0.1)


@gl
@pytest.mark.slow
def test_same_camera_and_background_as_gl(head):
    """A given camera (non-square image, tilted up vector) and the automatic framing both
    put the head on the same pixels; the background is the GL gradient."""
    mesh, _ = head
    tilted = Camera((0.3, 0.5, 0.4), (0.0, -0.05, 0.0), up=(1.0, 0.0, 0.0), fov_y=40.0)
    for camera in (None, tilted):
        kw = {"camera": camera, "size": (80, 48)}
        gl_image = render_image(None, mesh, **kw)
        mi_image = render_mitsuba(None, mesh, spp=4, **kw)
        black_gl = render_image(None, mesh, background=(0, 0, 0), **kw)[..., :3].max(axis=2) > 0
        black_mi = render_mitsuba(None, mesh, spp=4, background=(0, 0, 0), **kw)
        black_mi = black_mi[..., :3].max(axis=2) > 0
        assert black_gl.sum() > 300
        assert (black_gl ^ black_mi).sum() < 0.05 * black_gl.sum()  # edge pixels only
        # and a pixel round them: a sliver of the head too thin to lift a black pixel to
        # 1/255 still darkens the (bright) background there
        empty = ~binary_dilation(black_gl | black_mi)
        diff = np.abs(gl_image[..., :3].astype(int) - mi_image[..., :3])[empty]
        assert diff.max() <= 1


@pytest.mark.slow
def test_blond_renders_brighter_than_dark(head):
    _, hair = head
    lights = [Light((0.3, 0.5, 1.0), space="camera"), Light.ambient(intensity=0.2)]
    kw = {"size": SIZE, "spp": 4, "lights": lights, "background": (0, 0, 0)}
    blond = luminance(render_mitsuba(thick(hair, color=(0.55, 0.38, 0.2)), **kw)).sum()
    dark = luminance(render_mitsuba(thick(hair, color=(0.02, 0.012, 0.008)), **kw)).sum()
    assert blond > 2.0 * dark > 0


def test_absorption_from_color():
    """Chiang et al. 2016 eq. (the β_n = 0.3 default): white absorbs nothing, darker
    absorbs more, blue-poor brown absorbs blue most."""
    sigma = absorption_from_color([[1.0, 1.0, 1.0], [0.5, 0.5, 0.5], [0.2, 0.1, 0.05]])
    assert np.all(sigma[0] == 0)
    poly = 5.969 - 0.215 * 0.3 + 2.532 * 0.09 - 10.73 * 0.027 + 5.574 * 0.0081 + 0.245 * 0.00243
    assert sigma[1] == pytest.approx(np.full(3, (np.log(0.5) / poly) ** 2))
    assert sigma[2, 0] < sigma[2, 1] < sigma[2, 2]
    assert np.all(sigma[2] > sigma[1])
    assert np.all(np.isfinite(absorption_from_color([0.0, 0.0, 0.0])))


@pytest.mark.slow
def test_colour_follows_each_hair_and_its_length():
    """σ_a is a texture over the curve segments: two hairs side by side, one red, one
    blue at the root and green at the tip, keep their colours where they are."""
    n = 8
    points = np.concatenate(
        [
            np.linspace([-0.05, 0.1, 0], [-0.05, -0.1, 0], n),
            np.linspace([0.05, 0.1, 0], [0.05, -0.1, 0], n),
        ]
    )
    red, blue, green = (0.6, 0.02, 0.02), (0.02, 0.02, 0.6), (0.02, 0.6, 0.02)
    colors = np.array([red] * n + [blue] * 4 + [green] * 4, np.float32)
    hair = HairCurves(
        points, [0, n, 2 * n], {"width": np.full(2 * n, 0.01, np.float32), "color": colors}
    )
    camera = Camera((0, 0, 1), (0, 0, 0), fov_y=30)
    image = render_mitsuba(
        hair,
        camera=camera,
        size=(96, 96),
        spp=8,
        background=(0, 0, 0),
        lights=[Light((0, 0, 1)), Light.ambient(intensity=0.5)],
    )
    rgb = image[..., :3].astype(int)
    left, right = rgb[:, 30:44], rgb[:, 52:66]  # x = ∓0.05 m lands at columns 38 and 57
    assert left[..., 0].sum() > 1.2 * left[..., 2].sum()
    assert right[:40, :, 2].sum() > 1.2 * right[:40, :, 1].sum()  # root half, at the top
    assert right[56:, :, 1].sum() > 1.2 * right[56:, :, 2].sum()  # tip half


def straight_hairs(count: int, vertices: int) -> HairCurves:
    """``count`` straight hairs along +x, 1 cm apart in y, 1 cm per segment, 2 mm wide."""
    x = np.arange(vertices, dtype=np.float32) * 0.01
    points = np.zeros((count, vertices, 3), np.float32)
    points[..., 0] = x
    points[..., 1] = 0.01 * np.arange(count)[:, None]
    width = {"width": np.full(count * vertices, 2e-3, np.float32)}
    return HairCurves.from_array(points, point_data=width)


def test_hair_is_split_into_shapes_each_closed_by_a_zero_width_sentinel(tmp_path, monkeypatch):
    """What Mitsuba receives: whole hairs in shapes of at most MAX_SEGMENTS B-spline
    segments, every file ending in a 2-vertex sentinel of width 0 along its last hair's
    final segment, one absorption texel per segment, the sentinel's included."""
    monkeypatch.setattr(mitsuba, "MAX_SEGMENTS", 50)
    counts = [11] * 12 + [80] + [3] * 7  # 10-segment hairs, one longer than a shape
    hair = HairCurves.from_polylines(
        [
            np.column_stack([np.arange(n), np.full(n, i), np.zeros(n)]) * 0.01
            for i, n in enumerate(counts)
        ]
    )
    shapes = mitsuba._hair_shapes(mitsuba._mitsuba(), hair, np.full(3, 0.3), 1e-3, tmp_path)
    assert list(shapes) == [f"hair_{i}" for i in range(5)]
    parts = []
    for shape in shapes.values():
        loaded = load_mitsuba(shape["filename"])
        real, sentinel = loaded[:-1], loaded[-1:]
        segments = real.point_count - real.curve_count
        assert segments <= 50 or real.curve_count == 1
        np.testing.assert_allclose(sentinel.points, real.points[-2:], atol=1e-6)
        assert np.all(sentinel.point_data["width"] == 0)
        assert np.all(real.point_data["width"] > 0)
        texels = np.array(shape["bsdf"]["sigma_a"]["bitmap"])
        assert texels.shape == (segments + 1, 1, 3)  # v = (segment + t) / S over S rows
        parts.append(real)
    joined = HairCurves.concatenate(parts)
    assert joined.counts.tolist() == counts
    np.testing.assert_allclose(joined.points, hair.points, atol=1e-6)


def test_no_hit_reaches_past_a_shapes_segment_table(tmp_path, monkeypatch):
    """Mitsuba's ``bsplinecurve`` partials() recomputes a hit's segment as
    floor(v · S) from v = (v_local + segment) / S in float32, unclamped: a hit on the
    end of a shape's last segment gave S, one past its table (the segfault at 100,000
    hairs). Rays on the tip of every shape's last hair land on a real segment below
    S − 1, never on the sentinel, and floor(v · S) stays below S."""
    mi = mitsuba._mitsuba()
    monkeypatch.setattr(mitsuba, "MAX_SEGMENTS", 40)
    hair = straight_hairs(12, 11)  # 10 segments a hair: 3 shapes of 4 hairs
    shapes = mitsuba._hair_shapes(mi, hair, np.full(3, 0.3), 2e-3, tmp_path)
    scene = mi.load_dict({"type": "scene", **shapes})
    f32 = np.float32
    hits = 0
    for last in (3, 7, 11):  # the last hair of each shape
        tip = hair.curve(last)[-1]
        for x in np.linspace(tip[0] - 0.002, tip[0] - 1e-6, 200):  # its last fifth
            ray = mi.Ray3f(mi.Point3f(float(x), float(tip[1]), 0.5), mi.Vector3f(0, 0, -1))
            hit = scene.ray_intersect_preliminary(ray)
            assert hit.is_valid()
            size = hit.shape.primitive_count()  # S, the sentinel included
            assert size == 41 and hit.prim_index == size - 2
            v = f32(f32(hit.prim_uv[0]) + f32(hit.prim_index)) / f32(size)
            assert np.floor(f32(v) * f32(size)) < size
            hits += 1
    assert hits == 600


def test_split_hair_renders_as_one_shape(head, tmp_path, monkeypatch):
    """The same head, its 6,900 segments in one shape or in seven: the same picture
    (colour texels follow their shape), rendered in this process."""
    made = []

    def in_process(job, progress):
        out = str(tmp_path / "rgba.npy")
        mitsuba._path_trace(job, out, lambda done: None)
        return np.load(out)

    def hair_shapes(*args):
        made.append(hair_shapes.real(*args))
        return made[-1]

    hair_shapes.real = mitsuba._hair_shapes
    monkeypatch.setattr(mitsuba, "_in_child", in_process)
    monkeypatch.setattr(mitsuba, "_hair_shapes", hair_shapes)
    mesh, hair = head
    one = render_mitsuba(hair, mesh, size=SIZE, spp=4, seed=1)
    monkeypatch.setattr(mitsuba, "MAX_SEGMENTS", 1000)
    seven = render_mitsuba(hair, mesh, size=SIZE, spp=4, seed=1)
    assert [len(shapes) for shapes in made] == [1, 7]
    diff = np.abs(one.astype(int) - seven)
    assert diff.mean() < 0.5 and diff.max() <= 8, (diff.mean(), diff.max())


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"spp": 0}, InputError, "spp: expected a whole number in 1..65536"),
        ({"spp": 2.5}, InputError, "spp"),
        ({"seed": -1}, InputError, "seed"),
        ({"camera": "front"}, InputError, "camera: expected a Camera"),
        ({"settings": "front"}, InputError, "settings: expected RenderParams"),
        # the settings' keys are validated as [render]'s
        ({"size": (0, 10)}, ConfigError, r"^render: \[render\]\.size\.0: Input should be"),
        ({"lights": ["key"]}, ConfigError, r"\[render\]\.lights\.0: Input should be a valid"),
        ({"hair_width": 0.0}, ConfigError, r"\[render\]\.hair_width: Input should be greater"),
    ],
)
def test_bad_input_is_named(head, kwargs, error, match):
    with pytest.raises(error, match=match):
        render_mitsuba(head[1], **kwargs)


def test_nothing_to_draw():
    with pytest.raises(InputError, match="nothing to draw"):
        render_mitsuba(None)


def test_missing_mitsuba_names_the_extra(head, monkeypatch):
    monkeypatch.setitem(sys.modules, "mitsuba", None)  # import mitsuba -> ImportError
    with pytest.raises(InputError, match=r"pip install 'follicle\[pbr\]'"):
        render_mitsuba(head[1], size=SIZE, spp=1)


# the child faked: a segfault after 10 % (as Mitsuba's curve shape on 100,000 hairs),
# and an exception's one line
CRASH = "import os, signal; print(10, flush=True); os.kill(os.getpid(), signal.SIGSEGV)"
ERROR = "print('error: RuntimeError: bsplinecurve: something Mitsuba refused'); exit(1)"


def test_mitsuba_crashing_is_one_error_not_the_process_gone(head, monkeypatch):
    """The path tracer runs in a child: its segfault is one ResourceError naming it,
    progress until then still heard; an exception there is one line too."""
    mesh, hair = head
    heard = []
    monkeypatch.setattr(mitsuba, "_CHILD", [sys.executable, "-c", CRASH])
    with pytest.raises(ResourceError) as caught:
        render_mitsuba(hair, mesh, size=SIZE, spp=1, progress=lambda d, t: heard.append(d))
    assert str(caught.value).startswith("mitsuba crashed with SIGSEGV path-tracing 300 hairs")
    assert heard == [10]
    monkeypatch.setattr(mitsuba, "_CHILD", [sys.executable, "-c", ERROR])
    with pytest.raises(ResourceError, match="failed \\(RuntimeError: bsplinecurve") as caught:
        render_mitsuba(hair, mesh, size=SIZE, spp=1)
    assert "\n" not in str(caught.value)


@pytest.mark.slow
def test_cli_mitsuba_crashing_is_one_line_and_exit_2(tmp_path, monkeypatch):
    (tmp_path / "scene.toml").write_text(SCENE)
    monkeypatch.setattr(mitsuba, "_CHILD", [sys.executable, "-c", CRASH])
    args = ["render", str(tmp_path / "scene.toml"), "--engine", "mitsuba", "--spp", "1"]
    result = CliRunner().invoke(main, [*args, "-o", str(tmp_path / "still.png")])
    assert result.exit_code == 2, result.output
    lines = [x for x in result.output.splitlines() if x.startswith("error:")]
    assert lines == [lines[0]] and "mitsuba crashed with SIGSEGV" in lines[0]
    assert "Traceback" not in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]


SCENE = """\
[guides]
path = "builtin:short"
[groom]
count = 200
[render]
size = [40, 30]
"""


@pytest.mark.slow
def test_cli_engine_mitsuba(tmp_path):
    (tmp_path / "scene.toml").write_text(SCENE)
    out = tmp_path / "still.png"

    def run(*args):
        return CliRunner().invoke(main, ["render", str(tmp_path / "scene.toml"), *args])

    result = run("--engine", "mitsuba", "--spp", "2", "-o", str(out))
    assert result.exit_code == 0, result.output
    assert Image.open(out).size == (40, 30)
    for args, words in (
        (["--engine", "mitsuba", "--msaa", "4"], "--msaa does not apply to --engine mitsuba"),
        (["--spp", "4"], "--spp does not apply to --engine auto"),
        (["--engine", "mitsuba", "--spp", "0"], "[render].spp: Input should be greater than"),
    ):
        result = run(*args, "-o", str(tmp_path / "bad.png"))
        assert result.exit_code == 2 and words in result.output, result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml", "still.png"]


def test_mitsuba_is_an_engine_of_the_registry(head):
    """``render_image(engine="mitsuba")`` path-traces through the engine registry: the
    same image as render_mitsuba at the settings' spp, [render].spp from a scene; a
    raster renderer (the viewer, a cache's frames) refuses the stills-only engine."""
    from follicle.render import make_renderer
    from follicle.render.backends import ENGINES
    from follicle.scene import scene_from_toml

    mesh, hair = head
    direct = render_mitsuba(hair, mesh, size=SIZE, spp=4, seed=0)
    through = render_image(hair, mesh, size=SIZE, engine="mitsuba", spp=4)
    assert np.array_equal(direct, through)
    scene = scene_from_toml('[render]\nengine = "mitsuba"\nspp = 4\n', "s.toml")
    assert (scene.render.engine, scene.render.spp) == ("mitsuba", 4)
    assert ENGINES["mitsuba"].spp and not ENGINES["mitsuba"].sequences
    raster = "'mitsuba': the viewer, .* raster engine: auto, opengl, cpu"
    with pytest.raises(ConfigError, match=raster):
        make_renderer(scene.render)
