"""Self-shadowing from the key light: deep opacity maps (Yuksel & Keyser 2008) for the
hair and a plain shadow map for the skin, both seen from the light through one
orthographic view fitted to the scene.

Three passes: the skin's depth; the nearest hair depth per texel (MIN blending, depth
tested against the skin); then each hair fragment adds its opacity to the layer, of
four, that its depth falls in behind that nearest depth. Receivers (hair and skin, in
``lights.glsl``) interpolate the opacity in front of them between the layers and see
``exp(-κ · opacity)`` of the light.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..frames import normalize
from .options import soft_radius
from .programs import set_uniforms, use_framebuffer

if TYPE_CHECKING:
    import moderngl

__all__ = ["ShadowMaps", "automatic_layer", "light_projection"]

LAYERS = 4
# receivers' sampler units (0 stays free for the passes' own textures)
UNITS = {"dom_depth": 1, "dom_layers": 2, "skin_depth": 3}


def light_projection(
    direction: np.ndarray, lo: np.ndarray, hi: np.ndarray, size: int
) -> tuple[np.ndarray, float, float]:
    """Orthographic world → clip matrix looking along ``-direction`` at the box [lo, hi].

    Square texels, a texel of margin on each side; clip depth -1 .. 1 spans the box.
    Returns (matrix (4, 4) row-major, texel size in metres, depth range in metres).
    """
    forward = -normalize(np.asarray(direction, dtype=np.float64))
    helper = np.eye(3)[int(np.argmin(np.abs(forward)))]
    right = normalize(np.cross(forward, helper))
    up = np.cross(right, forward)
    corners = np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    xs, ys, zs = corners @ right, corners @ up, corners @ forward
    half = 0.5 * max(np.ptp(xs), np.ptp(ys), 1e-9) * (1.0 + 4.0 / size)
    cx, cy = 0.5 * (xs.min() + xs.max()), 0.5 * (ys.min() + ys.max())
    pad = 2.0 * half / size
    z0, z1 = zs.min() - pad, zs.max() + pad
    m = np.zeros((4, 4))
    m[0, :3], m[0, 3] = right / half, -cx / half
    m[1, :3], m[1, 3] = up / half, -cy / half
    m[2, :3], m[2, 3] = 2.0 * forward / (z1 - z0), -2.0 * z0 / (z1 - z0) - 1.0
    m[3, 3] = 1.0
    return m, 2.0 * half / size, float(z1 - z0)


class ShadowMaps:
    """The key light's maps at ``size`` × ``size`` texels, reused from frame to frame."""

    def __init__(self, ctx: moderngl.Context, size: int) -> None:
        self.ctx = ctx
        self.size = size
        self.skin_depth = ctx.depth_texture((size, size))
        self.skin_depth.compare_func = ""  # read as depths: lights.glsl filters the tests
        self.skin_depth.filter = (ctx.NEAREST, ctx.NEAREST)
        self.first = ctx.texture((size, size), 1, dtype="f4")
        self.layers = ctx.texture((size, size), LAYERS, dtype="f4")
        for tex in (self.skin_depth, self.first, self.layers):
            tex.repeat_x = tex.repeat_y = False
        for tex in (self.first, self.layers):
            tex.filter = (ctx.NEAREST, ctx.NEAREST)
        self._skin_fbo = ctx.framebuffer(depth_attachment=self.skin_depth)
        self._first_fbo = ctx.framebuffer([self.first], self.skin_depth)
        self._layers_fbo = ctx.framebuffer([self.layers], self.skin_depth)
        for fbo in (self._first_fbo, self._layers_fbo):
            fbo.depth_mask = False  # tested against the skin, never written (nor cleared)

    def release(self) -> None:
        for obj in (
            self._skin_fbo,
            self._first_fbo,
            self._layers_fbo,
            self.skin_depth,
            self.first,
            self.layers,
        ):
            obj.release()

    def bind(self) -> None:
        """Bind the maps to the receivers' sampler units."""
        self.first.use(UNITS["dom_depth"])
        self.layers.use(UNITS["dom_layers"])
        self.skin_depth.use(UNITS["skin_depth"])

    def render(
        self,
        light: tuple[np.ndarray, np.ndarray, float, float],
        layer: float,
        softness: float,
        hair_vaos: dict[str, list[moderngl.VertexArray]],
        hair_uniforms: dict,
        skin_vao: moderngl.VertexArray | None,
    ) -> dict[str, object]:
        """Render the maps; returns the receivers' uniforms.

        ``light`` is (direction towards the light, :func:`light_projection` matrix, texel
        size, depth range); layers are ``layer`` metres thick; skin receivers filter the
        skin's shadow ``softness`` metres wide (:func:`soft_radius`). ``hair_vaos`` maps
        ``hair_depth`` / ``hair_opacity`` to the vertex arrays that draw the hair (lines
        and ribbons; empty: no hair), ``hair_uniforms`` are the geometry shader's
        settings apart from the view; ``skin_vao`` draws the skin with ``mesh_depth``
        (None: no skin).
        """
        ctx = self.ctx
        direction, matrix, texel, depth_range = light
        mat = np.ascontiguousarray(matrix.T, dtype="f4").tobytes()
        layer_depth = layer / depth_range
        ctx.disable(ctx.BLEND | ctx.CULL_FACE)
        ctx.enable(ctx.DEPTH_TEST)
        ctx.depth_func = "<"

        use_framebuffer(self._skin_fbo)
        self._skin_fbo.clear(depth=1.0)
        if skin_vao is not None:
            set_uniforms(skin_vao.program, {"view_proj": mat})
            ctx.polygon_offset = (2.0, 4.0)  # slope-scaled bias against acne
            skin_vao.render(mode=ctx.TRIANGLES)
            ctx.polygon_offset = (0.0, 0.0)

        use_framebuffer(self._first_fbo)
        self._first_fbo.clear(1.0, 1.0, 1.0, 1.0)
        use_framebuffer(self._layers_fbo)
        self._layers_fbo.clear(0.0, 0.0, 0.0, 0.0)
        view = {
            **hair_uniforms,
            "view_proj": mat,
            "eye": (*direction, 0.0),
            "view_forward": tuple(-direction),
            "view_right": tuple(matrix[0, :3] / np.linalg.norm(matrix[0, :3])),
            "pixel_scale": texel,
            "max_step_px": 1e9,  # shadows need the shape only, not shading steps
            "viewport": (self.size, self.size),
            "line_stretch": True,
            "layer_depth": layer_depth,
            "dom_depth": 0,
        }
        ctx.enable(ctx.BLEND)
        ctx.blend_func = ctx.ONE, ctx.ONE
        for name, fbo, equation in (
            ("hair_depth", self._first_fbo, ctx.MIN),
            ("hair_opacity", self._layers_fbo, ctx.FUNC_ADD),
        ):
            use_framebuffer(fbo)
            ctx.blend_equation = (equation, equation)  # colour and alpha
            if name == "hair_opacity":
                self.first.use(0)  # the nearest depths, just drawn
            for vao in hair_vaos.get(name, []):
                set_uniforms(vao.program, view)
                vao.render(mode=ctx.LINES_ADJACENCY)
        ctx.blend_equation = (ctx.FUNC_ADD, ctx.FUNC_ADD)
        ctx.disable(ctx.BLEND)
        return {
            "shadows": True,
            "light_view_proj": mat,
            "layer_depth": layer_depth,
            "depth_per_metre": 1.0 / depth_range,
            "light_texel": texel,
            "skin_soft": soft_radius(softness, texel),
            **UNITS,
        }


def automatic_layer(lo: np.ndarray, hi: np.ndarray) -> float:
    """Default layer thickness: 1/100 of the hair's bounding-box diagonal."""
    return max(float(np.linalg.norm(np.asarray(hi) - np.asarray(lo))) / 100.0, 1e-6)
