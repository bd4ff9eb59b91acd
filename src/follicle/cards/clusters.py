"""Hairs grouped into cards: one cluster of hairs per card, a count per level of detail.

A card stands for hairs that run together, so hairs are clustered by where they grow
and where they go: each hair is described by its points at a few arc-length fractions
(root to tip) and the descriptions are clustered by Lloyd's k-means (Lloyd 1982) from a
k-means++ start (Arthur & Vassilvitskii 2007), the nearest centre found by a k-d tree.
Where the groom stores a grouping of its hairs (``curve_data['clump_id']`` or
``['guide_id']``) and there are at least as many groups as cards, whole groups are
clustered, so a clump is never split across cards. The start draws from a generator
seeded by ``seed`` alone: the same hairs and seed give the same clusters.
"""

from __future__ import annotations

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..groom.guides import resample_arclength

__all__ = ["GROUP_KEYS", "cluster_hairs"]

GROUP_KEYS = ("clump_id", "guide_id")  # curve_data keys that group hairs, first found used
SHAPE_SAMPLES = 4  # points per hair that describe it to the clustering: root .. tip
ITERATIONS = 12  # Lloyd iterations (the labels settle in fewer on grooms)


def _groups(curves: HairCurves) -> np.ndarray | None:
    """Each hair's group index 0..G-1 from the first of :data:`GROUP_KEYS` present."""
    for key in GROUP_KEYS:
        ids = curves.curve_data.get(key)
        if ids is not None:
            return np.unique(np.asarray(ids).reshape(len(curves)), return_inverse=True)[1]
    return None


def _kmeans(x: np.ndarray, weight: np.ndarray, k: int, seed: int) -> np.ndarray:
    """Labels 0..k-1 of the rows of ``x`` by weighted k-means, every label used."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    n = len(x)
    # k-means++ start: each next centre drawn with probability ∝ weight · D²
    chosen = [int(rng.choice(n, p=weight / weight.sum()))]
    d2 = np.sum((x - x[chosen[0]]) ** 2, axis=1)
    for _ in range(1, k):
        p = weight * d2
        total = p.sum()
        pick = int(rng.choice(n, p=p / total)) if total > 0 else int(np.argmax(d2))
        chosen.append(pick)
        d2 = np.minimum(d2, np.sum((x - x[pick]) ** 2, axis=1))
    centres = x[chosen].copy()
    labels = np.full(n, -1, np.int64)
    for _ in range(ITERATIONS):
        dist, new = cKDTree(centres).query(x)
        new = np.asarray(new, np.int64)
        # an emptied cluster takes the row farthest from its centre (labels stay 0..k-1)
        counts = np.bincount(new, minlength=k)
        for empty in np.flatnonzero(counts == 0):
            far = int(np.argmax(np.where(counts[new] > 1, dist, -1.0)))
            counts[new[far]] -= 1
            new[far] = empty
            counts[empty] = 1
            dist[far] = 0.0
        if np.array_equal(new, labels):
            break
        labels = new
        w = np.bincount(labels, weights=weight, minlength=k)
        for d in range(x.shape[1]):
            centres[:, d] = np.bincount(labels, weights=weight * x[:, d], minlength=k) / w
    return labels


def cluster_hairs(
    curves: HairCurves, count: int, seed: int = 0, option: str = "counts"
) -> np.ndarray:
    """Each hair's card, (C,) int64 in 0..count-1, every card with hairs.

    ``option`` names the setting that asked for ``count`` in the error raised when
    there are fewer hairs than cards.
    """
    n = len(curves)
    if count < 1:
        raise InputError(f"{option}: {count} cards; give each level of detail at least 1 card")
    if count > n:
        raise InputError(
            f"{option}: {count:,} cards for {n:,} hairs; ask for at most one card a hair"
        )
    shape = resample_arclength(curves, SHAPE_SAMPLES, what="hair").reshape(n, -1)
    groups = _groups(curves)
    if groups is None or groups.max() + 1 < count:
        return _kmeans(shape, np.ones(n), count, seed)
    g = int(groups.max()) + 1
    size = np.bincount(groups, minlength=g).astype(np.float64)
    mean = np.stack(
        [np.bincount(groups, weights=shape[:, d], minlength=g) for d in range(shape.shape[1])],
        axis=1,
    )
    return _kmeans(mean / size[:, None], size, count, seed)[groups]
