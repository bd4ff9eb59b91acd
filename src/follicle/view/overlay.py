"""What the viewer draws besides the render's hair and head: the simulated guides as
curves, the plain background when nothing is shown, and the solver's hair density as a
heat overlay composited in numpy."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..curves import HairCurves
from ..render import Camera
from ..render.image import encode_srgb8
from ..render.options import background_rows
from ..scene import SimParams
from ..sim.volume import VolumeGrid, grid_for

__all__ = ["DRAWN", "guide_curves", "background", "volume_overlay"]

DRAWN = ("width", "color", "opacity")  # the per-vertex attributes the renderer reads
GUIDE_COLOR = (1.0, 0.25, 0.0)  # linear RGB: orange, unlike any natural hair colour
GUIDE_WIDTH = 6e-4  # m: several hairs wide, so a guide stands out among its hairs
OVERLAY_ALPHA = 0.6  # opacity of the densest cell's colour
EMPTY = 1e-3  # density (in splatted vertices) below which a grid vertex shows nothing


def guide_curves(positions: np.ndarray) -> HairCurves:
    """The simulated guide strands (S, N, 3) as wide orange curves."""
    s, n, _ = positions.shape
    return HairCurves.from_array(
        positions,
        point_data={
            "width": np.full(s * n, GUIDE_WIDTH, np.float32),
            "color": np.tile(np.asarray(GUIDE_COLOR, np.float32), (s * n, 1)),
            "opacity": np.ones(s * n, np.float32),
        },
    )


def drawable(curves: HairCurves) -> HairCurves:
    """``curves`` with only the attributes the renderer reads (so guides join them)."""
    return HairCurves(
        curves.points,
        curves.offsets,
        {k: curves.point_data[k] for k in DRAWN if k in curves.point_data},
    )


def background(size: Sequence[int], top: Sequence[float], bottom: Sequence[float]) -> np.ndarray:
    """The renderer's background alone, (H, W, 4) uint8: its vertical linear-RGB
    gradient from ``bottom`` to ``top`` at the pixel centres, to one level of 255 (what
    is left with the hair, guides and head all hidden: the renderer draws nothing
    only with an error)."""
    w, h = size
    linear = np.ones((h, w, 4), np.float32)
    linear[..., :3] = background_rows((top, bottom), h)[:, None].astype(np.float32)
    return encode_srgb8(linear)


def density_grid(positions: np.ndarray, params: SimParams) -> VolumeGrid:
    """The hair density grid the solver builds each substep ([sim] volume_resolution,
    volume_blur; Almeida 2014 eq. 3.2), for the vertices ``positions`` (S, N, 3)."""
    x = np.ascontiguousarray(positions, np.float64)
    passes = params.volume_blur
    spec = grid_for(x, params.volume_resolution, margin=1 + passes)
    return VolumeGrid.splat(x, np.zeros_like(x), spec, passes)


def heat(t: np.ndarray) -> np.ndarray:
    """Heat colours (..., 3) in [0, 1] for ``t`` in [0, 1]: red through yellow to white."""
    t = t[..., None]
    return np.clip(np.concatenate([3 * t + 0.4, 3 * t - 1, 3 * t - 2], axis=-1), 0.0, 1.0)


def volume_overlay(
    image: np.ndarray, positions: np.ndarray, camera: Camera, params: SimParams
) -> np.ndarray:
    """``image`` with the hair density of ``positions`` over it: each grid vertex with
    hair, seen through ``camera``, colours a square the size of its cell on screen by
    the densest vertex seen there (relative to the densest of all), blended over the
    picture with opacity up to OVERLAY_ALPHA."""
    grid = density_grid(positions, params)
    d = grid.density
    cells = np.argwhere(d > EMPTY)
    if not len(cells):
        return image
    h, w = image.shape[:2]
    xy, depth = camera.project(grid.spec.origin + grid.spec.voxel * cells, (w, h))
    value = d[tuple(cells.T)] / d.max()
    seen = (depth > 0) & np.all((xy >= 0) & (xy < (w, h)), axis=1)
    if not seen.any():
        return image
    tile = grid.spec.voxel / (camera.pixel_scale(h) * float(np.median(depth[seen])))
    tile = max(int(round(tile)), 1)
    level = np.zeros((-(-h // tile), -(-w // tile)))
    tx, ty = (xy[seen] // tile).astype(np.int64).T
    np.maximum.at(level, (ty, tx), value[seen])
    level = np.repeat(np.repeat(level, tile, axis=0), tile, axis=1)[:h, :w]
    alpha = (OVERLAY_ALPHA * level)[..., None]
    out = image.copy()
    out[..., :3] = np.rint(image[..., :3] * (1 - alpha) + 255 * heat(level) * alpha)
    return out
