"""Per-vertex width, opacity and colour: root and tip values interpolated (000 §2.2.6, §2.2.9)."""

from __future__ import annotations

import numpy as np

from ..color import hsv_to_rgb, lerp_hsv, rgb_to_hsv

__all__ = ["vertex_parameter", "root_to_tip"]


def vertex_parameter(vertices: int) -> np.ndarray:
    """Uniform curve parameter t = i / (N - 1) of each vertex (000 §2.2.8), float64 (N,)."""
    return np.linspace(0.0, 1.0, vertices)


def root_to_tip(
    hairs: int,
    vertices: int,
    root_width: float,
    tip_width: float,
    root_color: tuple[float, float, float],
    tip_color: tuple[float, float, float],
    root_opacity: float,
    tip_opacity: float,
) -> dict[str, np.ndarray]:
    """``width``, ``opacity`` (P,) and ``color`` (P, 3) for ``hairs`` hairs of equal length.

    Width and opacity are linear in t; colour is interpolated in HSV along the
    shortest hue route, then converted to linear RGB (000 §2.2.6).
    """
    t = vertex_parameter(vertices)
    width = (1.0 - t) * root_width + t * tip_width
    opacity = (1.0 - t) * root_opacity + t * tip_opacity
    root_hsv, tip_hsv = rgb_to_hsv(np.asarray(root_color)), rgb_to_hsv(np.asarray(tip_color))
    hsv = lerp_hsv(root_hsv, tip_hsv, t)
    color = hsv_to_rgb(hsv)
    return {
        "width": np.tile(width.astype(np.float32), hairs),
        "opacity": np.tile(opacity.astype(np.float32), hairs),
        "color": np.tile(color.astype(np.float32), (hairs, 1)),
    }
