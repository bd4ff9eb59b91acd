"""OpenGL hair renderer: Catmull-Rom smoothing and camera-facing ribbons in a geometry
shader, Kajiya-Kay shading, a Lambert-shaded skin mesh and a gradient background
(002 §5.2). Headless through EGL (Mesa llvmpipe on machines without a GPU).

Lighting and blending happen in linear RGB in a half-float multisampled framebuffer;
after the MSAA resolve the image is read back and encoded to 8-bit sRGB once
(:func:`follicle.render.image.encode_srgb8`). Hair is drawn after the mesh with
standard alpha blending, depth test and depth writes on (no order-independent
transparency yet).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from importlib import resources

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from .camera import Camera, Light, default_lights, frame_camera
from .context import get_context
from .image import encode_srgb8, save_png

__all__ = [
    "Renderer",
    "render",
    "SHADINGS",
    "DEFAULT_SHADING_PARAMS",
    "DEFAULT_HAIR_COLOR",
    "DEFAULT_HAIR_WIDTH",
    "DEFAULT_SKIN_COLOR",
    "DEFAULT_BACKGROUND",
    "segment_indices",
]

SHADINGS = ("kajiya-kay",)
MAX_SUBDIVISIONS = 16
MAX_LIGHTS = 8
MAX_SIZE = 8192

DEFAULT_HAIR_COLOR = (0.16, 0.09, 0.045)  # linear RGB, a mid brown
DEFAULT_HAIR_WIDTH = 80e-6  # diameter, metres
DEFAULT_SKIN_COLOR = (0.42, 0.25, 0.18)  # linear RGB
DEFAULT_BACKGROUND = ((0.09, 0.095, 0.11), (0.012, 0.012, 0.016))  # (top, bottom), linear

DEFAULT_SHADING_PARAMS: dict[str, object] = {
    "diffuse": 0.6,  # K_d, eq. 3.8
    "specular": 0.22,  # K_s, eq. 3.9, primary (white) highlight
    "shininess": 80.0,  # p, eq. 3.9
    "specular_color": (1.0, 0.97, 0.92),
    "specular2": 0.35,  # secondary highlight, tinted by the hair colour
    "shininess2": 20.0,
    "shift": -0.08,  # tangent shifts along the fibre normal (Scheuermann)
    "shift2": 0.12,
    "root_occlusion": 0.65,  # darkening towards the root, 0 .. 1
    "roundness": 0.35,  # darkening towards the ribbon edges, 0 .. 1
    "min_width_px": 1.0,  # thinner hair is widened to this many pixels and faded
    "skin_wrap": 0.1,  # wrap-around term of the skin's Lambert shading
}

_SHADER_FILES = {
    "hair": ("hair_vs.glsl", "hair_gs.glsl", "hair_kajiya_kay_fs.glsl"),
    "mesh": ("mesh_vs.glsl", None, "mesh_fs.glsl"),
    "background": ("background_vs.glsl", None, "background_fs.glsl"),
}
_programs: dict[tuple[int, str], object] = {}


def _source(name: str) -> str:
    return resources.files("follicle.render").joinpath("shaders", name).read_text("utf-8")


def _program(ctx, name: str):
    """Compile (once per context) and return the named shader program."""
    key = (id(ctx), name)
    prog = _programs.get(key)
    if prog is None:
        vs, gs, fs = _SHADER_FILES[name]
        prog = ctx.program(
            vertex_shader=_source(vs),
            geometry_shader=_source(gs) if gs else None,
            fragment_shader=_source(fs),
        )
        _programs[key] = prog
    return prog


def segment_indices(offsets: np.ndarray) -> np.ndarray:
    """Lines-adjacency indices (S, 4) uint32 for every segment of every curve.

    Segment i of a curve with vertices P_0 … P_{n-1} gets (P_{i-1}, P_i, P_{i+1},
    P_{i+2}) with the indices clamped to the curve, i.e. its end points duplicated
    as phantom neighbours (000 §2.2.1, Fig. 2.8). Vectorised: no loop over curves.
    """
    offsets = np.asarray(offsets, dtype=np.int64)
    counts = np.diff(offsets)
    nseg = counts - 1
    total = int(nseg.sum())
    if total == 0:
        return np.zeros((0, 4), dtype=np.uint32)
    seg_starts = np.zeros(len(nseg), dtype=np.int64)
    np.cumsum(nseg[:-1], out=seg_starts[1:])
    first = np.repeat(offsets[:-1], nseg)  # first vertex of each segment's curve
    last = np.repeat(offsets[1:] - 1, nseg)  # last vertex of each segment's curve
    local = np.arange(total, dtype=np.int64) - np.repeat(seg_starts, nseg)
    idx = (first + local)[:, None] + np.arange(-1, 3, dtype=np.int64)[None, :]
    np.clip(idx, first[:, None], last[:, None], out=idx)
    return idx.astype(np.uint32)


def back_to_front(segments: np.ndarray, points: np.ndarray, camera: Camera) -> np.ndarray:
    """Segments ordered farthest first by the view depth of their middle.

    Hair is blended without writing depth, so every thin, partly covering strand
    adds to the coverage; drawing back to front keeps the nearer strands on top.
    """
    middle = 0.5 * (points[segments[:, 1]] + points[segments[:, 2]])
    depth = middle.astype(np.float64) @ (camera.basis()[2])
    return segments[np.argsort(-depth, kind="stable")]


def _curve_param(offsets: np.ndarray, n_points: int) -> np.ndarray:
    """Per vertex, its index along the curve / (n - 1): 0 at the root, 1 at the tip."""
    counts = np.diff(offsets)
    starts = np.repeat(offsets[:-1], counts)
    denom = np.repeat(np.maximum(counts - 1, 1), counts)
    return ((np.arange(n_points, dtype=np.int64) - starts) / denom).astype(np.float32)


def _color3(value: object, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise InputError(f"{name}: expected 3 non-negative linear RGB numbers, got {value!r}")
    return arr


def _parse_background(background: object) -> tuple[np.ndarray, np.ndarray]:
    if background is None:
        background = DEFAULT_BACKGROUND
    arr = np.asarray(background, dtype=np.float64)
    if arr.shape == (3,):
        top = bottom = _color3(arr, "background")
    elif arr.shape == (2, 3):
        top, bottom = _color3(arr[0], "background top"), _color3(arr[1], "background bottom")
    else:
        raise InputError(
            "background: expected one linear RGB colour (r, g, b) or a vertical gradient"
            f" ((r, g, b) top, (r, g, b) bottom), got shape {arr.shape}"
        )
    return top, bottom


def _parse_size(size: object) -> tuple[int, int]:
    try:
        w, h = size  # type: ignore[misc]
    except (TypeError, ValueError):
        raise InputError(f"size: expected (width, height), got {size!r}") from None
    out = []
    for v in (w, h):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 0 < v <= MAX_SIZE:
            raise InputError(
                f"size: width and height must be integers in 1..{MAX_SIZE}, got {size!r}"
            )
        out.append(int(v))
    return out[0], out[1]


def _parse_shading(shading: str, params: Mapping[str, object] | None) -> dict[str, object]:
    if shading not in SHADINGS:
        raise InputError(f"shading: unknown model {shading!r}; allowed: {', '.join(SHADINGS)}")
    merged = dict(DEFAULT_SHADING_PARAMS)
    for key, value in (params or {}).items():
        if key not in DEFAULT_SHADING_PARAMS:
            raise InputError(
                f"shading_params: unknown key {key!r}; allowed: {', '.join(DEFAULT_SHADING_PARAMS)}"
            )
        if key == "specular_color":
            merged[key] = tuple(_color3(value, "shading_params['specular_color']"))
        else:
            try:
                merged[key] = float(value)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                raise InputError(
                    f"shading_params[{key!r}]: expected a number, got {value!r}"
                ) from None
            if not np.isfinite(merged[key]):
                raise InputError(f"shading_params[{key!r}]: must be finite, got {value!r}")
    if merged["shininess"] <= 0 or merged["shininess2"] <= 0:
        raise InputError("shading_params: shininess and shininess2 must be positive")
    if merged["min_width_px"] <= 0:
        raise InputError("shading_params['min_width_px']: must be positive")
    return merged


def _check_mesh(mesh: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    try:
        vertices = np.asarray(mesh.vertices, dtype=np.float64)  # type: ignore[attr-defined]
        faces = np.asarray(mesh.faces)  # type: ignore[attr-defined]
        normals = np.asarray(mesh.vertex_normals("current"), dtype=np.float64)  # type: ignore[attr-defined]
    except AttributeError as exc:
        raise InputError(
            "mesh: expected a SkinMesh (vertices, faces, vertex_normals),"
            f" got {type(mesh).__name__}"
        ) from exc
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise InputError(
            "mesh: expected vertices (V, 3) and faces (F, 3),"
            f" got {vertices.shape} and {faces.shape}"
        )
    if normals.shape != vertices.shape:
        raise InputError(
            f"mesh: vertex normals have shape {normals.shape}, expected {vertices.shape}"
        )
    if not (np.all(np.isfinite(vertices)) and np.all(np.isfinite(normals))):
        raise InputError("mesh: vertices or normals contain NaN or inf")
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise InputError("mesh: face indices out of range of the vertices")
    return vertices, faces, normals


def _scene_bounds(curves: HairCurves | None, mesh: object | None) -> tuple[np.ndarray, np.ndarray]:
    boxes = []
    if curves is not None and curves.point_count:
        lo, hi = curves.bounds()
        pad = float(np.max(curves.point_data["width"])) / 2 if "width" in curves.point_data else 0.0
        boxes.append((lo - pad, hi + pad))
    if mesh is not None:
        lo, hi = mesh.bounds("current")  # type: ignore[attr-defined]
        boxes.append((np.asarray(lo, np.float64), np.asarray(hi, np.float64)))
    return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)


def _clip_range(camera: Camera, lo: np.ndarray, hi: np.ndarray) -> tuple[float, float]:
    """near/far: the camera's own, else fitted around the scene's bounding sphere."""
    if camera.near is not None and camera.far is not None:
        return float(camera.near), float(camera.far)
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    _, _, forward = camera.basis()
    depth = float((centre - camera.eye) @ forward)
    far = camera.far if camera.far is not None else max(depth + 1.05 * radius, 1e-6)
    near = camera.near
    if near is None:
        near = max(depth - 1.05 * radius, 1e-4 * far, 1e-6)
    if far <= near:
        far = near * 10.0
    return float(near), float(far)


def _mat(m: np.ndarray) -> bytes:
    return np.ascontiguousarray(m.T, dtype="f4").tobytes()


class Renderer:
    """An offscreen OpenGL renderer that owns its framebuffers.

    ``size`` is (width, height) in pixels; ``msaa`` the samples per pixel (0 or 1:
    none; capped to what the driver offers); ``background`` one linear RGB colour or
    ``(top, bottom)`` for a vertical gradient. Reuse one renderer for many frames; call
    :meth:`release` (or use it as a context manager) to free GPU memory early.
    """

    def __init__(
        self,
        size: Sequence[int] = (960, 960),
        msaa: int = 4,
        background: object = None,
    ) -> None:
        self.size = _parse_size(size)
        if isinstance(msaa, bool) or not isinstance(msaa, (int, np.integer)) or not 0 <= msaa <= 64:
            raise InputError(f"msaa: expected samples per pixel 0..64 (0 or 1: off), got {msaa!r}")
        self.background = _parse_background(background)
        self.ctx = ctx = get_context()
        samples = 0 if msaa <= 1 else min(int(msaa), int(ctx.max_samples))
        self.msaa = samples
        w, h = self.size
        self._color = ctx.renderbuffer((w, h), 4, samples=samples, dtype="f2")
        self._depth = ctx.depth_renderbuffer((w, h), samples=samples)
        self._fbo = ctx.framebuffer([self._color], self._depth)
        if samples:
            self._resolve_color = ctx.renderbuffer((w, h), 4, dtype="f2")
            self._resolve = ctx.framebuffer([self._resolve_color])
        else:
            self._resolve_color, self._resolve = None, self._fbo
        self._programs = {name: _program(ctx, name) for name in _SHADER_FILES}
        self._bg_vao = ctx.vertex_array(self._programs["background"], [])

    # ------------------------------------------------------------------ lifetime
    def release(self) -> None:
        """Free the framebuffers (the shared context and programs stay)."""
        for obj in (
            self._bg_vao,
            self._fbo,
            self._resolve,
            self._color,
            self._depth,
            self._resolve_color,
        ):
            if obj is not None:
                obj.release()
        self._bg_vao = self._fbo = self._resolve = None
        self._color = self._depth = self._resolve_color = None

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    # ------------------------------------------------------------------ drawing
    def draw(
        self,
        curves: HairCurves | None = None,
        mesh: object | None = None,
        camera: Camera | None = None,
        lights: Sequence[Light] | None = None,
        shading: str = "kajiya-kay",
        subdivisions: int = 4,
        shading_params: Mapping[str, object] | None = None,
        hair_color: Sequence[float] = DEFAULT_HAIR_COLOR,
        hair_width: float = DEFAULT_HAIR_WIDTH,
        hair_opacity: float = 1.0,
        skin_color: Sequence[float] = DEFAULT_SKIN_COLOR,
    ) -> np.ndarray:
        """Render one frame; returns (H, W, 4) uint8, top row first, sRGB, alpha 255.

        ``curves`` may be None or empty when a ``mesh`` is given. Per-vertex
        ``width``/``color``/``opacity`` of the curves win over ``hair_width`` (diameter,
        metres), ``hair_color`` (linear RGB) and ``hair_opacity``. ``camera`` None frames
        the scene with :func:`frame_camera`; ``lights`` None uses :func:`default_lights`.
        ``subdivisions`` (1..16) is the Catmull-Rom samples per segment.
        """
        if self._fbo is None:
            raise InputError("Renderer: already released")
        params = _parse_shading(shading, shading_params)
        if curves is not None and not isinstance(curves, HairCurves):
            raise InputError(f"curves: expected HairCurves or None, got {type(curves).__name__}")
        if (
            isinstance(subdivisions, bool)
            or not isinstance(subdivisions, (int, np.integer))
            or not (1 <= subdivisions <= MAX_SUBDIVISIONS)
        ):
            raise InputError(
                f"subdivisions: expected an integer in 1..{MAX_SUBDIVISIONS}, got {subdivisions!r}"
            )
        has_hair = curves is not None and curves.curve_count > 0
        mesh_arrays = _check_mesh(mesh) if mesh is not None else None
        if not has_hair and (mesh_arrays is None or len(mesh_arrays[1]) == 0):
            raise InputError(
                "render: nothing to draw; give non-empty curves and/or a mesh with faces"
            )
        hair_color = _color3(hair_color, "hair_color")
        skin_color = _color3(skin_color, "skin_color")
        if not (np.isfinite(hair_width) and hair_width > 0):
            raise InputError(
                f"hair_width: must be a positive diameter in metres, got {hair_width!r}"
            )
        if not 0.0 <= hair_opacity <= 1.0:
            raise InputError(f"hair_opacity: must be in [0, 1], got {hair_opacity!r}")

        w, h = self.size
        lo, hi = _scene_bounds(curves if has_hair else None, mesh)
        if camera is None:
            camera = frame_camera(lo, hi, aspect=w / h)
        elif not isinstance(camera, Camera):
            raise InputError(f"camera: expected a Camera, got {type(camera).__name__}")
        near, far = _clip_range(camera, lo, hi)
        view_proj = camera.projection_matrix(w / h, near, far) @ camera.view_matrix()
        light_uniforms = _light_uniforms(default_lights() if lights is None else lights, camera)
        right, _, forward = camera.basis()

        ctx = self.ctx
        self._fbo.use()
        ctx.viewport = (0, 0, w, h)
        self._fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)

        # background: a full-screen triangle, no depth
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND | ctx.CULL_FACE)
        bg = self._programs["background"]
        bg["top"].value = tuple(self.background[0])
        bg["bottom"].value = tuple(self.background[1])
        self._bg_vao.render(mode=ctx.TRIANGLES, vertices=3)

        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        released = []
        try:
            if mesh_arrays is not None and len(mesh_arrays[1]):
                released += self._draw_mesh(
                    mesh_arrays, camera, view_proj, light_uniforms, skin_color, params
                )
            if has_hair:
                ctx.enable(ctx.BLEND)
                ctx.blend_func = (
                    ctx.SRC_ALPHA,
                    ctx.ONE_MINUS_SRC_ALPHA,
                    ctx.ONE,
                    ctx.ONE_MINUS_SRC_ALPHA,
                )
                self._fbo.depth_mask = False  # strands accumulate coverage, back to front
                released += self._draw_hair(
                    curves,
                    camera,
                    view_proj,
                    light_uniforms,
                    params,
                    int(subdivisions),
                    right,
                    forward,
                    hair_color,
                    float(hair_width),
                    float(hair_opacity),
                )
            if self.msaa:
                ctx.copy_framebuffer(self._resolve, self._fbo)
            raw = self._resolve.read(components=4, dtype="f2")
        finally:
            for obj in released:
                obj.release()
            ctx.disable(ctx.BLEND | ctx.DEPTH_TEST)
            self._fbo.depth_mask = True
        linear = np.frombuffer(raw, dtype=np.float16).reshape(h, w, 4)[::-1]
        image = encode_srgb8(linear)
        image[..., 3] = 255  # the background is opaque
        return image

    def _draw_mesh(self, arrays, camera, view_proj, light_uniforms, skin_color, params) -> list:
        ctx = self.ctx
        vertices, faces, normals = arrays
        prog = self._programs["mesh"]
        data = np.empty((len(vertices), 6), dtype="f4")
        data[:, :3], data[:, 3:] = vertices, normals
        vbo = ctx.buffer(data.tobytes())
        ibo = ctx.buffer(np.ascontiguousarray(faces, dtype="u4").tobytes())
        vao = ctx.vertex_array(
            prog,
            [(vbo, "3f 3f", "in_position", "in_normal")],
            index_buffer=ibo,
            index_element_size=4,
        )
        prog["view_proj"].write(_mat(view_proj))
        prog["eye"].value = tuple(camera.eye)
        prog["skin_color"].value = tuple(skin_color)
        prog["wrap"].value = float(params["skin_wrap"])
        _set_lights(prog, light_uniforms)
        vao.render(mode=ctx.TRIANGLES)
        return [vao, vbo, ibo]

    def _draw_hair(
        self,
        curves,
        camera,
        view_proj,
        light_uniforms,
        params,
        subdivisions,
        right,
        forward,
        hair_color,
        hair_width,
        hair_opacity,
    ) -> list:
        ctx = self.ctx
        n = curves.point_count
        pd = curves.point_data
        # one interleaved upload per frame: position, width, colour, opacity, t
        data = np.empty((n, 9), dtype="f4")
        data[:, 0:3] = curves.points
        data[:, 3] = _point_attr(pd, "width", (n,), hair_width)
        data[:, 4:7] = _point_attr(pd, "color", (n, 3), hair_color)
        data[:, 7] = _point_attr(pd, "opacity", (n,), hair_opacity)
        data[:, 8] = _curve_param(curves.offsets, n)
        vbo = ctx.buffer(data.tobytes())
        segments = back_to_front(segment_indices(curves.offsets), curves.points, camera)
        ibo = ctx.buffer(segments.tobytes())
        prog = self._programs["hair"]
        vao = ctx.vertex_array(
            prog,
            [(vbo, "3f 1f 3f 1f 1f", "in_position", "in_width", "in_color", "in_opacity", "in_t")],
            index_buffer=ibo,
            index_element_size=4,
        )
        prog["view_proj"].write(_mat(view_proj))
        prog["eye"].value = tuple(camera.eye)
        prog["cam_forward"].value = tuple(forward)
        prog["cam_right"].value = tuple(right)
        prog["subdivisions"].value = subdivisions
        prog["pixel_scale"].value = camera.pixel_scale(self.size[1])
        prog["min_width_px"].value = float(params["min_width_px"])
        prog["k_diffuse"].value = float(params["diffuse"])
        prog["k_specular"].value = float(params["specular"])
        prog["shininess"].value = float(params["shininess"])
        prog["specular_color"].value = tuple(params["specular_color"])
        prog["k_specular2"].value = float(params["specular2"])
        prog["shininess2"].value = float(params["shininess2"])
        prog["shift"].value = float(params["shift"])
        prog["shift2"].value = float(params["shift2"])
        prog["root_occlusion"].value = float(params["root_occlusion"])
        prog["roundness"].value = float(params["roundness"])
        _set_lights(prog, light_uniforms)
        vao.render(mode=ctx.LINES_ADJACENCY)
        return [vao, vbo, ibo]


def _point_attr(
    pd: Mapping[str, np.ndarray], key: str, shape: tuple[int, ...], default
) -> np.ndarray:
    if key in pd:
        arr = np.asarray(pd[key], dtype=np.float32)
        if arr.shape != shape:
            raise InputError(f"point_data[{key!r}]: expected shape {shape}, got {arr.shape}")
        return arr
    return np.broadcast_to(np.asarray(default, dtype=np.float32), shape)


def _light_uniforms(
    lights: Sequence[Light], camera: Camera
) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    directions, radiances = [], []
    ambient = np.zeros(3)
    for light in lights:
        if not isinstance(light, Light):
            raise InputError(f"lights: expected Light objects, got {type(light).__name__}")
        if light.is_ambient:
            ambient += light.radiance
        else:
            directions.append(light.world_direction(camera))
            radiances.append(light.radiance)
    if len(directions) > MAX_LIGHTS:
        raise InputError(f"lights: at most {MAX_LIGHTS} directional lights, got {len(directions)}")
    dirs = np.zeros((MAX_LIGHTS, 3), dtype="f4")
    rads = np.zeros((MAX_LIGHTS, 3), dtype="f4")
    if directions:
        dirs[: len(directions)] = directions
        rads[: len(radiances)] = radiances
    return len(directions), dirs, rads, ambient


def _set_lights(prog, uniforms) -> None:
    count, dirs, rads, ambient = uniforms
    prog["n_lights"].value = count
    prog["ambient"].value = tuple(ambient)
    prog["light_dir"].write(dirs.tobytes())
    prog["light_radiance"].write(rads.tobytes())


def render(
    curves: HairCurves | None,
    mesh: object | None = None,
    camera: Camera | None = None,
    size: Sequence[int] = (960, 960),
    shading: str = "kajiya-kay",
    out: str | os.PathLike[str] | None = None,
    lights: Sequence[Light] | None = None,
    background: object = None,
    msaa: int = 4,
    subdivisions: int = 4,
    shading_params: Mapping[str, object] | None = None,
    hair_color: Sequence[float] = DEFAULT_HAIR_COLOR,
    hair_width: float = DEFAULT_HAIR_WIDTH,
    hair_opacity: float = 1.0,
    skin_color: Sequence[float] = DEFAULT_SKIN_COLOR,
) -> np.ndarray:
    """Render hair (and an optional skin mesh) to an (H, W, 4) uint8 sRGB image.

    ``camera`` None frames the union of hair and mesh bounds. When ``out`` is given
    the image is also written there as PNG (atomically). See :class:`Renderer`.
    """
    if shading not in SHADINGS:
        raise InputError(f"shading: unknown model {shading!r}; allowed: {', '.join(SHADINGS)}")
    with Renderer(size=size, msaa=msaa, background=background) as renderer:
        image = renderer.draw(
            curves,
            mesh,
            camera=camera,
            lights=lights,
            shading=shading,
            subdivisions=subdivisions,
            shading_params=shading_params,
            hair_color=hair_color,
            hair_width=hair_width,
            hair_opacity=hair_opacity,
            skin_color=skin_color,
        )
    if out is not None:
        save_png(image, out)
    return image
