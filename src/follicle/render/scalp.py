"""The skin under the hair tinted with the colour of the roots growing there, as game
engines paint a scalp texture under their hair cards: between the strands the eye sees
root-coloured skin, not bare skin, so a parting or a crown whorl reads as hair.

:func:`skin_colors` gives the skin's per-vertex colour from the roots near each vertex:
their mean root colour, weighted by how densely roots cover the place (1 within about
two root spacings of a root, fading to 0 by six), times ``[render].scalp_tint``. It
depends on the drawn hair only, so any skin and any groom get it, and it follows the
roots frame by frame when the skin moves."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..curves import HairCurves

__all__ = ["skin_colors", "NEAR_SPACINGS", "FAR_SPACINGS"]

NEAR_SPACINGS = 2.0  # full tint within this many root spacings of a root …
FAR_SPACINGS = 6.0  # … none beyond this many
_NEIGHBOURS = 4  # roots averaged for a vertex's tint colour
_SPACING_SAMPLE = 4096  # roots whose nearest neighbour gives the spacing


def skin_colors(
    vertices: np.ndarray,
    skin_color: np.ndarray,
    curves: HairCurves | None,
    hair_color: np.ndarray,
    tint: float,
) -> np.ndarray:
    """(V, 3) float32 linear RGB of the skin's ``vertices``: ``skin_color`` blended
    towards the colour of the nearby roots of ``curves`` (their first vertex's
    ``color``, else ``hair_color``) by ``tint`` where roots are dense (see the
    module). No hair or no tint: ``skin_color`` everywhere."""
    out = np.empty((len(vertices), 3), np.float32)
    out[:] = skin_color
    if curves is None or tint <= 0.0 or curves.curve_count == 0 or len(vertices) == 0:
        return out
    from scipy.spatial import cKDTree

    starts = curves.offsets[:-1]
    roots = np.asarray(curves.points[starts], np.float64)
    colors = curves.point_data.get("color")
    root_rgb = (
        np.broadcast_to(np.asarray(hair_color, np.float64), (len(roots), 3))
        if colors is None
        else np.asarray(colors[starts], np.float64).reshape(len(roots), 3)
    )
    tree = cKDTree(roots)
    spacing = _root_spacing(tree, roots)
    if spacing <= 0.0:
        return out
    far = FAR_SPACINGS * spacing
    k = min(_NEIGHBOURS, len(roots))
    dist, index = tree.query(np.asarray(vertices, np.float64), k=k, distance_upper_bound=far)
    dist, index = dist.reshape(len(vertices), k), index.reshape(len(vertices), k)
    found = np.isfinite(dist)
    count = found.sum(axis=1)
    near = count > 0
    if not near.any():
        return out
    picked = np.where(found, index, 0)
    mean = (root_rgb[picked] * found[..., None]).sum(axis=1)[near] / count[near, None]
    x = np.clip((far - dist[near, 0]) / (far - NEAR_SPACINGS * spacing), 0.0, 1.0)
    weight = tint * x * x * (3.0 - 2.0 * x)  # smoothstep from far to near
    blend = (1.0 - weight[:, None]) * np.asarray(skin_color, np.float64) + weight[:, None] * mean
    out[near] = blend
    return out


def _root_spacing(tree: Any, roots: np.ndarray) -> float:
    """The typical distance between neighbouring roots: the median, over up to
    4,096 evenly picked roots, of the distance to the nearest other root (coincident
    roots left out)."""
    if len(roots) < 2:
        return 0.0
    sample = roots[:: max(1, len(roots) // _SPACING_SAMPLE)]
    dist, _ = tree.query(sample, k=2)
    apart = dist[:, 1][dist[:, 1] > 0.0]
    return float(np.median(apart)) if len(apart) else 0.0
