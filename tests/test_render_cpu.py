"""The CPU engine (follicle.render.cpu) against the OpenGL engine, and on its own: the
same picture on the examples gallery within the stated tolerance, the same bytes for any
thread count, the automatic engine choice. (Every test of test_render*.py also runs on
both engines, through the ``each_engine`` fixture.)"""

from __future__ import annotations

from pathlib import Path

import numba
import numpy as np
import pytest

from follicle.curves import HairCurves
from follicle.errors import ConfigError, InputError
from follicle.pipeline import grow, render_scene
from follicle.render import (
    Camera,
    CpuRenderer,
    Light,
    engines,
    make_renderer,
    render_image,
    srgb_to_linear,
)
from follicle.render.cpu.steps import space_order
from follicle.render.image import half_bits
from follicle.render.settings import RenderParams
from follicle.scene import Scene, load_scene
from test_render import FLAT, FRONT, sphere

ROOT = Path(__file__).resolve().parents[1]
GALLERY = sorted((ROOT / "examples").glob("*.toml"))
# the tolerance stated in the README: per example, over the RGB of every pixel, in
# 8-bit sRGB levels (measured on the bust gallery: means 0.36-1.50, 99th percentiles 5-13)
MEAN_LEVELS, P99_LEVELS = 3.0, 24.0
ENGINES = ("opengl", "cpu")


def difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    d = np.abs(a[..., :3].astype(int) - b[..., :3].astype(int))
    return float(d.mean()), float(np.percentile(d, 99))


@pytest.mark.parametrize("shading", [None, "physical"])  # the scene's own, and physical
@pytest.mark.parametrize("path", GALLERY, ids=[p.stem for p in GALLERY])
@pytest.mark.slow
def test_the_gallery_looks_the_same_on_both_engines(path, shading):
    scene = load_scene(path)
    mesh, curves = grow(scene)
    params = scene.render.replace("test", size=(320, 320))
    if shading is not None:
        params = params.replace("test", shading=shading, shading_params={})
    gl = render_scene(curves, mesh, params.replace("test", engine="opengl"))
    cpu = render_scene(curves, mesh, params.replace("test", engine="cpu"))
    mean, p99 = difference(cpu, gl)
    assert mean <= MEAN_LEVELS and p99 <= P99_LEVELS, (mean, p99)
    # a real comparison: the hair is there, and another picture is far outside it
    assert np.abs(cpu.astype(int) - cpu[0, 0].astype(int)).max() > 60
    lit_otherwise = render_scene(curves, mesh, params.replace("test", engine="cpu", shadows=False))
    assert difference(lit_otherwise, gl)[1] > P99_LEVELS / 4


@pytest.fixture(scope="module")
def small_scene():
    scene = Scene()
    scene = scene.replace(groom=scene.groom.replace(count=3000))
    return grow(scene)


@pytest.mark.parametrize("oit", [True, False])
@pytest.mark.slow
def test_same_bytes_for_any_thread_count(small_scene, oit):
    mesh, curves = small_scene
    settings = RenderParams(size=(200, 150), engine="cpu", oit=oit, shading="scheuermann")
    before = numba.get_num_threads()
    images = []
    try:
        for threads in sorted({1, before}):
            numba.set_num_threads(threads)
            images.append(render_image(curves, mesh, settings=settings))
    finally:
        numba.set_num_threads(before)
    assert images[0].std() > 5  # hair, skin and shadows, not a blank frame
    for image in images[1:]:
        np.testing.assert_array_equal(image, images[0])


def test_the_resolve_encodes_as_the_half_float_readback():
    """The CPU engine encodes in its resolve kernel through half_bits; it must give the
    bytes numpy's float32 → float16 conversion gives (ties to even, subnormals,
    overflow), which the OpenGL engine's read-back goes through."""
    edges = [
        0x00000000, 0x80000000, 0x7F800000, 0xFF800000,  # ±0, ±inf
        0x477FEFFF, 0x477FF000, 0x477FF001,  # just under, at, over 65520 (→ inf)
        0x33000000, 0x33000001, 0x33800000,  # 2^-25 (a tie to 0), above, 2^-24
        0x387FC000, 0x387FE000, 0x38800000,  # the largest subnormal, the tie, 2^-14
        0x3F800FFF, 0x3F801000, 0x3F801001, 0x3F803000,  # ties to even around 1
        0x3B4D2E1C, 0x3F7FFFFF, 0xBF000000,  # 0.0031308, just under 1, -0.5
    ]  # fmt: skip
    bits = np.concatenate([np.arange(0, 2**32, 4099, dtype=np.uint64), edges]).astype(np.uint32)
    values = bits.view(np.float32)
    with np.errstate(over="ignore"):
        expected = values.astype(np.float16).view(np.uint16)
    ours = np.array([half_bits(int(b)) for b in bits[::97]] + [half_bits(b) for b in edges])
    pick = np.concatenate([np.arange(0, len(bits) - len(edges), 97), np.arange(-len(edges), 0)])
    keep = ~np.isnan(values[pick])
    np.testing.assert_array_equal(ours[keep], expected[pick][keep])
    assert np.all(np.isnan(np.array(ours[~keep], np.uint16).view(np.float16)))


def test_curves_are_drawn_in_the_order_of_their_roots_in_space():
    """space_order: the Morton order of the roots' cells (x the lowest bit, then y, z),
    stable within a cell; a permutation of every curve."""
    roots = np.array(
        [[0, 0, 1], [0, 1, 0], [1, 0, 0], [0, 0, 0], [0.001, 0, 0], [1, 1, 1]], np.float32
    )
    points = np.repeat(roots, 2, axis=0)
    points[1::2, 2] += 0.5  # each curve's second point; the grid is over the roots
    offsets = np.arange(0, 13, 2, dtype=np.int64)
    order = space_order(points, offsets, 6)
    assert order.tolist() == [3, 4, 2, 1, 0, 5]
    hair = HairCurves.from_polylines([np.cumsum(np.ones((9, 3)), 0) * k for k in range(1, 50)])
    order = space_order(hair.points.astype(np.float32), hair.offsets, 6)
    assert sorted(order.tolist()) == list(range(49))


def test_the_renderer_reuses_and_reports_its_stages(small_scene):
    mesh, curves = small_scene
    settings = RenderParams(size=(96, 96), engine="cpu")
    with make_renderer(settings) as r:
        assert isinstance(r, CpuRenderer)
        first = r.draw(curves, mesh, settings=settings)
        np.testing.assert_array_equal(r.draw(curves, mesh, settings=settings), first)
        assert set(r.timings) == {"shadows", "skin", "steps", "bin", "raster", "resolve"}
        assert all(t >= 0 for t in r.timings.values())
    assert first.shape == (96, 96, 4) and np.all(first[..., 3] == 255)


class _FakeContext:
    def __init__(self, renderer: str) -> None:
        self.info = {"GL_RENDERER": renderer}


@pytest.mark.parametrize(
    ("gl", "chosen"),
    [
        ("llvmpipe (LLVM 15.0.6, 256 bits)", "cpu"),
        ("softpipe", "cpu"),
        ("NVIDIA H200/PCIe/SSE2", "opengl"),
        ("AMD Radeon RX 7900 XTX (radeonsi, navi31, LLVM 15.0.7, DRM 3.54)", "opengl"),
        (None, "cpu"),  # no EGL at all
    ],
)
def test_auto_takes_opengl_only_on_a_gpu(monkeypatch, gl, chosen):
    from follicle.errors import FollicleError
    from follicle.render import context

    def fake():
        if gl is None:
            raise FollicleError("cannot create a headless OpenGL context")
        return _FakeContext(gl)

    monkeypatch.setattr(context, "get_context", fake)
    monkeypatch.setattr(engines, "_automatic", {})
    assert engines.resolve_engine("auto") == chosen
    assert engines.resolve_engine("cpu") == "cpu"
    assert engines.resolve_engine("opengl") == "opengl"
    if chosen == "cpu":  # (a Renderer would need the faked context)
        with make_renderer(RenderParams(engine="auto", size=(8, 8))) as r:
            assert isinstance(r, CpuRenderer)


def test_a_bad_engine_names_the_key():
    with pytest.raises(ConfigError, match=r"\[render\]\.engine"):
        RenderParams().replace("scene.toml", engine="vulkan")
    with pytest.raises(ConfigError, match="engine"):
        render_image(None, None, engine="directx")
    with pytest.raises(InputError, match="engine: expected one of auto, opengl, cpu"):
        engines.resolve_engine("metal")


def test_wide_hair_covers_the_ribbon_the_opengl_engine_draws():
    """Hair many pixels wide, bending on screen, is a ribbon on both engines: the same
    covered pixels (no spikes where a short piece runs across the strand)."""
    t = np.linspace(0.0, 1.0, 12)
    pts = np.stack([0.3 * (t - 0.5), 0.08 * np.sin(9.0 * t), np.zeros_like(t)], axis=1)
    curves = HairCurves.from_array(pts[None], point_data={"width": np.full(12, 0.02)})
    kw = dict(
        camera=Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0)),
        size=(240, 160),
        background=(0.0, 0.0, 0.0),
        hair_color=(1.0, 1.0, 1.0),
        lights=[Light.ambient(intensity=1.0)],
        shading_params={"root_occlusion": 0.0, "roundness": 0.0},
        msaa=0,
        shadows=False,
    )
    cover = [srgb_to_linear(render_image(curves, engine=e, **kw)[..., 0] / 255.0) for e in ENGINES]
    gl, cpu = (c.sum() for c in cover)  # pixels' worth of ribbon
    assert gl > 600  # the ribbon: 6 px wide, about 165 px long
    assert abs(cpu - gl) < 0.02 * gl, (cpu, gl)
    masks = [c > 0.5 for c in cover]  # no holes at the bends, no spikes off them
    union, both = (masks[0] | masks[1]).sum(), (masks[0] & masks[1]).sum()
    assert both / union > 0.95, (both, union)


def test_render_lod_draws_a_share_of_the_hairs_and_keeps_the_look(small_scene):
    from follicle.render.frame import prepare_frame

    mesh, curves = small_scene
    base = RenderParams(size=(320, 240), engine="cpu", shadows=False)
    lod = base.replace("test", lod=1.0)
    frame = prepare_frame(lod, lod.size, curves, mesh, None, 512)
    # 80 µm hair about 0.1 px wide here: about a tenth of the hairs, ten times as wide
    assert 0.05 <= frame.lod < 0.3
    assert abs(frame.curves.curve_count - frame.lod * curves.curve_count) < 0.05 * 3000
    assert prepare_frame(base, base.size, curves, mesh, None, 512).curves is curves
    every, thinned = (
        render_image(curves, mesh, settings=base),
        render_image(curves, mesh, settings=lod),
    )
    mean, _ = difference(thinned, every)
    assert 0.0 < mean < 4.0, mean  # the same brightness, other strands
    assert render_image(curves, mesh, settings=lod.replace("test", lod=64.0)).shape == every.shape


def test_hair_behind_the_skins_silhouette_is_anti_aliased_as_on_opengl():
    """Blue hair passing behind a red sphere's edge (msaa 4): the CPU engine tests it
    against each of the pixel's skin samples, as OpenGL's MSAA does, so the edge pixels
    mix hair and skin instead of a stair-step of hair drawn over the edge."""
    n, m = 40, 30
    y = np.repeat(np.linspace(-0.06, 0.06, n), m)
    x = np.tile(np.linspace(-0.2, 0.2, m), n)
    points = np.stack([x, y, np.full(n * m, -0.15)], 1).astype(np.float32)
    curves = HairCurves(points, np.arange(0, n * m + 1, m))
    kw = dict(camera=FRONT, size=(160, 160), background=(0, 0, 0), msaa=4, shadows=False)
    kw.update(hair_color=(0, 0, 1), skin_color=(1, 0, 0), hair_width=0.004, shading_params=FLAT)
    gl, cpu = (
        render_image(curves, sphere(0.1), engine=e, **kw)[..., :3].astype(int) for e in ENGINES
    )
    edge = (gl[..., 0] > 20) & (gl[..., 2] > 20)  # OpenGL's pixels of hair and skin
    assert edge.sum() > 30
    assert ((cpu[..., 0] > 20) & (cpu[..., 2] > 20))[edge].mean() > 0.85
    # hair over the edge pixel (before: 26 of 46), and the difference there (before: 42)
    assert (edge & (cpu[..., 2] > gl[..., 2] + 40)).sum() < edge.sum() / 4
    assert np.abs(cpu - gl)[edge].mean() < 30
