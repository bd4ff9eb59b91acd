"""A path-traced reference still with Mitsuba 3, seen and lit like the OpenGL render.

The same camera (or the same automatic framing), the same lights, skin colour and
background gradient as :func:`follicle.render.render_image`, so the two images can be laid
side by side. The hair is Mitsuba's ``bsplinecurve`` shape, loaded from curve files
:func:`follicle.io.mitsuba.save_mitsuba` writes (round tubes through every vertex,
radius = width / 2; several shapes, each closed by a sentinel, see
:func:`_hair_shapes`), with the ``hair`` BSDF (Chiang et al. 2016). Its absorption σ_a
is derived per curve segment from the hair colour (:func:`absorption_from_color`), or,
for hair grown from melanin, from its pigment concentrations (:mod:`follicle.melanin`),
and handed to the BSDF as a texture over each shape's ``v`` coordinate, which runs over the
segments of its curves in file order, so every hair keeps its own colour and its
root-to-tip gradient. The skin is a two-sided diffuse mesh.

Lights: a directional light of radiance L becomes a ``directional`` emitter of
irradiance π·L, so a white Lambertian surface facing it is as bright as the GL skin
shading makes it (GL: ρ·L·cos θ; Mitsuba: ρ/π·E·cos θ); the ambient lights add up to
one ``constant`` environment of that radiance. Emitters are hidden from the camera:
the image is rendered with alpha and composited, in linear RGB, onto the GL
renderer's background gradient, then encoded to 8-bit sRGB like the GL image.

Variant ``scalar_rgb`` (multi-threaded CPU): it needs no kernel compilation, and its
image blocks, with a box pixel filter, make the result reproducible (the same seed gives
the same bytes). ``llvm_ad_rgb`` aborted in LLVM's code generator on the development
machine, so it is not used. Loading this module does not import Mitsuba; rendering
does, and sets its variant.
"""

from __future__ import annotations

import contextlib
import math
import os
import pickle
import signal
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..arrays import budget_runs
from ..curves import HairCurves
from ..errors import InputError, ResourceError
from ..io.mitsuba import save_mitsuba
from ..melanin import AZIMUTHAL_ROUGHNESS, absorption_from_color, melanin_absorption
from ..validate import whole
from .camera import Camera, Light, default_lights, frame_scene
from .frame import drawable
from .image import encode_srgb8, save_png
from .options import MAX_SPP, background_rows, color3, parse_background, parse_size, point_attr

if TYPE_CHECKING:
    from .settings import RenderParams

__all__ = ["render_mitsuba", "VARIANT", "MAX_DEPTH"]

VARIANT = "scalar_rgb"
MAX_DEPTH = 24  # path length: light hair needs many bounces (Russian roulette after 5)
MAX_SEGMENTS = 1 << 16  # B-spline segments per curve shape (see _hair_shapes)


def _mitsuba():
    """The ``mitsuba`` module set to :data:`VARIANT`."""
    try:
        import mitsuba as mi
    except ImportError:
        raise InputError(
            "the Mitsuba renderer is not installed; install the pbr extra:"
            " pip install 'follicle[pbr]'"
        ) from None
    if VARIANT not in mi.variants():
        raise InputError(f"mitsuba {mi.__version__} lacks the {VARIANT} variant")
    mi.set_variant(VARIANT)
    return mi


@contextlib.contextmanager
def _reporting(mi, progress: Callable[[int, int], None] | None) -> Iterator[None]:
    """While rendering, Mitsuba's logger reports its progress to ``progress`` (in
    per cent) and prints nothing: its own appender would draw a second bar."""
    if progress is None:
        yield
        return
    report = progress  # the closure below sees it narrowed

    class Reporter(mi.Appender):
        def append(self, level, text):  # log lines: the CLI's -v logging says enough
            pass

        def log_progress(self, fraction, name, formatted, eta, ptr=None):
            report(min(int(fraction * 100), 100), 100)

    logger = mi.logger()
    saved = [logger.appender(i) for i in range(logger.appender_count())]
    level = logger.log_level()
    logger.clear_appenders()
    logger.add_appender(Reporter())
    logger.set_log_level(mi.LogLevel.Info)  # progress is reported at the Info level
    try:
        yield
    finally:
        logger.clear_appenders()
        for appender in saved:
            logger.add_appender(appender)
        logger.set_log_level(level)


def _segment_absorption(curves: HairCurves, hair_color: np.ndarray) -> np.ndarray:
    """σ_a per curve segment (S, 3), float32, in the order of the curve file's segments:
    curve by curve, root to tip. Hair grown from melanin (``curve_data`` ``melanin`` and
    ``melanin_redness``, with its ``dye``) takes its pigments' σ_a
    (:func:`follicle.melanin.melanin_absorption`), every segment of a curve alike;
    other hair the σ_a of each segment's colour, the mean of its two vertices'."""
    cd = curves.curve_data
    if "melanin" in cd and "melanin_redness" in cd:
        dye = cd.get("dye", (1.0, 1.0, 1.0))
        sigma = melanin_absorption(cd["melanin"], cd["melanin_redness"], dye)
        return np.repeat(sigma, curves.counts - 1, axis=0).astype(np.float32)
    color = point_attr(curves.point_data, "color", (curves.point_count, 3), hair_color)
    last = np.zeros(curves.point_count, dtype=bool)
    last[curves.offsets[1:] - 1] = True
    starts = np.flatnonzero(~last)
    mean = 0.5 * (color[starts].astype(np.float64) + color[starts + 1])
    return absorption_from_color(mean).astype(np.float32)


def _hair_shapes(mi, curves: HairCurves, hair_color, hair_width, folder: Path) -> dict:
    """The hair as ``bsplinecurve`` shapes of at most :data:`MAX_SEGMENTS` segments
    each, every one closed by a zero-width sentinel curve, keyed ``hair_0``, ``hair_1``…

    Why: Mitsuba 3.9's ``bsplinecurve`` (``src/shapes/bsplinecurve.cpp``) reports a
    hit's ``v = (v_local + prim_index) / S`` over the shape's S segments, in float32
    in the scalar variants, and ``partials()``, which the path tracer's surface
    interaction calls on every hit, turns it back into a segment, ``floor(v · S)``,
    without clamping it (``eval_parameterization`` clamps; upstream's pull request
    1928 "Clamp the segment index in partials()" adds it). ``v_local + prim_index``
    rounds to a multiple of the float32 spacing at S, so a hit on the last ~ulp(S)/2
    of a shape's last segment gives segment S, one past the end: Mitsuba reads an
    index from beyond its segment table and a control point from anywhere. With
    all 100,000 default hairs in one shape (S = 2,300,000, spacing 0.25) that was
    the last eighth of the last hair's tip, and the render died with SIGSEGV in
    ``partials`` (seen in gdb); 50,000 hairs (spacing 0.125) merely missed it.

    So each shape ends with a sentinel: a straight, zero-radius segment along its last
    hair's final segment, inside that hair's tube (the bounds do not change). Having
    no width, it is hit only by a ray through its very axis, and a ray from outside
    the tube hits the tube first; every hit is then on a segment below S − 1, and
    ``floor(v · S)`` at most S − 1. Splitting the hair into shapes of at most
    :data:`MAX_SEGMENTS` (spacing 1/256) keeps ``v`` precise besides: at 2.3 million
    segments the last eighth of every segment took its frame, and its absorption texel
    (looked up by ``v``), from the next segment, on a hair's tip from the next hair.
    """
    width = point_attr(curves.point_data, "width", (curves.point_count,), hair_width)
    hair = HairCurves(curves.points, curves.offsets, {"width": width})
    sigma = _segment_absorption(curves, hair_color)
    shapes = {}
    for i, (a, b) in enumerate(budget_runs(curves.counts - 1, MAX_SEGMENTS)):
        part = hair[a:b]
        sentinel = HairCurves(part.points[-2:], [0, 2], {"width": np.zeros(2, np.float32)})
        path = save_mitsuba(iter([part, sentinel]), folder / f"hair_{i}.txt")
        first = int(curves.offsets[a] - a)  # segments before curve a
        rows = sigma[first : first + part.point_count - part.curve_count]
        rows = np.concatenate([rows, rows[-1:]])  # the sentinel's texel: never looked up
        shapes[f"hair_{i}"] = {
            "type": "bsplinecurve",
            "filename": str(path),
            "bsdf": {
                "type": "hair",
                "azimuthal_roughness": AZIMUTHAL_ROUGHNESS,
                "sigma_a": {
                    "type": "bitmap",
                    # one texel per segment, down the image: v = (segment + t) / S
                    "bitmap": mi.Bitmap(np.ascontiguousarray(rows[:, None, :])),
                    "raw": True,
                    "filter_type": "nearest",
                    "wrap_mode": "clamp",
                },
            },
        }
    return shapes


def _skin_shape(mi, arrays, skin_color: np.ndarray):
    vertices, faces, normals = arrays
    bsdf = mi.load_dict(
        {
            "type": "twosided",
            "bsdf": {
                "type": "diffuse",
                "reflectance": {"type": "rgb", "value": skin_color.tolist()},
            },
        }
    )
    props = mi.Properties()
    props["bsdf"] = bsdf
    mesh = mi.Mesh("skin", len(vertices), len(faces), props, has_vertex_normals=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = np.ascontiguousarray(vertices, np.float32).ravel()
    params["vertex_normals"] = np.ascontiguousarray(normals, np.float32).ravel()
    params["faces"] = np.ascontiguousarray(faces, np.uint32).ravel()
    params.update()
    return mesh


def _emitters(lights: Sequence[Light], camera: Camera) -> dict:
    out: dict[str, dict] = {}
    ambient = np.zeros(3)
    for i, light in enumerate(lights):
        if not isinstance(light, Light):
            raise InputError(f"lights: expected Light objects, got {type(light).__name__}")
        if light.is_ambient:
            ambient += light.radiance
            continue
        out[f"light_{i}"] = {
            "type": "directional",
            "direction": (-light.world_direction(camera)).tolist(),
            "irradiance": {"type": "rgb", "value": (math.pi * light.radiance).tolist()},
            "sampling_weight": _luminance(light.radiance),
        }
    if np.any(ambient > 0):
        out["ambient"] = {
            "type": "constant",
            "sampling_weight": _luminance(ambient),
            "radiance": {"type": "rgb", "value": ambient.tolist()},
        }
    return out


def _luminance(rgb: np.ndarray) -> float:
    """Rec. 709 luminance: each emitter is picked for next-event estimation in proportion
    to the irradiance it gives (π·L both for a directional light and an environment), so
    a dim fill light does not take as many samples as the key."""
    return max(float(rgb @ (0.2126, 0.7152, 0.0722)), 1e-6)


def _sensor(mi, camera: Camera, size: tuple[int, int], spp: int, seed: int) -> dict:
    _, up, _ = camera.basis()
    near, far = camera.clip_range()
    return {
        "type": "perspective",
        "fov": camera.fov_y,
        "fov_axis": "y",
        "near_clip": near,
        "far_clip": far,
        "to_world": mi.ScalarTransform4f().look_at(
            origin=camera.eye.tolist(), target=camera.target.tolist(), up=up.tolist()
        ),
        "film": {
            "type": "hdrfilm",
            "width": size[0],
            "height": size[1],
            "pixel_format": "rgba",
            "rfilter": {"type": "box"},
        },
        "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
    }


def _path_trace(job: dict, out: str, report: Callable[[int], None]) -> None:
    """In the child process: the scene of ``job`` path-traced, its RGBA saved to
    ``out`` (.npy); progress in per cent told to ``report``."""
    mi = _mitsuba()
    scene: dict[str, object] = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": MAX_DEPTH, "hide_emitters": True},
        "sensor": _sensor(mi, job["camera"], job["size"], job["spp"], job["seed"]),
        **job["emitters"],
    }
    with tempfile.TemporaryDirectory(prefix="follicle-mitsuba-") as folder:
        if job["hair"] is not None:
            scene |= _hair_shapes(
                mi, job["hair"], job["hair_color"], job["hair_width"], Path(folder)
            )
        if job["skin"] is not None:
            scene["skin"] = _skin_shape(mi, job["skin"], job["skin_color"])
        with _reporting(mi, lambda done, total: report(done)):
            image = mi.render(mi.load_dict(scene), seed=job["seed"], spp=job["spp"])
        np.save(out, np.array(image, dtype=np.float64))


# the child's command, given the job and output files (a test fakes a crash with another)
_CHILD = [sys.executable, "-m", "follicle.render.mitsuba"]


def _in_child(job: dict, progress: Callable[[int, int], None] | None) -> np.ndarray:
    """:func:`_path_trace` in a child process (this module run with the job's file), so
    that Mitsuba crashing (as its curve shape did at 100,000 hairs, before
    :func:`_hair_shapes` kept hits inside its segment table) is one ResourceError, not
    this process gone without a word. The child prints its
    progress, one number a line, or ``error: …``."""
    with tempfile.TemporaryDirectory(prefix="follicle-mitsuba-") as folder:
        job_file, out = os.path.join(folder, "job.pickle"), os.path.join(folder, "rgba.npy")
        with open(job_file, "wb") as f:
            pickle.dump(job, f)
        child = subprocess.Popen([*_CHILD, job_file, out], stdout=subprocess.PIPE, text=True)
        failed = None
        try:
            for line in child.stdout or ():
                if line.startswith("error: "):
                    failed = line[len("error: ") :].strip()
                elif progress is not None and line.strip().isdigit():
                    progress(int(line), 100)
            child.wait()
        finally:
            if child.poll() is None:  # interrupted: the child goes too
                child.kill()
                child.wait()
        if child.returncode == 0 and os.path.exists(out):
            return np.load(out)
    code = child.returncode
    how = f"crashed with {signal.Signals(-code).name}" if code < 0 else f"failed ({failed})"
    hairs = 0 if job["hair"] is None else job["hair"].curve_count
    raise ResourceError(
        f"mitsuba {how} path-tracing {hairs:,} hairs at {job['size'][0]}x{job['size'][1]};"
        " render fewer hairs, or use --engine opengl or cpu"
    )


def _child_main(job_file: str, out: str) -> None:
    """The child process: the job read and path-traced; an exception is one
    ``error: …`` line for the parent to raise, not a traceback."""
    with open(job_file, "rb") as f:
        job = pickle.load(f)  # written by _in_child into its own temporary folder
    try:
        _path_trace(job, out, lambda done: print(done, flush=True))
    except Exception as exc:  # reported to the parent, which raises it
        print(f"error: {type(exc).__name__}: {exc}".splitlines()[0], flush=True)
        sys.exit(1)


def render_mitsuba(
    curves: HairCurves | None,
    mesh: object | None = None,
    camera: Camera | None = None,
    settings: RenderParams | None = None,
    spp: int | None = None,
    seed: int = 0,
    out: str | os.PathLike[str] | None = None,
    progress: Callable[[int, int], None] | None = None,
    **overrides: object,
) -> np.ndarray:
    """Path-trace hair (and an optional skin mesh) to an (H, W, 4) uint8 sRGB image.

    ``settings`` and keyword ``overrides`` mean what they mean for
    :func:`follicle.render.render_image`; of them the path tracer uses ``size``, ``lights``
    (none: :func:`default_lights`), the background, ``fov``, ``eye`` and ``target``
    (``camera`` None takes them, else frames hair and mesh at ``fov`` degrees),
    ``hair_color`` and ``hair_width`` (per-vertex ``color``/``width`` win over them)
    and ``skin_color``; per-vertex opacity is not used (fibres are opaque, light passes
    through them as the BSDF says). ``spp`` samples per pixel (None: the settings'
    ``spp``); the same ``seed`` gives the same image. ``out``: also write PNG there.
    ``progress(done, 100)`` hears Mitsuba's own render progress, in per cent.
    """
    from .settings import with_overrides

    settings = with_overrides(settings, overrides)
    w, h = parse_size(settings.size)
    spp = settings.spp if spp is None else whole(spp, "spp", 1, MAX_SPP)
    seed = whole(seed, "seed", 0, 2**32 - 1)
    hair, skin = drawable(curves, mesh)
    hair_color = color3(settings.hair_color, "hair_color")
    skin_color = color3(settings.skin_color, "skin_color")
    hair_width = settings.hair_width
    background = parse_background(settings.background)
    lights = settings.light_list()
    if camera is None:
        camera = settings.camera()
    if camera is None:
        camera = frame_scene(hair, mesh, settings.fov, w / h)
    elif not isinstance(camera, Camera):
        raise InputError(f"camera: expected a Camera, got {type(camera).__name__}")
    _mitsuba()  # installed, with the variant: an InputError here, not in the child
    job = {
        "hair": hair,
        "skin": skin,
        "hair_color": hair_color,
        "hair_width": hair_width,
        "skin_color": skin_color,
        "camera": camera,
        "size": (w, h),
        "spp": spp,
        "seed": seed,
        "emitters": _emitters(default_lights() if lights is None else lights, camera),
    }
    rgba = _in_child(job, progress)
    alpha = np.clip(rgba[..., 3:], 0.0, 1.0)
    linear = np.empty((h, w, 4))
    linear[..., :3] = rgba[..., :3] + (1.0 - alpha) * background_rows(background, h)[:, None, :]
    linear[..., 3] = 1.0
    image = encode_srgb8(linear)
    if out is not None:
        save_png(image, out)
    return image


if __name__ == "__main__":
    _child_main(*sys.argv[1:])
