"""OpenGL hair renderer: Catmull-Rom smoothing and camera-facing ribbons in a geometry
shader, Kajiya-Kay shading, a Lambert-shaded skin mesh and a gradient background
(002 §5.2). Headless through EGL (Mesa llvmpipe on machines without a GPU).

Lighting and blending happen in linear RGB in a half-float multisampled framebuffer;
after the MSAA resolve the image is read back and encoded to 8-bit sRGB once
(:func:`follicle.render.image.encode_srgb8`). Hair is drawn after the mesh, depth
tested against it but without depth writes, segments sorted back to front, so every
thin strand adds its coverage (an order-independent method comes with the full
renderer).
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
from .options import (
    DEFAULT_HAIR_COLOR,
    DEFAULT_HAIR_WIDTH,
    DEFAULT_SKIN_COLOR,
    MAX_LIGHTS,
    MAX_SUBDIVISIONS,
    SHADINGS,
    check_mesh,
    color3,
    parse_background,
    parse_shading,
    parse_size,
    point_attr,
)
from .strands import back_to_front, curve_param, segment_indices

__all__ = ["Renderer", "render"]

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
        self.size = parse_size(size)
        if isinstance(msaa, bool) or not isinstance(msaa, (int, np.integer)) or not 0 <= msaa <= 64:
            raise InputError(f"msaa: expected samples per pixel 0..64 (0 or 1: off), got {msaa!r}")
        self.background = parse_background(background)
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
        fov: float = 35.0,
    ) -> np.ndarray:
        """Render one frame; returns (H, W, 4) uint8, top row first, sRGB, alpha 255.

        ``curves`` may be None or empty when a ``mesh`` is given. Per-vertex
        ``width``/``color``/``opacity`` of the curves win over ``hair_width`` (diameter,
        metres), ``hair_color`` (linear RGB) and ``hair_opacity``. ``camera`` None frames
        hair and mesh with :func:`frame_camera` at ``fov`` degrees (vertical); ``lights``
        None uses :func:`default_lights`.
        ``subdivisions`` (1..16) is the Catmull-Rom samples per segment.
        """
        if self._fbo is None:
            raise InputError("Renderer: already released")
        params = parse_shading(shading, shading_params)
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
        mesh_arrays = check_mesh(mesh) if mesh is not None else None
        if not has_hair and (mesh_arrays is None or len(mesh_arrays[1]) == 0):
            raise InputError(
                "render: nothing to draw; give non-empty curves and/or a mesh with faces"
            )
        hair_color = color3(hair_color, "hair_color")
        skin_color = color3(skin_color, "skin_color")
        if not (np.isfinite(hair_width) and hair_width > 0):
            raise InputError(
                f"hair_width: must be a positive diameter in metres, got {hair_width!r}"
            )
        if not 0.0 <= hair_opacity <= 1.0:
            raise InputError(f"hair_opacity: must be in [0, 1], got {hair_opacity!r}")

        w, h = self.size
        lo, hi = _scene_bounds(curves if has_hair else None, mesh)
        if camera is None:
            camera = frame_camera(lo, hi, fov_y=fov, aspect=w / h)
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
        data[:, 3] = point_attr(pd, "width", (n,), hair_width)
        data[:, 4:7] = point_attr(pd, "color", (n, 3), hair_color)
        data[:, 7] = point_attr(pd, "opacity", (n,), hair_opacity)
        data[:, 8] = curve_param(curves.offsets, n)
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
    fov: float = 35.0,
) -> np.ndarray:
    """Render hair (and an optional skin mesh) to an (H, W, 4) uint8 sRGB image.

    ``camera`` None frames the union of hair and mesh bounds at ``fov`` degrees
    (vertical). When ``out`` is given
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
            fov=fov,
        )
    if out is not None:
        save_png(image, out)
    return image
