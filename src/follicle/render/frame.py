"""What every raster engine works out before it draws a frame: the camera and its clip
range, the lights, the shading model's parameters, the key light's shadow view and the
hair's per-vertex attributes, from the curves, the mesh and the
:class:`~follicle.render.settings.RenderParams`. The OpenGL engine uploads it as
uniforms and buffers; the CPU engine hands it to its kernels. One set-up, so the two
draw the same picture.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from . import scalp
from .camera import Camera, Light, default_lights, frame_scene, hair_bounds, scene_bounds
from .lod import lod_fraction, thin_out
from .options import (
    MAX_LIGHTS,
    ShadingValue,
    check_mesh,
    color3,
    model_uniforms,
    parse_shading,
    point_attr,
    scalar_param,
    see_through,
)
from .shadows import automatic_layer, light_projection
from .strands import StrandTables

if TYPE_CHECKING:
    from .settings import RenderParams

__all__ = ["Frame", "drawable", "prepare_frame", "hair_vertices", "light_arrays"]


@dataclass(frozen=True)
class Frame:
    """One frame's set-up (see :func:`prepare_frame`)."""

    settings: RenderParams
    size: tuple[int, int]
    camera: Camera
    near: float
    far: float
    view_proj: np.ndarray  # (4, 4) float64, world -> clip
    params: dict[str, ShadingValue]  # the shading model's parameters and the common ones
    n_lights: int  # directional lights; the first is the key
    light_dirs: np.ndarray  # (MAX_LIGHTS, 3) float32, unit, towards the lights
    light_radiance: np.ndarray  # (MAX_LIGHTS, 3) float32
    ambient: np.ndarray  # (3,) float64
    hair_color: np.ndarray
    skin_colors: np.ndarray | None  # (V, 3) float32 linear RGB per skin vertex (scalp.py)
    curves: HairCurves | None  # None: no hair to draw
    mesh: tuple[np.ndarray, np.ndarray, np.ndarray] | None  # vertices, faces, normals
    light: tuple[np.ndarray, np.ndarray, float, float] | None  # key light: direction,
    # orthographic matrix, texel size, depth range (shadows on); None: no shadows
    layer: float  # deep opacity map layer thickness, metres
    oit_depth: float  # view depth of the nearest corner of the scene box
    lod: float  # the share of the hairs drawn ([render].lod; 1: all)

    @property
    def model(self) -> dict[str, ShadingValue]:
        """The parameters as the shaders take them (``p_`` names, angles in radians)."""
        return model_uniforms(self.settings.shading, self.params)


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


def _nearest_depth(camera: Camera, lo: np.ndarray, hi: np.ndarray, near: float) -> float:
    """View depth of the nearest corner of the box [lo, hi], at least ``near``."""
    corners = np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    return max(float(np.min((corners - camera.eye) @ camera.basis()[2])), near)


def light_arrays(
    lights: Sequence[Light], camera: Camera
) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """(directional count, directions, radiances, ambient); the first directional light
    is the key, the one that casts shadows."""
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


def drawable(
    curves: HairCurves | None, mesh: object | None
) -> tuple[HairCurves | None, tuple[np.ndarray, np.ndarray, np.ndarray] | None]:
    """What a render draws: the curves when they have any, the mesh's (vertices, faces,
    normals) when it has faces; an InputError for the wrong types or for nothing."""
    if curves is not None and not isinstance(curves, HairCurves):
        raise InputError(f"curves: expected HairCurves or None, got {type(curves).__name__}")
    mesh_arrays = check_mesh(mesh) if mesh is not None else None
    hair = curves if curves is not None and curves.curve_count > 0 else None
    skin = mesh_arrays if mesh_arrays is not None and len(mesh_arrays[1]) > 0 else None
    if hair is None and skin is None:
        raise InputError("render: nothing to draw; give non-empty curves and/or a mesh with faces")
    return hair, skin


def prepare_frame(
    settings: RenderParams,
    size: tuple[int, int],
    curves: HairCurves | None,
    mesh: object | None,
    camera: Camera | None,
    shadow_size: int,
) -> Frame:
    """Check what is to be drawn and work out the frame (``settings`` already whole:
    :func:`~follicle.render.settings.with_overrides`). ``camera`` None: the settings'
    eye and target, else :func:`~.camera.frame_scene` around hair and mesh. With ``[render].lod``
    the hair drawn is thinned out to the share :func:`~.lod.lod_fraction` gives."""
    params = parse_shading(settings.shading, settings.shading_params)
    hair, skin = drawable(curves, mesh)
    hair_color = color3(settings.hair_color, "hair_color")
    skin_color = color3(settings.skin_color, "skin_color")
    skin_colors = None
    if skin is not None:  # tinted by the roots of all the hair, before any is thinned out
        skin_colors = scalp.skin_colors(
            skin[0], skin_color, hair, hair_color, float(settings.scalp_tint)
        )
    lights = settings.light_list()
    if camera is None:
        camera = settings.camera()
    w, h = size
    hair_box = hair_bounds(hair) if hair is not None else None
    lo, hi = scene_bounds(hair, mesh, hair_box)
    if camera is None:
        camera = frame_scene(hair, mesh, settings.fov, w / h)
    elif not isinstance(camera, Camera):
        raise InputError(f"camera: expected a Camera, got {type(camera).__name__}")
    near, far = _clip_range(camera, lo, hi)
    hair_lo, hair_hi = hair_box if hair_box is not None else (lo, hi)
    drawn = 1.0
    if settings.lod > 0 and hair is not None:  # of all the hair: framing and bounds stay
        width = float(settings.hair_width)
        drawn = lod_fraction(hair, camera, (w, h), settings.lod, default_width=width)
        hair = thin_out(hair, drawn, default_width=width)
    view_proj = camera.projection_matrix(w / h, near, far) @ camera.view_matrix()
    n_dir, dirs, rads, ambient = light_arrays(
        default_lights() if lights is None else lights, camera
    )
    light = None
    if settings.shadows and n_dir > 0:
        key = dirs[0].astype(np.float64)
        light = (key, *light_projection(key, lo, hi, shadow_size))
    layer = scalar_param(params, "shadow_layer") or automatic_layer(hair_lo, hair_hi)
    return Frame(
        settings=settings,
        size=(w, h),
        camera=camera,
        near=near,
        far=far,
        view_proj=view_proj,
        params=params,
        n_lights=n_dir,
        light_dirs=dirs,
        light_radiance=rads,
        ambient=ambient,
        hair_color=hair_color,
        skin_colors=skin_colors,
        curves=hair,
        mesh=skin,
        light=light,
        layer=layer,
        oit_depth=_nearest_depth(camera, lo, hi, near),
        lod=drawn,
    )


def hair_vertices(frame: Frame, tables: StrandTables, out: np.ndarray | None = None) -> np.ndarray:
    """Per vertex (P, 7) float32: width, colour (3), opacity, t (0 root .. 1 tip), seed
    (per strand) — the curves' own point data where they have it, the settings' else;
    t and the seeds from the renderer's ``tables``. Written into ``out`` when given (a
    (P, 7) view, e.g. the columns of a vertex buffer)."""
    curves = frame.curves
    assert curves is not None
    s = frame.settings
    n = curves.point_count
    pd = curves.point_data
    data = np.empty((n, 7), dtype="f4") if out is None else out
    data[:, 0] = point_attr(pd, "width", (n,), float(s.hair_width))
    data[:, 1:4] = point_attr(pd, "color", (n, 3), frame.hair_color)
    data[:, 4] = point_attr(pd, "opacity", (n,), float(s.hair_opacity))
    if s.shading == "physical":  # light hair lets the light behind it through
        data[:, 4] *= 1.0 - see_through(data[:, 1:4], frame.params)
    data[:, 5], data[:, 6] = tables.param_and_seeds(curves.offsets)
    return data
