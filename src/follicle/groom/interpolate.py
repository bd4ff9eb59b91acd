"""Hair shapes from guides by inverse-distance weighting in root-local frames (000 §2.2.4)."""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from ..errors import InputError

__all__ = ["idw_weights", "blend_guides"]


def idw_weights(
    guide_roots: cKDTree | np.ndarray, hair_roots: np.ndarray, samples: int
) -> tuple[np.ndarray, np.ndarray]:
    """The n+1 nearest guides of every hair and their weights (000 §2.2.4).

    ``guide_roots`` is a cKDTree over the guide roots (build it once per group) or
    the (S, 3) roots. Weights are ((r - d) / (r d))², normalised, with r the distance
    of the (n+1)-th nearest guide, so the farthest one fades out smoothly. A hair on
    a guide root copies that guide. Returns (indices int64 (H, k), weights float32 (H, k)).
    """
    if samples < 1:
        raise InputError(f"guide_samples: need at least 1, got {samples}")
    tree = guide_roots if isinstance(guide_roots, cKDTree) else cKDTree(guide_roots)
    k = min(samples + 1, tree.n)
    dist, idx = tree.query(hair_roots, k=k)
    if k == 1:
        return idx.reshape(-1, 1).astype(np.int64), np.ones((len(hair_roots), 1), np.float32)
    r = dist[:, -1:]
    with np.errstate(divide="ignore", invalid="ignore"):
        w = ((r - dist) / (r * dist)) ** 2
    exact = dist[:, 0] <= 1e-12
    w[exact] = 0.0
    w[exact, 0] = 1.0
    flat = ~np.isfinite(w).all(axis=1) | (w.sum(axis=1) <= 0)  # all equidistant
    w[flat] = 1.0
    w /= w.sum(axis=1, keepdims=True)
    return idx.astype(np.int64), w.astype(np.float32)


@njit(cache=True)
def _blend_kernel(local, idx, w, origin, tangent, binormal, normal, scale, out):
    n_hairs, k = idx.shape
    n_verts = local.shape[1]
    for h in range(n_hairs):
        for i in range(n_verts):
            x = 0.0
            y = 0.0
            z = 0.0
            for j in range(k):
                g = idx[h, j]
                wj = w[h, j]
                x += wj * local[g, i, 0]
                y += wj * local[g, i, 1]
                z += wj * local[g, i, 2]
            x *= scale
            y *= scale
            z *= scale
            for a in range(3):
                out[h, i, a] = (
                    origin[h, a] + x * tangent[h, a] + y * binormal[h, a] + z * normal[h, a]
                )


def blend_guides(
    local: np.ndarray,
    indices: np.ndarray,
    weights: np.ndarray,
    origin: np.ndarray,
    tangent: np.ndarray,
    binormal: np.ndarray,
    normal: np.ndarray,
    scale: float = 1.0,
) -> np.ndarray:
    """Weighted guide shapes (S, N, 3 in root frames) placed on each hair's frame, (H, N, 3)."""
    out = np.empty((len(indices), local.shape[1], 3), dtype=np.float32)
    _blend_kernel(
        np.ascontiguousarray(local, np.float32),
        np.ascontiguousarray(indices, np.int64),
        np.ascontiguousarray(weights, np.float32),
        *(np.ascontiguousarray(a, np.float64) for a in (origin, tangent, binormal, normal)),
        float(scale),
        out,
    )
    return out
