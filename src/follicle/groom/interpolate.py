"""Hair shapes from guides in root-local frames: blending (Šik 2012 §2.2.4 IDW weights, or
barycentric ones) and the single-strand offsets of Le Muzic 2012 §5.1.4."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..kernels import kernel, prange
from ..rng import purpose_id, uniforms
from .knn import PointGrid
from .params import per_hair, row

__all__ = ["idw_weights", "guide_turn", "blend_guides", "tilt", "translate_guides"]

_TILT = purpose_id("offset angle")


def idw_weights(
    guide_roots: PointGrid | np.ndarray, hair_roots: np.ndarray, samples: int
) -> tuple[np.ndarray, np.ndarray]:
    """The n+1 nearest guides of every hair and their weights (Šik 2012 §2.2.4).

    ``guide_roots`` is a PointGrid over the guide roots (build it once per group) or
    the (S, 3) roots. Weights are ((r - d) / (r d))², normalised, with r the distance
    of the (n+1)-th nearest guide, so the farthest one fades out smoothly. A hair on
    a guide root copies that guide. Returns (indices int64 (H, k), weights float32 (H, k)).
    """
    if samples < 1:
        raise InputError(f"guide_samples: need at least 1, got {samples}")
    grid = guide_roots if isinstance(guide_roots, PointGrid) else PointGrid(guide_roots)
    k = min(samples + 1, grid.n)
    dist, idx = grid.query(hair_roots, k)
    w = np.empty(dist.shape, dtype=np.float32)
    _idw_kernel(dist, w)
    return idx, w


@kernel(parallel=True, nogil=True)
def _idw_kernel(dist, w):
    k = dist.shape[1]
    for h in prange(dist.shape[0]):
        d = dist[h]
        if k == 1 or d[0] <= 1e-12:  # on a guide root (or one guide): copy it
            for j in range(k):
                w[h, j] = 0.0
            w[h, 0] = 1.0
            continue
        r = d[k - 1]
        total = 0.0
        for j in range(k):
            x = (r - d[j]) / (r * d[j])
            total += x * x
        if not total > 0.0 or not np.isfinite(total):  # all equidistant: equal weights
            for j in range(k):
                w[h, j] = 1.0 / k
            continue
        for j in range(k):
            x = (r - d[j]) / (r * d[j])
            w[h, j] = x * x / total


@kernel(parallel=True, nogil=True)
def _turn_kernel(index, weight, guide_tangents, tangent, binormal, out):
    for h in prange(index.shape[0]):
        tx = 0.0
        ty = 0.0
        tz = 0.0
        for j in range(index.shape[1]):
            g = index[h, j]
            wj = weight[h, j]
            tx += wj * guide_tangents[g, 0]
            ty += wj * guide_tangents[g, 1]
            tz += wj * guide_tangents[g, 2]
        x = tx * tangent[h, 0] + ty * tangent[h, 1] + tz * tangent[h, 2]
        y = tx * binormal[h, 0] + ty * binormal[h, 1] + tz * binormal[h, 2]
        r = np.hypot(x, y)
        if r <= 1e-9:  # guides' tangents cancel out or stand on the normal: no turn
            out[h, 0] = 1.0
            out[h, 1] = 0.0
        else:
            out[h, 0] = x / r
            out[h, 1] = y / r


def guide_turn(
    index: np.ndarray,
    weight: np.ndarray,
    guide_tangents: np.ndarray,
    tangent: np.ndarray,
    binormal: np.ndarray,
) -> np.ndarray:
    """(cos, sin) (H, 2) of the angle about the normal from each root's ``tangent`` to the
    ``weight``-ed sum of its guides' root tangents, projected on its tangent plane.

    Root-local frames follow the UV tangent, which spins around UV poles and seams;
    turned by this angle, a hair's frame lines up with its guides', so it bends the way
    they do everywhere. At a guide root the turn is 0. No turn where the guides'
    tangents cancel out or stand on the normal.
    """
    out = np.empty((len(index), 2), dtype=np.float64)
    _turn_kernel(
        np.ascontiguousarray(index, np.int64),
        np.ascontiguousarray(weight, np.float32),
        np.ascontiguousarray(guide_tangents, np.float64),
        np.ascontiguousarray(tangent),
        np.ascontiguousarray(binormal),
        out,
    )
    return out


@kernel(parallel=True, nogil=True)
def _blend_kernel(local, idx, w, scale, out):
    n_verts = out.shape[1]
    for h in prange(idx.shape[0]):
        sc = scale[row(scale, h)]
        for i in range(n_verts):
            x = 0.0
            y = 0.0
            z = 0.0
            for j in range(idx.shape[1]):
                g = idx[h, j]
                wj = w[h, j]
                x += wj * local[g, i, 0]
                y += wj * local[g, i, 1]
                z += wj * local[g, i, 2]
            out[h, i, 0] = sc * x
            out[h, i, 1] = sc * y
            out[h, i, 2] = sc * z


def blend_guides(
    local: np.ndarray,
    indices: np.ndarray,
    weights: np.ndarray,
    vertices: int,
    scale: float | np.ndarray = 1.0,
) -> np.ndarray:
    """Weighted guide shapes in root-local frames, times ``scale``: (H, vertices, 3) float64.

    ``local`` (S, N, 3) holds the guides in their root frames (Šik 2012 §2.2.4); only the
    first ``vertices`` ≤ N are blended (a cut hair never needs the rest, §2.2.8).
    """
    out = np.empty((len(indices), vertices, 3), dtype=np.float64)
    _blend_kernel(
        np.ascontiguousarray(local, np.float32),
        np.ascontiguousarray(indices, np.int64),
        np.ascontiguousarray(weights, np.float32),
        per_hair(scale, len(indices), "scale"),
        out,
    )
    return out


@kernel(parallel=True, nogil=True)
def _tilt_kernel(local, ca, sa, cb, sb):
    for h in prange(local.shape[0]):
        for i in range(local.shape[1]):
            x, y, z = local[h, i, 0], local[h, i, 1], local[h, i, 2]
            y, z = ca[h] * y - sa[h] * z, sa[h] * y + ca[h] * z  # about the root tangent x
            x, z = cb[h] * x + sb[h] * z, -sb[h] * x + cb[h] * z  # about the binormal y
            local[h, i, 0], local[h, i, 1], local[h, i, 2] = x, y, z


def tilt(local: np.ndarray, seed: int, ids: np.ndarray, max_angle: float) -> None:
    """Le Muzic 2012 §5.1.4 single-strand offset by angle, in place: each hair (root-local) turns
    about its root tangent and binormal by two random angles in ±``max_angle`` degrees
    from the (seed, id, "offset angle") stream, so copies of one guide fan out instead
    of clustering."""
    u = uniforms(seed, ids, _TILT, 2)
    angle = np.radians(max_angle) * (2.0 * u - 1.0)
    c, s = np.cos(angle), np.sin(angle)
    _tilt_kernel(local, c[:, 0].copy(), s[:, 0].copy(), c[:, 1].copy(), s[:, 1].copy())


@kernel(parallel=True, nogil=True)
def _reframe_kernel(rel, idx, tangent, binormal, normal, scale, out):
    for h in prange(idx.shape[0]):
        g = idx[h]
        sc = scale[row(scale, h)]
        for i in range(out.shape[1]):
            x, y, z = rel[g, i, 0], rel[g, i, 1], rel[g, i, 2]
            out[h, i, 0] = sc * (x * tangent[h, 0] + y * tangent[h, 1] + z * tangent[h, 2])
            out[h, i, 1] = sc * (x * binormal[h, 0] + y * binormal[h, 1] + z * binormal[h, 2])
            out[h, i, 2] = sc * (x * normal[h, 0] + y * normal[h, 1] + z * normal[h, 2])


def translate_guides(
    rel: np.ndarray,
    indices: np.ndarray,
    rest_frame: tuple[np.ndarray, np.ndarray, np.ndarray],
    vertices: int,
    scale: float | np.ndarray = 1.0,
) -> np.ndarray:
    """Le Muzic 2012 §5.1.4 single-strand offset by displacement: guide ``indices[h]``'s rest shape
    ``rel`` (S, N, 3, world axes, root at 0) moved to hair h's root unturned, in the
    hair's root-local frame (T, B, N rows of ``rest_frame``), times ``scale``."""
    out = np.empty((len(indices), vertices, 3), dtype=np.float64)
    _reframe_kernel(
        np.ascontiguousarray(rel, np.float32),
        np.ascontiguousarray(indices, np.int64),
        *(np.ascontiguousarray(a, np.float64) for a in rest_frame),
        per_hair(scale, len(indices), "scale"),
        out,
    )
    return out
