"""The atlas's textures, drawn by follicle's own strand rasterizer (:mod:`follicle.render.cpu`).

Every card's hairs are moved into its texture: a member's point at station k with card
coordinates (across, depth) (:func:`.strips.card_coordinates`) lands at column
x + (across / width + ½)·w and row y + h·k / (M − 1) of the card's rectangle. All cards
of all levels are then one set of strands in texel space, drawn at once through an
orthographic view by the CPU engine's step and strand kernels, unshaded: each step
carries three values to average instead of a shaded colour, and the weighted blended
pass with a constant weight (McGuire & Bavoil 2013, weight 1) gives at each texel the
coverage-weighted mean Σ vα / Σ α of the hairs over it and their coverage 1 − Π(1 − α).
Three such passes give the maps of Unreal's card layout: the colour, (depth, root-to-tip,
seed) and the tangent.
"""

from __future__ import annotations

import numpy as np

from ..kernels import kernel, prange
from ..render.cpu.bins import bin_boxes, tile_grid
from ..render.cpu.lines import PASSES, draw_strands, segment_boxes
from ..render.cpu.shading import POWER_STEPS, no_shadow
from ..render.cpu.steps import fill_steps, segment_steps, space_order
from ..render.options import MAX_STEP_PX

__all__ = ["CHANNELS", "bake"]

# the passes' three values each
CHANNELS = (("red", "green", "blue"), ("depth", "root_to_tip", "seed"), ("tx", "ty", "tz"))
_SUBDIVISIONS = 16  # most steps a segment (the engine's MAX_SUBDIVISIONS)


@kernel(parallel=True)
def _step_values(offsets, order, seg_base, step_start, values, steps):
    """Write each step's three ``values`` (P, 3), linear along its segment as the engine
    takes vertex colours, into the steps' colour fields (5, 6, 7)."""
    for q in prange(len(offsets) - 1):
        c = order[q]
        first, last = offsets[c], offsets[c + 1] - 1
        for i in range(first, last):
            seg = seg_base[q] + i - first
            s0 = step_start[seg]
            n = step_start[seg + 1] - s0 - 1
            for k in range(n + 1):
                u = k / n
                for ch in range(3):
                    steps[s0 + k, 5 + ch] = values[i, ch] + (values[i + 1, ch] - values[i, ch]) * u


def bake(
    points: np.ndarray,
    offsets: np.ndarray,
    width: np.ndarray,
    opacity: np.ndarray,
    values: list[np.ndarray],
    size: int,
) -> tuple[np.ndarray, list[np.ndarray]]:
    """Draw strands given in texel space — ``points`` (P, 3) float32 (column, row, 0),
    ``offsets`` (C + 1,), ``width`` (P,) in texels, ``opacity`` (P,) — into a
    ``size``² atlas: their coverage (size, size) float32 and, for each of ``values``
    ((P, 3) each), its coverage-weighted mean at each texel (size, size, 3) float32, 0
    where no hair is."""
    from numba import get_num_threads

    points = np.ascontiguousarray(points, np.float32)
    offsets = np.ascontiguousarray(offsets, np.int64)
    order = space_order(points, offsets, 6)
    attrs = np.zeros((len(points), 7), np.float32)
    attrs[:, 0] = width
    attrs[:, 4] = opacity
    # texel space to clip space: x, y in [0, size] to [-1, 1]; rows counted downwards
    vp = np.diag([2.0 / size, 2.0 / size, 1.0, 1.0])
    vp[:2, 3] = -1.0
    # the view: no eye, orthographic, a texel a unit, steps at most MAX_STEP_PX texels
    view = np.array([0, 0, 1, 0, 0, 0, -1, 1, 0, 0, 1.0, MAX_STEP_PX], np.float64)
    counts, seg_base = segment_steps(points, offsets, order, view, _SUBDIVISIONS)
    step_start = np.zeros(len(counts) + 1, np.int64)
    np.cumsum(counts + 1, out=step_start[1:])
    # unshaded: no model, no lights (of the types the camera's pass gives, so the
    # kernel's one compiled signature serves both)
    lights = np.zeros((1, 3), np.float32)
    steps = fill_steps(
        points, offsets, order, attrs, seg_base, step_start, vp, view, float(size),
        float(size), False, 0, np.zeros(1), np.zeros((2, POWER_STEPS + 1)), np.zeros(2), 0,
        lights, lights, np.zeros(3), no_shadow(),
    )  # fmt: skip
    threads = get_num_threads()
    tile, nx, ny = tile_grid(size, size, threads)
    tile_start, items = bin_boxes(segment_boxes(steps, step_start), tile, nx, ny)
    ref = np.full((size, size, 1), np.inf)
    consts = np.array([1.0, 0.0, 1.0])  # OIT depth 1, sharpness 0: every weight 1
    coverage = None
    means = []
    for vals in values:
        _step_values(offsets, order, seg_base, step_start, np.asarray(vals, np.float32), steps)
        buf = np.zeros((size, size, 5), np.float32)
        buf[..., 4] = 1.0
        args = (steps, step_start, tile_start, items, tile, nx, buf, ref[..., 0], ref)
        draw_strands(PASSES["oit"], *args, consts, threads)
        weight = buf[..., 3:4]
        means.append(np.where(weight > 0, buf[..., :3] / np.where(weight > 0, weight, 1), 0))
        coverage = 1.0 - buf[..., 4]
    assert coverage is not None
    return coverage.astype(np.float32), [m.astype(np.float32) for m in means]
