"""Hair strands: several fibres grown around each generated hair (Šik 2012 §2.2.7).

The generated hair (the *main hair*) stays in its root-local frame (Šik 2012 §2.2.2: strands
are made before the transform to world space); every fibre vertex ``P_i`` is put on the
plane through the main hair vertex ``P_i^M`` spanned by the main hair's curve normal
``N_i`` and binormal ``B_i`` (equation 2.5)::

    P_i = scale · [P_i^M + d·splay(t_i)·(cos φ_i·N_i + sin φ_i·aspect·B_i)
                   + offset·t_i³·N_i]

    splay(t) = 4(t − ½)²·border(t) + (1 − 4(t − ½)²)·centre,
    border(t) = tip if t > ½ else root

``(d, φ)`` is the fibre's place in a unit disc (concentric sampling, Shirley & Chiu),
``φ_i`` advances by a constant twist step per vertex with the paper's incremental
sine/cosine recurrence, and ``scale = 1 − randomize·ξ``. Every random number is a pure
function of (seed, hair id · count + fibre, purpose), so chunks of hairs can be made in
any order or split and give the same bytes.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import InputError
from ..frames import polyline_frames
from ..kernels import kernel, prange
from ..rng import purpose_id, stream_key, uniform
from ..validate import whole
from .params import per_hair, row

__all__ = ["make_fibres", "inherit", "splay_profile"]

_DISC_STREAM = purpose_id("strand disc")  # two numbers: the concentric disc sample
_RANDOM_STREAM = purpose_id("strand randomize")  # one number: ξ of Randomize_Strand
_BLOCK = 64  # hairs per parallel work item (the per-hair frame scratch is reused)
_QUARTER_PI = np.pi / 4.0
_HALF_PI = np.pi / 2.0
_ROOT_TANGENT = np.array([1.0, 0.0, 0.0])  # local +x: the first normal of every hair frame


# ------------------------------------------------------------------ numba helpers
@kernel(inline="always")
def _concentric(u0, u1):
    """Uniform [0,1)² → unit disc, area preserving (Shirley & Chiu; PBRT 13.6.2)."""
    a = 2.0 * u0 - 1.0
    b = 2.0 * u1 - 1.0
    if a == 0.0 and b == 0.0:
        return 0.0, 0.0
    if abs(a) > abs(b):
        r = a
        theta = _QUARTER_PI * (b / a)
    else:
        r = b
        theta = _HALF_PI - _QUARTER_PI * (a / b)
    return r * np.cos(theta), r * np.sin(theta)


@kernel(parallel=True, nogil=True)
def _fibres_kernel(
    local, ids, seed, count, s_root, s_centre, s_tip, twist, aspect, offset, randomize, out, uv
):
    n, nv = local.shape[0], local.shape[1]
    inv = 1.0 / (nv - 1)
    ucount = np.uint64(count)
    for blk in prange((n + _BLOCK - 1) // _BLOCK):
        tan = np.empty((nv, 3))
        nor = np.empty((nv, 3))
        bi = np.empty((nv, 3))
        spl = np.empty(nv)
        off = np.empty(nv)
        for h in range(blk * _BLOCK, min(n, (blk + 1) * _BLOCK)):
            p = local[h]
            polyline_frames(p, _ROOT_TANGENT, tan, nor, bi)
            for i in range(nv):
                t = i * inv
                w = 4.0 * (t - 0.5) * (t - 0.5)
                border = s_tip[row(s_tip, h)] if t > 0.5 else s_root[row(s_root, h)]
                spl[i] = w * border + (1.0 - w) * s_centre[row(s_centre, h)]
                off[i] = offset[row(offset, h)] * (t * t * t)
            step = twist[row(twist, h)] * inv
            ct = np.cos(step)
            st = np.sin(step)
            asp = aspect[row(aspect, h)]
            rnd = randomize[row(randomize, h)]
            base = np.uint64(ids[h]) * ucount
            for j in range(count):
                f = h * count + j
                fid = base + np.uint64(j)
                key = stream_key(seed, fid, _DISC_STREAM)
                x, y = _concentric(uniform(key, 0), uniform(key, 1))
                uv[f, 0] = x
                uv[f, 1] = y
                d = np.sqrt(x * x + y * y)
                if d > 0.0:
                    c = x / d
                    s = y / d
                else:
                    c = 1.0
                    s = 0.0
                scale = 1.0 - rnd * uniform(stream_key(seed, fid, _RANDOM_STREAM), 0)
                for i in range(nv):
                    if i > 0:  # Šik 2012 §2.2.7: sin/cos of φ_i from those of φ_{i-1}
                        c, s = c * ct - s * st, s * ct + c * st
                    di = d * spl[i]
                    a = di * c
                    b = di * s * asp
                    for k in range(3):
                        out[f, i, k] = scale * (
                            p[i, k] + (a * nor[i, k] + b * bi[i, k]) + off[i] * nor[i, k]
                        )


# ------------------------------------------------------------------ Python API
def splay_profile(t: object, root: float, centre: float, tip: float) -> np.ndarray:
    """splay(t) of Šik 2012 §2.2.7: root at t = 0, centre at ½, tip at 1, quadratic between.

    4(t − ½)²·border(t) + (1 − 4(t − ½)²)·centre with border = tip for t > ½, else root.
    """
    t = np.asarray(t, dtype=np.float64)
    w = 4.0 * (t - 0.5) ** 2
    return w * np.where(t > 0.5, tip, root) + (1.0 - w) * centre


def make_fibres(
    local: np.ndarray,
    hair_ids: np.ndarray,
    seed: int,
    count: int,
    splay_root: object,
    splay_centre: object,
    splay_tip: object,
    twist: object = 0.0,
    aspect: object = 1.0,
    offset: object = 0.0,
    randomize: object = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``count`` fibres around every hair of a chunk, in the hairs' root-local frames.

    Parameters
    ----------
    local : (n, N, 3) float
        Main hairs in their root-local frames (x = root tangent, y = binormal,
        z = surface normal), vertex 0 the root at the origin, N >= 2.
    hair_ids : (n,) int
        Global hair ids; the random numbers of fibre j of hair h come from the streams
        (seed, hair_ids[h] · count + j, purpose), so any chunking gives the same bytes.
    seed : int
    count : int >= 1
        Fibres per strand (Multi_Strand_Count), the same for all hairs.
    splay_root, splay_centre, splay_tip : scalar or (n,) float >= 0
        splay(t) at t = 0, ½, 1 (already global × texture), lengths in local units.
    twist : scalar or (n,) float
        Total angle in radians the fibres turn about the hair from root to tip.
    aspect : scalar or (n,) float >= 0
        Cross-section radius along the binormal B relative to the one along N.
    offset : scalar or (n,) float
        Displacement along the curve normal N at the tip, growing as t³.
    randomize : scalar or (n,) float in [0, 1]
        Randomize_Strand: fibre j is scaled about the root by 1 − randomize · ξ_j.

    Returns
    -------
    fibres : (n·count, N, 3) float64
        Fibre f = h·count + j (strands are contiguous), same local frame as its hair.
    fibre_parent : (n·count,) int64
        Row of ``local`` each fibre came from (``hair_ids[fibre_parent]`` is its id).
    strand_id : (n·count,) int64
        Fibre index within its strand, 0 … count − 1.
    strand_uv : (n·count, 2) float32
        The fibre's place (d cos φ, d sin φ) in the unit disc of the strand
        cross-section at the root, before twist, aspect, splay and randomize
        (u along the curve normal N, v along the binormal B).

    Notes
    -----
    Cross-section frame: the rotation-minimising frame of the hair (Šik 2012 §2.2.8, as
    :func:`follicle.frames.polyline_frames`) with the first normal the root
    tangent (local +x, the paper's choice of N_0), binormal B = T × N in local
    coordinates. The degeneracy threshold is per hair (chunk independent).

    Seed ambiguities and the choices made here:

    * t_i = i / (N − 1): the root is t = 0 and the last vertex t = 1 (the paper's extra
      Catmull-Rom end vertices are not part of our curves).
    * twist_* = twist / (N − 1), not twist / N_vertices: Šik 2012 defines twist as "the
      difference between the angle at the fibre root and at the fibre tip", which
      this makes exact. φ_i follows the paper's recurrence sin φ_i = sin φ_{i−1} cos
      twist_* + cos φ_{i−1} sin twist_*, cos φ_i = cos φ_{i−1} cos twist_* − sin φ_{i−1}
      sin twist_*, with sin/cos of φ_0 from the disc sample (no trig per vertex).
    * Randomize_Strand: Šik 2012 prints scale = (1 − R)·ξ, which would shrink every
      fibre at random even with R = 0; we use 1 − R·ξ (like the paper's Random_Scale,
      §2.2.2), so R = 0 leaves fibres unchanged and R = 1 scales by ξ ∈ [0, 1).
      As in equation 2.5 the whole fibre vertex is scaled about the hair root (the
      local origin): fibres get random lengths, the root offsets shrink with them.
    * d ∈ [0, 1] and φ come from one concentric disc sample per fibre (two numbers
      of the "strand disc" stream); ξ is number 0 of the "strand randomize" stream.
    * Hairs are not re-parametrised for a cut: a caller that cuts before making
      strands must pass the uncut hair or accept t relative to the kept vertices.

    Fibres inherit colour, width and opacity from their hair (Šik 2012 §2.2.7): repeat the
    hair's per-vertex arrays with :func:`inherit` (or ``values.reshape(n, N, ...)
    [fibre_parent]``) and per-hair arrays with ``values[fibre_parent]``. Curve normals
    must be recomputed per fibre after the transform to world space.
    """
    try:
        pts = np.asarray(local, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError("local: expected a float array of shape (n, N, 3)") from exc
    if pts.ndim != 3 or pts.shape[2] != 3:
        raise InputError(f"local: expected shape (n, N, 3), got shape {pts.shape}")
    n, nv = pts.shape[0], pts.shape[1]
    if nv < 2:
        raise InputError(f"local: every hair needs at least 2 vertices, got N = {nv}")
    if not np.all(np.isfinite(pts)):
        raise InputError("local: values must be finite (no NaN or inf)")
    ids = np.asarray(hair_ids)
    if ids.shape != (n,) or (ids.size and not np.issubdtype(ids.dtype, np.integer)):
        raise InputError(
            f"hair_ids: expected {n} integers (one per hair), got shape {ids.shape} "
            f"dtype {ids.dtype}"
        )
    seed = whole(seed, "seed")
    count = whole(count, "count", 1)
    s_root = per_hair(splay_root, n, "splay_root", lo=0.0)
    s_centre = per_hair(splay_centre, n, "splay_centre", lo=0.0)
    s_tip = per_hair(splay_tip, n, "splay_tip", lo=0.0)
    tw = per_hair(twist, n, "twist")
    asp = per_hair(aspect, n, "aspect", lo=0.0)
    off = per_hair(offset, n, "offset")
    rnd = per_hair(randomize, n, "randomize", lo=0.0, hi=1.0)

    fibres = np.empty((n * count, nv, 3), dtype=np.float64)
    uv = np.empty((n * count, 2), dtype=np.float32)
    if n:
        _fibres_kernel(
            np.ascontiguousarray(pts),
            np.ascontiguousarray(ids, dtype=np.int64).view(np.uint64),
            np.uint64(int(seed) & 0xFFFFFFFFFFFFFFFF),
            count,
            s_root,
            s_centre,
            s_tip,
            tw,
            asp,
            off,
            rnd,
            fibres,
            uv,
        )
    parent = np.repeat(np.arange(n, dtype=np.int64), count)
    strand_id = np.tile(np.arange(count, dtype=np.int64), n)
    return fibres, parent, strand_id, uv


def inherit(
    point_data: Mapping[str, object], fibre_parent: object, vertices: int
) -> dict[str, np.ndarray]:
    """Per-vertex arrays of the hairs repeated for their fibres (Šik 2012 §2.2.7).

    Each value has a first axis of n · ``vertices`` (hairs one after another, as in
    ``HairCurves.point_data``); the result has len(fibre_parent) · ``vertices`` rows,
    fibre f taking the rows of hair ``fibre_parent[f]``.
    """
    vertices = whole(vertices, "vertices", 1)
    parent = np.asarray(fibre_parent)
    if parent.ndim != 1 or (parent.size and not np.issubdtype(parent.dtype, np.integer)):
        raise InputError(f"fibre_parent: expected a 1-D integer array, got shape {parent.shape}")
    out: dict[str, np.ndarray] = {}
    for key, value in point_data.items():
        arr = np.asarray(value)
        if arr.ndim < 1 or arr.shape[0] % vertices:
            raise InputError(
                f"point_data[{key!r}]: first axis {arr.shape[:1]} is not a multiple of "
                f"vertices = {vertices}"
            )
        n = arr.shape[0] // vertices
        if parent.size and (parent.min() < 0 or parent.max() >= n):
            raise InputError(f"fibre_parent: indices must lie in [0, {n}) for {key!r}")
        rest = arr.shape[1:]
        out[key] = arr.reshape((n, vertices) + rest)[parent].reshape((-1,) + rest)
    return out
