"""Root placement: hair roots on the rest mesh, by area times root density.

A first sampler: one weight per triangle (area × density averaged over its corners
and centre), a CDF over triangles, and exactly two random numbers per root, the
first reused inside the chosen triangle (000 §2.1.5). Root k depends only on
(seed, k), so any index range can be generated on its own.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..mesh.skin import SkinMesh
from ..mesh.texture import Texture
from ..rng import purpose_id, uniforms

__all__ = ["triangle_weights", "sample_roots", "place_on_triangles"]

_ROOT_STREAM = purpose_id("root")


def triangle_weights(mesh: SkinMesh, density: Texture | float | None = None) -> np.ndarray:
    """Relative root probability of every triangle, float64 (F,)."""
    areas = mesh.face_areas("rest")
    if density is None or isinstance(density, (int, float)):
        if density is not None and not density > 0:
            raise InputError(f"density: must be positive, got {density}")
        weights = areas.copy()
    else:
        if mesh.uvs is None:
            raise InputError(
                f"mesh '{mesh.name}' has no UVs, so a density texture cannot be mapped"
            )
        corners = mesh.uvs[mesh.faces]  # (F, 3, 2)
        probes = np.concatenate([corners, corners.mean(axis=1, keepdims=True)], axis=1)
        values = density.sample(probes.reshape(-1, 2))
        if values.ndim > 1:
            values = values[:, 0]
        if np.any(values < 0):
            raise InputError(f"density texture '{density.name}' has negative values")
        weights = areas * values.reshape(-1, 4).mean(axis=1)
    if not np.any(weights > 0):
        raise InputError(
            f"mesh '{mesh.name}': the root density is zero everywhere; paint some density"
        )
    return weights


def sample_roots(
    weights: np.ndarray, count: int, seed: int = 0, start: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Roots ``start … start+count-1``: (triangle int32 (n,), bary float32 (n, 2)).

    ``bary`` follows 000 §2.2.3: position = u·v0 + v·v1 + (1-u-v)·v2.
    """
    if count < 0:
        raise InputError(f"count: must be ≥ 0, got {count}")
    xi = uniforms(seed, np.arange(start, start + count, dtype=np.int64), _ROOT_STREAM, 2)
    return place_on_triangles(weights, xi)


def place_on_triangles(weights: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Map pairs of numbers in [0, 1) to points on triangles chosen ∝ ``weights``.

    The first number picks the triangle through the CDF and, rescaled inside its
    interval, is reused with the second to place the point uniformly in the triangle
    (000 §2.1.5: exactly two numbers per sample). Returns (triangle int32 (n,),
    bary float32 (n, 2)) in the 000 §2.2.3 convention u·v0 + v·v1 + (1-u-v)·v2.
    """
    cdf = np.cumsum(weights, dtype=np.float64)
    target = xi[:, 0] * cdf[-1]
    tri = np.minimum(np.searchsorted(cdf, target, side="right"), len(cdf) - 1)
    low = np.where(tri > 0, cdf[tri - 1], 0.0)
    inner = np.clip((target - low) / np.maximum(weights[tri], 1e-300), 0.0, 1.0)
    root = np.sqrt(inner)
    bary = np.stack([1.0 - root, xi[:, 1] * root], axis=1)
    return tri.astype(np.int32), bary.astype(np.float32)
