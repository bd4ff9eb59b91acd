"""The CPU engine: follicle's own strand rasterizer, numba kernels over plain arrays, for
machines whose OpenGL is a software rasterizer (or missing). Like the compute
rasterizers that draw thin strands in Unreal and Frostbite, it skips the
general-purpose pipeline that wastes its work on sub-pixel lines.

A frame, as the OpenGL engine's (:mod:`follicle.render.opengl`), from the same set-up
(:func:`follicle.render.frame.prepare_frame`):

1. the key light's maps (shadows on): the skin's depth, then the deep opacity maps'
   nearest hair depth and four opacity layers (Yuksel & Keyser 2008), drawn by the
   same strand kernels as the colour;
2. the opaque layer: the background gradient and the skin, rasterized into a depth
   buffer and shaded once per pixel (Lambert with wrap, shadowed);
3. the hair: every segment smoothed by Catmull-Rom, cut into steps by its screen length
   and bend, each step projected and shaded (:mod:`.steps`); segments binned into
   32-pixel tiles (:mod:`.bins`); the tiles drawn in parallel with analytic coverage
   and weighted blended order-independent transparency (:mod:`.lines`);
4. the resolve: the hair's weighted average over the opaque layer by 1 − Π(1 − α),
   encoded to 8-bit sRGB.

Each tile belongs to one thread and every list is in drawing order, so the picture is
the same, byte for byte, for any number of threads.
"""

from __future__ import annotations

import time
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from ...curves import HairCurves
from ...kernels import kernel, prange
from ..camera import Camera
from ..frame import Frame, hair_vertices, prepare_frame
from ..image import half_bits, srgb8_table
from ..options import MAX_STEP_PX, background_rows, scalar_param, soft_radius
from ..raster import RasterRenderer
from ..strands import StrandTables
from .bins import bin_boxes, tile_grid
from .lines import PASSES, draw_strands, segment_boxes
from .shading import MODELS, no_shadow, pack_model, pack_powers, pack_shadow
from .steps import fill_steps, segment_steps, space_order
from .triangles import draw_triangles, project_triangles, shade_skin

if TYPE_CHECKING:
    from ...mesh.skin import SkinMesh
    from ..settings import RenderParams

__all__ = ["CpuRenderer", "skin_depth"]

# the roots' grid that orders the curves (.steps.space_order): 64 cells an axis
SPACE_ORDER_BITS = 6
STAGES = ("shadows", "skin", "steps", "bin", "raster", "resolve")


@kernel(parallel=True)
def _resolve(buf, behind, blend, table, out):
    """The frame to 8-bit sRGB (``out`` (H, W, 4) uint8, alpha 255): with ``blend``,
    weighted blended OIT's last step, the hair's average colour Σcαw / Σαw over the
    opaque layer ``behind`` by 1 − Π(1 − α); without, ``buf``'s colour as it is.
    Encoded through float16 and ``table`` (:func:`~follicle.render.image.srgb8_table`):
    the bytes of :func:`~follicle.render.image.encode_srgb8` on the half-float image
    the OpenGL engine reads back, in one pass instead of three."""
    h, w = behind.shape[:2]
    for i in prange(h):
        row = np.empty(3 * w, np.float32)
        for j in range(w):
            for c in range(3):
                if blend:
                    weight = buf[i, j, 3]
                    hair = buf[i, j, c] / weight if weight > 0.0 else 0.0
                    row[3 * j + c] = hair + (behind[i, j, c] - hair) * buf[i, j, 4]
                else:
                    row[3 * j + c] = buf[i, j, c]
        bits = row.view(np.uint32)
        for j in range(w):
            for c in range(3):
                out[i, j, c] = table[half_bits(np.int64(bits[3 * j + c]))]
            out[i, j, 3] = 255


def _view(eye: np.ndarray, perspective: bool, forward, right, pixel: float, step: float):
    return np.array([*eye, float(perspective), *forward, *right, pixel, step], np.float64)


class CpuRenderer(RasterRenderer):
    """The CPU engine, with :class:`~follicle.render.Renderer`'s interface
    (:class:`~follicle.render.raster.RasterRenderer`): ``size``, ``msaa`` (coverage here
    is analytic; 2 or more supersamples the skin 2 × 2), ``background`` and
    ``shadow_size``. Holds no GPU resources. After a :meth:`draw`, :attr:`timings` has
    the seconds of each stage of that frame (:data:`STAGES`)."""

    timings: dict[str, float]  # the last frame's, set by draw

    @cached_property
    def _backdrop(self) -> np.ndarray:
        """The background gradient, (H, W, 3) float32."""
        w, h = self.size
        rows = background_rows(self.background, h).astype(np.float32)
        return np.ascontiguousarray(np.broadcast_to(rows[:, None, :], (h, w, 3)))

    @cached_property
    def _tables(self) -> StrandTables:
        return StrandTables()

    @cached_property
    def _buffers(self) -> dict[str, np.ndarray]:
        return {}

    # ------------------------------------------------------------------ drawing
    def draw(
        self,
        curves: HairCurves | None = None,
        mesh: object | None = None,
        camera: Camera | None = None,
        settings: RenderParams | None = None,
    ) -> np.ndarray:
        """Render one frame; returns (H, W, 4) uint8, top row first, sRGB, alpha 255.
        The arguments are :meth:`follicle.render.Renderer.draw`'s."""
        from ..settings import with_overrides

        settings = with_overrides(settings, {})
        f = prepare_frame(settings, self.size, curves, mesh, camera, self.shadow_size)
        times = dict.fromkeys(STAGES, 0.0)
        clock = time.perf_counter()
        hair = self._hair(f) if f.curves is not None else None
        shadow = self._shadow_maps(f, hair)
        times["shadows"] = time.perf_counter() - clock

        clock = time.perf_counter()
        behind, ref = self._opaque(f, shadow)
        times["skin"] = time.perf_counter() - clock
        w, h = self.size
        image = np.empty((h, w, 4), np.uint8)
        if f.curves is None:
            _resolve(behind, behind, False, srgb8_table(), image)
        else:
            cam = f.camera
            right, _, forward = cam.basis()
            view = _view(cam.eye, True, forward, right, cam.pixel_scale(h), MAX_STEP_PX)
            p = f.params
            clock = time.perf_counter()
            steps, step_start = self._steps(
                f,
                hair,
                f.view_proj,
                view,
                (w, h),
                True,
                np.array([p["root_occlusion"], p["roundness"]], np.float64),
                shadow,
            )
            times["steps"] = time.perf_counter() - clock
            clock = time.perf_counter()
            boxes = segment_boxes(steps, step_start)
            order = None
            if not settings.oit:  # "over" blending: segments back to front
                order = _back_to_front(steps, step_start)
                boxes = boxes[order]
            tile, nx, ny = _tiles(w, h)
            tile_start, items = bin_boxes(boxes, tile, nx, ny)
            if order is not None:
                items = order[items].astype(np.int32)
            times["bin"] = time.perf_counter() - clock
            clock = time.perf_counter()
            consts = np.array([f.oit_depth, p["oit_sharpness"], 1.0], np.float64)
            if settings.oit:
                buf = self._buffer("oit", (h, w, 5), np.float32, 0.0)
                buf[..., 4] = 1.0
                mode = PASSES["oit"]
            else:
                buf = behind.copy()
                mode = PASSES["over"]
            draw_strands(
                mode,
                steps,
                step_start,
                tile_start,
                items,
                tile,
                nx,
                buf,
                ref[..., 0],  # the layers pass's nearest hair: not read here
                ref,
                consts,
                _threads(),
            )
            times["raster"] = time.perf_counter() - clock
            clock = time.perf_counter()
            _resolve(buf, behind, bool(settings.oit), srgb8_table(), image)
            times["resolve"] = time.perf_counter() - clock
        self.timings = times
        return image

    def _hair(self, f: Frame) -> tuple:
        """The hair's arrays for the step kernels: control points, offsets, the curves
        in space order (:func:`.steps.space_order`) and the vertex attributes."""
        curves = f.curves
        assert curves is not None
        points = np.ascontiguousarray(curves.points, dtype=np.float32)
        offsets = np.ascontiguousarray(curves.offsets, dtype=np.int64)
        order = space_order(points, offsets, SPACE_ORDER_BITS)
        return points, offsets, order, hair_vertices(f, self._tables)

    def _steps(self, f: Frame, hair, vp, view, size, shade, common, shadow):
        """The hair's steps seen through ``vp`` (see :mod:`.steps`), the curves in
        space order."""
        points, offsets, order, attrs = hair
        counts, seg_base = segment_steps(points, offsets, order, view, f.settings.subdivisions)
        step_start = np.zeros(len(counts) + 1, np.int64)
        np.cumsum(counts + 1, out=step_start[1:])
        steps = fill_steps(
            points,
            offsets,
            order,
            attrs,
            seg_base,
            step_start,
            np.ascontiguousarray(vp, np.float64),
            view,
            float(size[0]),
            float(size[1]),
            shade,
            MODELS[f.settings.shading],
            pack_model(f.settings.shading, f.model),
            pack_powers(f.settings.shading, f.model),
            common,
            f.n_lights,
            f.light_dirs,
            f.light_radiance,
            np.asarray(f.ambient, np.float64),
            shadow,
        )
        return steps, step_start

    def _shadow_maps(self, f: Frame, hair) -> tuple:
        """The key light's maps and lookup numbers (see shading.key_visibility); a map
        of one texel and shadows off when there is no key light or shadows are off."""
        if f.light is None:
            return no_shadow()
        direction, matrix, texel, depth_range = f.light
        size = self.shadow_size
        tile, nx, ny = _tiles(size, size)
        skin = self._buffer("light skin", (size, size), np.float32, 1.0)
        if f.mesh is not None:
            _skin_raster(f.mesh, matrix, skin, None, None)
        first = self._buffer("nearest", (size, size, 1), np.float32, 1.0)
        layers = self._buffer("layers", (size, size, 4), np.float32, 0.0)
        if f.curves is not None:
            right = matrix[0, :3] / np.linalg.norm(matrix[0, :3])
            view = _view(direction, False, -direction, right, texel, 1e9)
            steps, step_start = self._steps(
                f, hair, matrix, view, (size, size), False, np.zeros(2), no_shadow()
            )
            boxes = segment_boxes(steps, step_start)
            tile_start, items = bin_boxes(boxes, tile, nx, ny)
            consts = np.array([1.0, 0.0, f.layer / depth_range], np.float64)
            args = (steps, step_start, tile_start, items, tile, nx)
            opaque = skin[..., None]  # one sample a texel
            draw_strands(PASSES["nearest"], *args, first, skin, opaque, consts, _threads())
            draw_strands(PASSES["layers"], *args, layers, first[..., 0], opaque, consts, _threads())
        shadow = pack_shadow(
            True,
            f.layer / depth_range,
            1.0 / depth_range,
            texel,
            scalar_param(f.params, "shadow_density"),
            soft_radius(scalar_param(f.params, "skin_softness"), texel),
        )
        return (
            np.ascontiguousarray(matrix, np.float64),
            first[..., 0],
            layers,
            skin,
            shadow,
        )

    def _opaque(self, f: Frame, shadow: tuple) -> tuple[np.ndarray, np.ndarray]:
        """The background and the shaded skin (H, W, 3), and the skin's view depth at
        each pixel's samples (H, W, samples; +inf where there is none). With ``msaa`` 2
        or more the skin is drawn and shaded at 2 × 2 samples a pixel, each triangle
        shaded once a pixel (its silhouette anti-aliased), and the hair is tested
        against each sample (:func:`.lines.draw_strands`)."""
        w, h = self.size
        if f.mesh is None:
            return self._backdrop, self._buffer("ref", (h, w, 1), np.float64, np.inf)
        k = 2 if self.msaa >= 2 else 1
        depth = self._buffer("depth", (h * k, w * k), np.float64, np.inf)
        tri = self._buffer("tri", (h * k, w * k), np.int32, -1)
        bary = self._buffer("bary", (h * k, w * k, 2), np.float32, None)
        _skin_raster(f.mesh, f.view_proj, depth, tri, bary)
        vertices, faces, normals = f.mesh
        behind = self._buffer("behind", (h, w, 3), np.float32, None)
        np.copyto(behind, self._backdrop)
        ref = self._buffer("ref", (h, w, k * k), np.float64, None)
        ref[:] = depth.reshape(h, k, w, k).transpose(0, 2, 1, 3).reshape(h, w, k * k)
        shade_skin(
            tri,
            bary,
            k,
            vertices,
            normals,
            np.ascontiguousarray(faces, np.int64),
            np.asarray(f.camera.eye, np.float64),
            np.asarray(f.skin_colors, np.float64),
            scalar_param(f.params, "skin_wrap"),
            f.n_lights,
            f.light_dirs,
            f.light_radiance,
            np.asarray(f.ambient, np.float64),
            shadow,
            behind,
        )
        return behind, ref

    def _buffer(self, name: str, shape: tuple, dtype, fill: object) -> np.ndarray:
        """A work array kept from frame to frame (no fresh pages each frame), set to
        ``fill`` (None: left as it is)."""
        buf = self._buffers.get(name)
        if buf is None or buf.shape != shape or buf.dtype != dtype:
            buf = self._buffers[name] = np.empty(shape, dtype)
        if fill is not None:
            buf.fill(fill)
        return buf


def _skin_raster(mesh: tuple, matrix: np.ndarray, depth: np.ndarray, tri, bary) -> None:
    """The skin's triangles through ``matrix`` into ``depth`` (its shape the raster's):
    with ``tri`` and ``bary`` the camera's (view depth, triangle and barycentrics per
    sample), without the light's (biased light depth)."""
    vertices, faces, _ = mesh
    faces = np.ascontiguousarray(faces, np.int64)
    camera = tri is not None
    h, w = depth.shape
    screen, boxes = project_triangles(vertices, faces, matrix, w, h, camera)
    tile, nx, ny = _tiles(w, h)
    tile_start, items = bin_boxes(boxes, tile, nx, ny)
    if not camera:
        tri, bary = np.empty((1, 1), np.int32), np.empty((1, 1, 2), np.float32)
    args = (screen, faces, tile_start, items, tile, nx, depth, tri, bary, camera, _threads())
    draw_triangles(*args)


def skin_depth(mesh: SkinMesh, camera: Camera, size: tuple[int, int]) -> np.ndarray:
    """The view depth of the skin's rest pose at each pixel centre of a ``size`` = (w,
    h) picture through ``camera`` ((h, w) float64, +inf where there is no skin): what
    hides a point from the camera, for tools that pick what the user sees."""
    w, h = size
    near, far = camera.clip_range()
    vp = camera.projection_matrix(w / h, near, far) @ camera.view_matrix()
    depth = np.full((h, w), np.inf)
    tri = np.empty((h, w), np.int32)
    bary = np.empty((h, w, 2), np.float32)
    skin = (np.asarray(mesh.rest_vertices, np.float64), mesh.faces, None)
    _skin_raster(skin, np.ascontiguousarray(vp), depth, tri, bary)
    return depth


def _threads() -> int:
    import numba

    return numba.get_num_threads()


def _tiles(w: int, h: int) -> tuple[int, int, int]:
    """Tile side, tiles across and down for a w × h raster (:func:`.bins.tile_grid`)."""
    return tile_grid(w, h, _threads())


def _back_to_front(steps: np.ndarray, step_start: np.ndarray) -> np.ndarray:
    """Segments ordered farthest first by the view depth of their middle step."""
    middle = steps[(step_start[:-1] + step_start[1:] - 1) // 2, 2]
    return np.argsort(-np.nan_to_num(middle, nan=-np.inf), kind="stable").astype(np.int64)
