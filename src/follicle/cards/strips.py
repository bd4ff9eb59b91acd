"""Card strips: each cluster of hairs (:mod:`.clusters`) as a flat strip along its centre
curve, lying on the skin, as wide as its hairs spread.

The centre curve is the mean of the members' arc-length samples (station k of every
member at the same fraction of its length), lifted along the skin normal to the
members' outer layer (:data:`OUTER_LAYER`): seen from outside, the outermost hairs draw
the groom's outline, and a flat card at the layer's middle would fall inside it. The
strip's frame starts from the mean skin normal at the members' roots and is carried
along the centre curve by rotation minimizing frames (Šik 2012 §2.2.8; Wang et al.
2008), so a card lies flat on the head where it grows and does not twist; its across
direction is tangent × normal. A member's point at station k has card coordinates
(across, depth): its offset from the centre there along the across direction and along
the normal. The card's width is twice the largest |across| of its members plus their
widest hair, so its texture holds every hair.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..frames import normalize, rotation_minimizing_frames

__all__ = ["OUTER_LAYER", "Strips", "fit_strips", "card_coordinates", "strip_mesh"]

OUTER_LAYER = 0.8  # the strip's height over the skin: this quantile of its members' depths


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
