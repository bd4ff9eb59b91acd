"""OpenGL hair renderer: Catmull-Rom smoothing and viewer-facing ribbons in a geometry
shader (Le Muzic 2012 §5.2), three hair shading models, deep-opacity-map self-shadowing, weighted
blended order-independent transparency, a Lambert-shaded skin mesh and a gradient
background. Headless through EGL (Mesa llvmpipe on machines without a GPU).

A frame is: the key light's shadow maps (:mod:`.shadows`); the opaque layer
(background and skin, writing depth); the hair, depth tested against it but not
writing depth, accumulated order-independently (McGuire & Bavoil 2013) into two float
targets; a composite of the two. Everything is linear RGB in float framebuffers
(multisampled with ``msaa``); the composite is read back once and encoded to 8-bit sRGB
(:func:`follicle.render.image.encode_srgb8`). Hair thinner than a pixel is drawn as
one-pixel lines whose opacity is scaled by the share of the pixels the hair covers, so
it stays soft (analytic coverage), and is shaded once per Catmull-Rom step in the
geometry shader (at one step a segment, ``subdivisions`` 1, the same lines go without
a geometry shader, shaded per vertex: llvmpipe runs geometry shaders on one thread);
wider hair is drawn as ribbons shaded per fragment.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from .camera import Camera
from .context import get_context
from .frame import Frame, hair_vertices, prepare_frame
from .image import encode_srgb8
from .options import (
    DEFAULT_SHADOW_SIZE,
    MAX_STEP_PX,
    ShadingValue,
    scalar_param,
)
from .programs import get_program, set_uniforms, use_framebuffer
from .raster import RasterRenderer
from .shadows import UNITS as SHADOW_UNITS
from .shadows import ShadowMaps
from .strands import StrandTables, back_to_front, vertex_tangents

if TYPE_CHECKING:  # imported when used: pydantic is slow to load, `import follicle` quick
    import moderngl

    from .settings import RenderParams

__all__ = ["Renderer"]

# at one step a segment thin hair is drawn as plain lines shaded per vertex, without
# the geometry shader (the same picture; False: through it, as at more steps)
PLAIN_LINES = True
_HAIR_LAYOUT = (
    ("3f", "in_position"),
    ("1f", "in_width"),
    ("3f", "in_color"),
    ("1f", "in_opacity"),
    ("1f", "in_t"),
    ("1f", "in_seed"),
)
_MESH_LAYOUT = (("3f", "in_position"), ("3f", "in_normal"), ("3f", "in_color"))


class _Releasable(Protocol):
    """A GL object this renderer frees: buffer, texture, framebuffer, vertex array."""

    def release(self) -> None: ...


def _buffer_format(
    prog: moderngl.Program, vbo: moderngl.Buffer, layout: tuple[tuple[str, str], ...]
) -> tuple:
    """moderngl's (buffer, format, names...) for ``prog``: attributes it does not read
    (dropped by the compiler) become padding."""
    used = [(fmt, name) for fmt, name in layout if name in prog]
    fmt = " ".join(f if name in prog else f"{4 * int(f[:-1])}x" for f, name in layout)
    return (vbo, fmt, *(name for _, name in used))


def _mat(m: np.ndarray) -> bytes:
    return np.ascontiguousarray(m.T, dtype="f4").tobytes()


class Renderer(RasterRenderer):
    """An offscreen OpenGL renderer that owns its framebuffers.

    ``size`` is (width, height) in pixels; ``msaa`` the samples per pixel (0 or 1:
    none; capped to what the driver offers); ``background`` one linear RGB colour or
    ``(top, bottom)`` for a vertical gradient; ``shadow_size`` the texels per side of
    the key light's shadow maps: :meth:`from_settings` takes them from a scene's
    ``[render]``, and :meth:`draw` the rest. Reuse one renderer for many frames; call
    :meth:`release` (or use it as a context manager) to free GPU memory early.
    """

    def __init__(
        self,
        size: Sequence[int] = (960, 960),
        msaa: int = 4,
        background: object = None,
        shadow_size: int = DEFAULT_SHADOW_SIZE,
    ) -> None:
        super().__init__(size, msaa, background, shadow_size)
        self.ctx = ctx = get_context()
        samples = 0 if self.msaa <= 1 else min(self.msaa, int(ctx.max_samples))
        self.msaa = samples
        w, h = self.size
        self._opaque = ctx.texture((w, h), 4, samples=samples, dtype="f2")
        self._accum = ctx.texture((w, h), 4, samples=samples, dtype="f4")
        self._weight = ctx.texture((w, h), 1, samples=samples, dtype="f4")
        self._depth = ctx.depth_renderbuffer((w, h), samples=samples)
        self._opaque_fbo = ctx.framebuffer([self._opaque], self._depth)
        self._hair_fbo = ctx.framebuffer([self._accum, self._weight], self._depth)
        self._out = ctx.renderbuffer((w, h), 4, dtype="f2")
        self._out_fbo: moderngl.Framebuffer | None = ctx.framebuffer([self._out])
        self._shadow = ShadowMaps(ctx, self.shadow_size)
        self._tables = StrandTables()
        self._fullscreen = {
            name: ctx.vertex_array(get_program(ctx, name), [])
            for name in ("background", "composite_msaa" if samples else "composite")
        }

    # ------------------------------------------------------------------ lifetime
    def release(self) -> None:
        """Free the framebuffers and shadow maps (the shared context and programs stay)."""
        if self._out_fbo is None:
            return
        objs: tuple[_Releasable, ...] = (
            *self._fullscreen.values(),
            self._opaque_fbo,
            self._hair_fbo,
            self._out_fbo,
            self._opaque,
            self._accum,
            self._weight,
            self._depth,
            self._out,
        )
        for obj in objs:
            obj.release()
        self._shadow.release()
        self._out_fbo = None

    # ------------------------------------------------------------------ drawing
    def draw(
        self,
        curves: HairCurves | None = None,
        mesh: object | None = None,
        camera: Camera | None = None,
        settings: RenderParams | None = None,
    ) -> np.ndarray:
        """Render one frame; returns (H, W, 4) uint8, top row first, sRGB, alpha 255.

        ``settings`` is a :class:`~follicle.render.settings.RenderParams` (a scene's
        ``[render]``; None: its defaults).

        ``curves`` may be None or empty when a ``mesh`` is given. Per-vertex
        ``width``/``color``/``opacity`` of the curves win over the settings'
        ``hair_width`` (diameter, metres), ``hair_color`` (linear RGB) and
        ``hair_opacity``. ``camera`` None takes the settings' ``eye`` and ``target``, and
        when they are unset frames hair and mesh with :func:`frame_camera` at ``fov``
        degrees (vertical); no ``lights`` is :func:`default_lights`. ``shading`` is
        ``kajiya-kay``, ``scheuermann`` or ``marschner``, tuned by ``shading_params``
        (:data:`follicle.render.options.MODEL_PARAMS`). ``shadows``: the first
        directional light casts hair and skin shadows (deep opacity maps). ``oit``
        False blends the hair "over" the opaque layer, segments sorted back to front on
        the CPU (the foundation's method; thin and wide segments sorted separately).
        ``subdivisions`` is the most Catmull-Rom steps per segment; fewer are taken
        where a segment is short and straight on screen. The settings' ``size``,
        ``msaa``, background and ``shadow_size`` are the renderer's own, given when it
        was made (:meth:`from_settings`).
        """
        from .settings import with_overrides

        if self._out_fbo is None:
            raise InputError("Renderer: already released")
        settings = with_overrides(settings, {})
        f = prepare_frame(settings, self.size, curves, mesh, camera, self._shadow.size)
        params, camera, light = f.params, f.camera, f.light
        w, h = self.size
        right, _, forward = camera.basis()
        frame: dict[str, object] = {
            **f.model,
            "n_lights": f.n_lights,
            "light_dir": f.light_dirs.tobytes(),
            "light_radiance": f.light_radiance.tobytes(),
            "ambient": tuple(f.ambient),
            "root_occlusion": params["root_occlusion"],
            "roundness": params["roundness"],
            "shadow_density": params["shadow_density"],
            "shadows": False,
            **SHADOW_UNITS,  # distinct units even when unused: their sampler types differ
        }
        subdivisions, oit = settings.subdivisions, settings.oit
        hair_gs = {"subdivisions": subdivisions}

        ctx = self.ctx
        released: list[_Releasable] = []
        try:
            hair_vaos, skin_vaos = {}, None
            if f.curves is not None:
                hair_vaos = self._hair_arrays(
                    f, f.curves, None if light is None else light[2], released
                )
            if f.mesh is not None:
                assert f.skin_colors is not None  # made with the mesh
                skin_vaos = self._mesh_arrays(f.mesh, f.skin_colors, released)
            if light is not None:
                frame.update(
                    self._shadow.render(
                        light,
                        f.layer,
                        scalar_param(params, "skin_softness"),
                        hair_vaos,
                        hair_gs,
                        skin_vaos["mesh_depth"] if skin_vaos else None,
                    )
                )
            self._shadow.bind()
            view = {
                "view_proj": _mat(f.view_proj),
                "eye": (*camera.eye, 1.0),
                "view_forward": tuple(forward),
                "view_right": tuple(right),
                "pixel_scale": camera.pixel_scale(h),
                "max_step_px": MAX_STEP_PX,
                "viewport": (float(w), float(h)),
                "line_stretch": self.msaa == 0,  # multisampled lines are 1-pixel rectangles
                "oit_depth": f.oit_depth,
                "oit_sharpness": params["oit_sharpness"] if oit else 0.0,
            }
            use_framebuffer(self._hair_fbo)
            self._hair_fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)  # and the shared depth
            self._draw_opaque(skin_vaos, {**frame, **view}, params["skin_wrap"])
            self._draw_hair(hair_vaos.get("colour", []), {**frame, **view, **hair_gs}, oit)
            self._composite()
            raw = self._out_fbo.read(components=4, dtype="f2")
        finally:
            for obj in released:
                obj.release()
            ctx.disable(ctx.BLEND | ctx.DEPTH_TEST)
            ctx.blend_equation = (ctx.FUNC_ADD, ctx.FUNC_ADD)  # colour and alpha
        linear = np.frombuffer(raw, dtype=np.float16).reshape(h, w, 4)[::-1]
        image = encode_srgb8(linear)
        image[..., 3] = 255  # the background is opaque
        return image

    def _hair_arrays(
        self, f: Frame, curves: HairCurves, light_texel: float | None, released: list[_Releasable]
    ) -> dict[str, list]:
        """Upload the hair ``curves`` of frame ``f`` (its :attr:`~Frame.curves`) once; the
        vertex arrays that draw it, by pass (``colour``: (vertex array, primitive) pairs;
        ``hair_depth``, ``hair_opacity``, drawn as lines with adjacency, only with a
        ``light_texel`` size).

        Segments thinner than a pixel (texel) at both ends go to the line programs
        (``_thin``, the colour shaded per Catmull-Rom step; at one step a segment,
        ``hair_line``: plain lines shaded per vertex, no geometry shader), the others
        to the ribbon programs (shaded per fragment).
        """
        ctx = self.ctx
        camera = f.camera
        shading, oit, subdivisions = f.settings.shading, f.settings.oit, f.settings.subdivisions
        segments = self._tables.segments(curves.offsets)
        data = np.empty((curves.point_count, 10), dtype="f4")  # position, hair_vertices
        data[:, 0:3] = curves.points
        hair_vertices(f, self._tables, data[:, 3:])
        depth = (curves.points - camera.eye.astype("f4")) @ camera.basis()[2].astype("f4")
        pixel = camera.pixel_scale(self.size[1]) * np.maximum(depth, 1e-9)
        vbo = ctx.buffer(data)
        released.append(vbo)
        buffers: dict[int, tuple] = {}  # one index buffer per distinct segment list

        def split(pixel_size) -> tuple[np.ndarray, np.ndarray]:
            width = data[:, 3] / pixel_size
            thin = np.maximum(width[segments[:, 1]], width[segments[:, 2]]) < 1.0
            if thin.all():
                return segments, segments[:0]
            return segments[thin], segments[~thin]

        def arrays(names, segs, extra=()) -> list:
            if not len(segs):
                return []
            if id(segs) not in buffers:  # the entry keeps segs alive: ids stay unique
                buffers[id(segs)] = (segs, ctx.buffer(np.ascontiguousarray(segs)))
                released.append(buffers[id(segs)][1])
            ibo = buffers[id(segs)][1]
            out = []
            for name in names:
                prog = get_program(ctx, name)
                out.append(
                    ctx.vertex_array(
                        prog,
                        [_buffer_format(prog, vbo, _HAIR_LAYOUT), *extra],
                        index_buffer=ibo,
                        index_element_size=4,
                    )
                )
                released.append(out[-1])
            return out

        thin, wide = split(pixel)
        if not oit:
            thin, wide = (back_to_front(s, curves.points, camera) for s in (thin, wide))
        if PLAIN_LINES and subdivisions == 1 and len(thin):  # the geometry shader adds nothing
            tangents = ctx.buffer(vertex_tangents(curves.points, curves.offsets))
            released.append(tangents)
            lines = [
                (vao, ctx.LINES)
                for vao in arrays(
                    [f"hair_line:{shading}"], thin[:, 1:3], [(tangents, "3f", "in_tangent")]
                )
            ]
        else:
            lines = [(vao, ctx.LINES_ADJACENCY) for vao in arrays([f"hair_thin:{shading}"], thin)]
        ribbons = [(vao, ctx.LINES_ADJACENCY) for vao in arrays([f"hair:{shading}"], wide)]
        vaos = {"colour": lines + ribbons}
        if light_texel is not None:
            thin, wide = split(light_texel)
            pair = arrays(["hair_depth_thin", "hair_opacity_thin"], thin)
            pair += arrays(["hair_depth", "hair_opacity"], wide)
            vaos["hair_depth"], vaos["hair_opacity"] = pair[0::2], pair[1::2]
        return vaos

    def _mesh_arrays(
        self,
        arrays: tuple[np.ndarray, np.ndarray, np.ndarray],
        colors: np.ndarray,
        released: list[_Releasable],
    ) -> dict[str, moderngl.VertexArray]:
        ctx = self.ctx
        vertices, faces, normals = arrays
        data = np.empty((len(vertices), 9), dtype="f4")
        data[:, :3], data[:, 3:6], data[:, 6:] = vertices, normals, colors
        vbo = ctx.buffer(data.tobytes())
        ibo = ctx.buffer(np.ascontiguousarray(faces, dtype="u4").tobytes())
        released += [vbo, ibo]
        vaos = {}
        for name in ("mesh", "mesh_depth"):
            prog = get_program(ctx, name)
            vaos[name] = ctx.vertex_array(
                prog,
                [_buffer_format(prog, vbo, _MESH_LAYOUT)],
                index_buffer=ibo,
                index_element_size=4,
            )
            released.append(vaos[name])
        return vaos

    def _draw_opaque(
        self,
        skin_vaos: dict[str, moderngl.VertexArray] | None,
        uniforms: dict[str, object],
        wrap: ShadingValue,
    ) -> None:
        """Background (a full-screen triangle, no depth), then the skin."""
        ctx = self.ctx
        use_framebuffer(self._opaque_fbo)
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND | ctx.CULL_FACE)
        bg = self._fullscreen["background"]
        set_uniforms(
            bg.program, {"top": tuple(self.background[0]), "bottom": tuple(self.background[1])}
        )
        bg.render(mode=ctx.TRIANGLES, vertices=3)
        if skin_vaos is not None:
            ctx.enable(ctx.DEPTH_TEST)
            ctx.depth_func = "<"
            vao = skin_vaos["mesh"]
            set_uniforms(vao.program, {**uniforms, "wrap": wrap})
            vao.render(mode=ctx.TRIANGLES)

    def _draw_hair(
        self, vaos: list[tuple[moderngl.VertexArray, int]], uniforms: dict[str, object], oit: bool
    ) -> None:
        """Weighted blended OIT: colour·α·w and α·w summed, Π(1 - α) in the alpha; or,
        without ``oit``, "over" the opaque layer (w = 1: the colour is premultiplied)."""
        ctx = self.ctx
        fbo = self._hair_fbo if oit else self._opaque_fbo
        use_framebuffer(fbo)
        fbo.depth_mask = False
        ctx.enable(ctx.DEPTH_TEST | ctx.BLEND)
        ctx.depth_func = "<"
        if oit:
            # colour and alpha apart; moderngl's stub types blend_func as a pair only
            ctx.blend_func = ctx.ONE, ctx.ONE, ctx.ZERO, ctx.ONE_MINUS_SRC_ALPHA  # type: ignore[assignment]
        else:
            ctx.blend_func = ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA
        for vao, primitive in vaos:
            set_uniforms(vao.program, uniforms)
            vao.render(mode=primitive)
        fbo.depth_mask = True

    def _composite(self) -> None:
        ctx = self.ctx
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND)
        if self._out_fbo is None:
            raise InputError("Renderer: already released")
        use_framebuffer(self._out_fbo)
        vao = self._fullscreen["composite_msaa" if self.msaa else "composite"]
        for unit, tex in enumerate((self._opaque, self._accum, self._weight)):
            tex.use(unit)
        set_uniforms(vao.program, {"opaque": 0, "accum": 1, "weight": 2, "samples": self.msaa})
        vao.render(mode=ctx.TRIANGLES, vertices=3)
