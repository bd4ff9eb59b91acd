"""Clumping: hairs pulled towards the hair at the centre of their clump.

Clump centres are extra roots drawn by the density sampler (a Halton sequence, so
they spread evenly); each hair joins the nearest centre of its own interpolation group
on the rest mesh. The centre hair is grown like any hair; vertex i of a member moves
towards the centre's vertex i by a(t) = (root + (tip − root) t^profile)(1 − noise ξ),
ξ per hair from (seed, id). Everything happens in rest-pose root-local frames, so
clumps keep their shape on an animated mesh and any chunking gives the same bytes.
"""

from __future__ import annotations

import numpy as np

from ..kernels import kernel, prange
from ..rng import purpose_id, stream_key, uniform
from .knn import PointGrid
from .params import per_hair, row

__all__ = ["assign_clumps", "clump"]

_CLUMP = purpose_id("clump noise")


def assign_clumps(
    centre_roots: np.ndarray, centre_group: np.ndarray, roots: np.ndarray, group: np.ndarray
) -> np.ndarray:
    """Index of the nearest clump centre of the same group for every root; −1 if none."""
    out = np.full(len(roots), -1, dtype=np.int64)
    for g in np.unique(group):
        members = np.flatnonzero(centre_group == g)
        if len(members) == 0:
            continue
        sel = np.flatnonzero(group == g)
        _, nearest = PointGrid(centre_roots[members]).query(roots[sel], 1)
        out[sel] = members[nearest[:, 0]]
    return out


@kernel(parallel=True, nogil=True)
def _clump_kernel(
    local,
    centre,
    which,
    root,
    tangent,
    binormal,
    normal,
    a_root,
    a_tip,
    profile,
    noise,
    ids,
    seed,
    t,
):
    n = local.shape[1]
    for h in prange(local.shape[0]):
        c = which[h]
        if c < 0:
            continue
        ar = a_root[row(a_root, h)]
        at = a_tip[row(a_tip, h)]
        k = 1.0 - noise[row(noise, h)] * uniform(stream_key(seed, ids[h], _CLUMP), 0)
        th = t[row(t, h)]
        for i in range(1, n):
            a = (ar + (at - ar) * th[i] ** profile) * k
            dx = centre[c, i, 0] - root[h, 0]
            dy = centre[c, i, 1] - root[h, 1]
            dz = centre[c, i, 2] - root[h, 2]
            gx = dx * tangent[h, 0] + dy * tangent[h, 1] + dz * tangent[h, 2]
            gy = dx * binormal[h, 0] + dy * binormal[h, 1] + dz * binormal[h, 2]
            gz = dx * normal[h, 0] + dy * normal[h, 1] + dz * normal[h, 2]
            local[h, i, 0] += a * (gx - local[h, i, 0])
            local[h, i, 1] += a * (gy - local[h, i, 1])
            local[h, i, 2] += a * (gz - local[h, i, 2])


def clump(
    local: np.ndarray,
    centre: np.ndarray,
    which: np.ndarray,
    rest_frame: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    attract_root: float | np.ndarray,
    attract_tip: float | np.ndarray,
    profile: float,
    noise: float | np.ndarray,
    ids: np.ndarray,
    seed: int,
    t: np.ndarray,
) -> None:
    """Pull hairs ``local`` (m, n, 3, root-local, in place) towards their clump centres.

    ``centre`` (C, ≥n, 3) holds the centre hairs in rest world space, ``which`` (m,)
    each hair's centre (−1: none), ``rest_frame`` = (root, T, B, N) each (m, 3) on the
    rest pose, ``t`` (1|m, n) the curve parameters. The root vertex never moves.
    """
    m = len(local)
    _clump_kernel(
        local,
        np.ascontiguousarray(centre, dtype=np.float64),
        which,
        *(np.ascontiguousarray(a, dtype=np.float64) for a in rest_frame),
        per_hair(attract_root, m, "clump_root", 0.0, 1.0),
        per_hair(attract_tip, m, "clump_tip", 0.0, 1.0),
        float(profile),
        per_hair(noise, m, "clump_noise", 0.0, 1.0),
        ids,
        np.uint64(seed),
        t,
    )
