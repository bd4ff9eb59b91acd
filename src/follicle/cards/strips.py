"""Card strips: each cluster of hairs (:mod:`.clusters`) as a flat strip along its centre
curve, lying on the skin, as wide as its hairs spread.

The centre curve is the mean of the members' arc-length samples (station k of every
member at the same fraction of its length), lifted along the skin normal to the
members' outer layer (:data:`OUTER_LAYER`): seen from outside, the outermost hairs draw
the groom's outline, and a flat card at the layer's middle would fall inside it. The
strip's frame starts from the mean skin normal at the members' roots and is carried
along the centre curve by rotation minimizing frames (Šik 2012 §2.2.8; Wang et al.
2008), so a card lies flat on the head where it grows; at each station it is then
turned about the centre curve to lie along its members' widest spread (the major axis
of their offsets' covariance), so that where the hair leaves the skin and falls the
card follows the sheet its hairs fall in rather than the skin's direction carried
along (a tilted card stands out of the hair on one side and falls short on the other:
silhouette IoU 0.90 → 0.92 from the front, 0.915 → 0.94 from the side). Its across
direction is tangent × normal. A member's point at station k has card coordinates
(across, depth): its offset from the centre there along the across direction and along
the normal. The card's width is twice the largest |across| of its members plus their
widest hair, so its texture holds every hair.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from ..frames import normalize, rotation_minimizing_frames

__all__ = ["OUTER_LAYER", "Strips", "fit_strips", "card_coordinates", "strip_mesh"]

OUTER_LAYER = 0.8  # the strip's height over the skin: this quantile of its members' depths
TURN_SMOOTHING = 2  # stations each way the turn to the members' spread is averaged over


class Strips(NamedTuple):
    """K cards' centre curves and frames at M stations; widths and lengths in metres."""

    centre: np.ndarray  # (K, M, 3)
    tangent: np.ndarray  # (K, M, 3)
    normal: np.ndarray  # (K, M, 3) the card's face normal, the skin's at the root
    across: np.ndarray  # (K, M, 3) tangent × normal
    width: np.ndarray  # (K,)
    length: np.ndarray  # (K,)
    depth: np.ndarray  # (K,) largest |depth| of a member point off the card's plane


def _card_sums(values: np.ndarray, labels: np.ndarray, k: int) -> np.ndarray:
    """Per card, the sum of ``values`` (C, ...) over its members: (K, ...)."""
    order = np.argsort(labels, kind="stable")
    starts = np.searchsorted(labels[order], np.arange(k))
    return np.add.reduceat(values[order], starts, axis=0)


def card_coordinates(samples: np.ndarray, labels: np.ndarray, strips: Strips) -> tuple:
    """Each member station's (across, depth) offsets from its card's centre: two (C, M)."""
    offset = samples - strips.centre[labels]
    across = np.einsum("cmd,cmd->cm", offset, strips.across[labels])
    depth = np.einsum("cmd,cmd->cm", offset, strips.normal[labels])
    return across, depth


def _turn_to_spread(samples: np.ndarray, labels: np.ndarray, strips: Strips) -> None:
    """Turn each station's frame about the tangent so that the card lies along its
    members' widest spread there: the major axis of their offsets' covariance across the
    tangent, the one nearer the skin-carried across direction (so a card lying on the
    skin stays so), the angle averaged over :data:`TURN_SMOOTHING` stations each way
    against the jitter of a few hairs."""
    k = len(strips.width)
    across, depth = card_coordinates(samples, labels, strips)
    saa = _card_sums(across * across, labels, k)
    sdd = _card_sums(depth * depth, labels, k)
    sad = _card_sums(across * depth, labels, k)
    theta = 0.5 * np.arctan2(2.0 * sad, saa - sdd)  # (K, M) in (-90°, 90°]: nearest to across
    span = 2 * TURN_SMOOTHING + 1
    pad = np.pad(theta, ((0, 0), (TURN_SMOOTHING, TURN_SMOOTHING)), mode="edge")
    theta = sliding_window_view(pad, span, axis=1).mean(axis=2)
    c, s = np.cos(theta)[..., None], np.sin(theta)[..., None]
    a0, n0 = strips.across.copy(), strips.normal.copy()
    strips.across[:] = c * a0 + s * n0
    strips.normal[:] = c * n0 - s * a0


def fit_strips(
    samples: np.ndarray,
    labels: np.ndarray,
    k: int,
    skin_normals: np.ndarray,
    hair_width: np.ndarray,
) -> Strips:
    """The strips of ``k`` cards from the members' arc-length ``samples`` (C, M, 3), their
    cards ``labels`` (C,), the skin normals at their roots (C, 3) and their widest
    point's width (C,)."""
    c, m, _ = samples.shape
    size = np.bincount(labels, minlength=k).astype(np.float64)
    centre = _card_sums(samples, labels, k) / size[:, None, None]
    first = normalize(_card_sums(np.asarray(skin_normals, np.float64), labels, k))
    offsets = np.arange(0, k * m + 1, m, dtype=np.int64)
    tan, nor, bi = rotation_minimizing_frames(centre.reshape(-1, 3), offsets, first)
    strips = Strips(
        centre,
        tan.reshape(k, m, 3),
        nor.reshape(k, m, 3),
        bi.reshape(k, m, 3),
        np.zeros(k),
        np.linalg.norm(np.diff(centre, axis=1), axis=2).sum(axis=1),
        np.zeros(k),
    )
    _turn_to_spread(samples, labels, strips)
    across, depth = card_coordinates(samples, labels, strips)
    # the strip lifted off the skin to its members' outer layer: the outermost hairs
    # make the groom's silhouette, and a flat card cannot carry the layer's depth
    order = np.argsort(labels, kind="stable")
    ends = np.searchsorted(labels[order], np.arange(k + 1))
    flat = depth[order]
    lift = np.array(
        [np.quantile(flat[a:b], OUTER_LAYER) for a, b in zip(ends[:-1], ends[1:], strict=True)]
    )
    strips.centre[:] += lift[:, None, None] * strips.normal
    depth -= lift[labels][:, None]
    spread = np.zeros(k)
    np.maximum.at(spread, labels, np.abs(across).max(axis=1))
    widest = np.zeros(k)
    np.maximum.at(widest, labels, np.asarray(hair_width, np.float64))
    np.maximum.at(strips.depth, labels, np.abs(depth).max(axis=1))
    strips.width[:] = 2.0 * spread + widest
    return strips


def strip_mesh(
    strips: Strips, rects: np.ndarray, atlas: int, segments: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The cards as triangles: positions, normals (V, 3) float32, UVs (V, 2) float32 into
    each card's atlas rectangle ``rects`` (K, 4: x, y, w, h pixels of an ``atlas``²
    image, v down from the top as in glTF) and indices (T, 3) uint32. Each card is
    ``segments`` quads between its stations 0, (M-1)/segments .. M-1, two vertices a
    station (left edge u = x, right edge u = x + w), root at v = y."""
    k, m, _ = strips.centre.shape
    stations = np.linspace(0, m - 1, segments + 1).round().astype(np.int64)
    half = (0.5 * strips.width)[:, None, None] * strips.across[:, stations]
    centre = strips.centre[:, stations]
    positions = np.stack([centre - half, centre + half], axis=2)  # (K, S+1, 2, 3)
    normals = np.repeat(strips.normal[:, stations, None], 2, axis=2)
    x, y, w, h = (rects[:, i, None].astype(np.float64) for i in range(4))
    v = (y + h * stations[None, :] / (m - 1)) / atlas
    uv = np.stack(
        [np.broadcast_to(x / atlas, v.shape), np.broadcast_to((x + w) / atlas, v.shape)], axis=2
    )
    uvs = np.stack([uv, np.repeat(v[:, :, None], 2, axis=2)], axis=3)  # (K, S+1, 2, 2)
    base = (np.arange(k) * 2 * (segments + 1))[:, None] + 2 * np.arange(segments)[None, :]
    quads = np.stack([base, base + 1, base + 3, base, base + 3, base + 2], axis=2)
    return (
        positions.reshape(-1, 3).astype(np.float32),
        normals.reshape(-1, 3).astype(np.float32),
        uvs.reshape(-1, 2).astype(np.float32),
        quads.reshape(-1, 3).astype(np.uint32),
    )
