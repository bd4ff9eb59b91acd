"""Per-vertex width, opacity and colour: root and tip values interpolated (Šik 2012 §2.2.6, §2.2.9).

Each hair gets a colour at its root and tip (or one mutant colour), shifted in hue,
saturation and value by per-hair random amounts, and interpolated to its vertices in
HSV along the shortest hue route; width and opacity are linear in the curve parameter.
Every random choice is a pure function of (seed, hair id, purpose), so any split of the
hair ids into chunks gives the same bytes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TypedDict

import numpy as np

from ..color import hsv_to_rgb1, hue_distance1, rgb_to_hsv1
from ..errors import InputError
from ..kernels import kernel, prange
from ..rng import purpose_id, stream_key, uniform
from ..validate import whole
from .params import curve_parameter, per_hair, row

if TYPE_CHECKING:
    from typing_extensions import Unpack

__all__ = ["ENDS", "hair_ends", "hair_shifts", "shifted_rgb", "vertex_look", "hair_appearance"]

_MUTANT = purpose_id("mutant hair")  # one number per hair: mutant when ξ < fraction
_VARIATION = purpose_id("color variation")  # numbers 0, 1, 2: hue, saturation, value


# --------------------------------------------------------------------------- kernel
@kernel(nogil=True)
def _clamp01(x):
    return min(max(x, 0.0), 1.0)


@kernel(nogil=True)
def _shifted_hsv(r, g, b, dh, ds, dv):
    """Šik 2012 §2.2.6: RGB to HSV minus the shifts; s, v clamped to [0, 1] (hue wraps later)."""
    h, s, v = rgb_to_hsv1(r, g, b)
    return h - dh, _clamp01(s - ds), _clamp01(v - dv)


@kernel(inline="always")
def _hair_shifts(ids, seed, hue_var, sat_var, val_var, mutant_fraction, i):
    """Whether hair ``i`` is a mutant, and its hue, saturation and value shifts."""
    hair = ids[i]
    fraction = mutant_fraction[row(mutant_fraction, i)]
    mutant = uniform(stream_key(seed, hair, _MUTANT), 0) < fraction
    key = stream_key(seed, hair, _VARIATION)
    dh = hue_var[row(hue_var, i)] * 2.0 * (uniform(key, 0) - 0.5)
    ds = sat_var[row(sat_var, i)] * 2.0 * (uniform(key, 1) - 0.5)
    dv = val_var[row(val_var, i)] * 2.0 * (uniform(key, 2) - 0.5)
    return mutant, dh, ds, dv


@kernel(parallel=True, nogil=True)
def _shifts_kernel(ids, seed, hue_var, sat_var, val_var, mutant_fraction, out):
    for i in prange(ids.shape[0]):
        mutant, dh, ds, dv = _hair_shifts(ids, seed, hue_var, sat_var, val_var, mutant_fraction, i)
        out[i, 0] = 1.0 if mutant else 0.0
        out[i, 1], out[i, 2], out[i, 3] = dh, ds, dv


@kernel(inline="always")
def shifted_rgb(r, g, b, shift):
    """An RGB colour moved by a hair's :func:`hair_shifts` row ``shift`` as its root and
    tip colours are (Šik 2012 §2.2.6); unchanged, with no trip through HSV, when the
    shifts are 0."""
    if shift[1] == 0.0 and shift[2] == 0.0 and shift[3] == 0.0:
        return r, g, b
    h, s, v = _shifted_hsv(r, g, b, shift[1], shift[2], shift[3])
    return hsv_to_rgb1(h, s, v)


# per hair: root h, s, v, signed hue distance to the tip, tip s, v; width and opacity
# at root and tip: everything a vertex's look needs besides its curve parameter
ENDS = 10


@kernel(parallel=True, nogil=True)
def _ends_kernel(
    ids,
    seed,
    root_rgb,
    tip_rgb,
    hue_var,
    sat_var,
    val_var,
    mutant_fraction,
    mutant_rgb,
    root_w,
    tip_w,
    root_op,
    tip_op,
    ends,
):
    """Fill ``ends`` (n, ENDS) for hairs ``ids``; inputs have n rows or one shared row."""
    for i in prange(ids.shape[0]):
        mutant, dh, ds, dv = _hair_shifts(ids, seed, hue_var, sat_var, val_var, mutant_fraction, i)
        if mutant:  # one colour for the whole hair
            m = mutant_rgb[row(mutant_rgb, i)]
            h1, s1, v1 = _shifted_hsv(m[0], m[1], m[2], dh, ds, dv)
            h2, s2, v2 = h1, s1, v1
        else:
            ra = root_rgb[row(root_rgb, i)]
            ta = tip_rgb[row(tip_rgb, i)]
            h1, s1, v1 = _shifted_hsv(ra[0], ra[1], ra[2], dh, ds, dv)
            h2, s2, v2 = _shifted_hsv(ta[0], ta[1], ta[2], dh, ds, dv)
        e = ends[i]
        e[0], e[1], e[2] = h1, s1, v1
        e[3] = hue_distance1(h1, h2)  # shortest signed route, from wrapped hues
        e[4], e[5] = s2, v2
        e[6], e[7] = root_w[row(root_w, i)], tip_w[row(tip_w, i)]
        e[8], e[9] = root_op[row(root_op, i)], tip_op[row(tip_op, i)]


@kernel(inline="always")
def vertex_look(e, t):
    """(r, g, b, width, opacity) at curve parameter ``t`` of a hair with ends ``e``.

    Šik 2012 §2.2.9: value = t·tip + (1 − t)·root; hue = hue1 + t·hue_dist, wrapped.
    """
    u = 1.0 - t
    r, g, b = hsv_to_rgb1(e[0] + t * e[3], u * e[1] + t * e[4], u * e[2] + t * e[5])
    return r, g, b, u * e[6] + t * e[7], u * e[8] + t * e[9]


@kernel(parallel=True, nogil=True)
def _look_kernel(ends, t, color, width, opacity):
    nv = t.shape[1]
    for i in prange(ends.shape[0]):
        tr = row(t, i)
        for j in range(nv):
            k = i * nv + j
            color[k, 0], color[k, 1], color[k, 2], width[k], opacity[k] = vertex_look(
                ends[i], t[tr, j]
            )


# --------------------------------------------------------------------- validation
def _hair_ids(hair_ids: object) -> np.ndarray:
    arr = np.asarray(hair_ids)
    if arr.ndim != 1 or (arr.size and not np.issubdtype(arr.dtype, np.integer)):
        raise InputError(
            f"hair_ids: expected a 1-D array of integers, got shape {arr.shape} {arr.dtype}"
        )
    if np.any(arr < 0):
        raise InputError("hair_ids: ids must be non-negative")
    return np.ascontiguousarray(arr, dtype=np.int64)


# ------------------------------------------------------------------------- public
def hair_ends(
    hair_ids: object,
    seed: int,
    root_color: object,
    tip_color: object,
    hue_var: float | np.ndarray,
    sat_var: float | np.ndarray,
    val_var: float | np.ndarray,
    mutant_fraction: float | np.ndarray,
    mutant_color: object,
    root_width: float | np.ndarray,
    tip_width: float | np.ndarray,
    root_opacity: float | np.ndarray,
    tip_opacity: float | np.ndarray,
) -> np.ndarray:
    """Each hair's colour, width and opacity at root and tip: float64 (n, ENDS).

    Šik 2012 §2.2.6. Per-hair inputs are the property values already evaluated at each root
    (a scalar or (3,) colour is shared by all n hairs):

    - ``root_color``, ``tip_color``, ``mutant_color``: linear RGB ≥ 0, (n, 3) or (3,),
      global value and texture already mixed by the caller. Šik 2012 mixes them by
      component-wise addition (``Root_Color_G + Root_Color_T(u, v)``, likewise tip and
      mutant); follicle's PropertyMap multiplies (``value × texture(uv)``); either result
      is valid input. An HSV value above 1 is clamped to 1 (hue and saturation kept),
      as Šik 2012 keeps s and v in [0, 1].
    - ``hue_var`` degrees in [0, 180], ``sat_var`` and ``val_var`` in [0, 1]: G × T(u, v).
      Each hair draws shifts uniform in ±var (streams of (seed, id, "color variation"))
      and subtracts the same shifts from its root and tip colours (mutants too); hue
      wraps around 360°, s and v are clamped to [0, 1].
    - ``mutant_fraction`` in [0, 1]: Percent_Mutant_Hair_G · _T(u, v) / 100. A hair is a
      mutant when ξ < fraction, ξ from (seed, id, "mutant hair"); a mutant is
      ``mutant_color`` (shifted) from root to tip.
    - ``root_width``, ``tip_width``: diameters in metres, > 0; ``root_opacity``,
      ``tip_opacity`` in [0, 1]. Linear in t.

    :func:`vertex_look` reads a vertex's values off a row.
    """
    ids = _hair_ids(hair_ids)
    n = ids.shape[0]
    seed = whole(seed, "seed", 0, 2**64 - 1)
    inputs = (
        per_hair(root_color, n, "root_color", 0.0, vector=True),
        per_hair(tip_color, n, "tip_color", 0.0, vector=True),
        per_hair(hue_var, n, "hue_var", 0.0, 180.0),
        per_hair(sat_var, n, "sat_var", 0.0, 1.0),
        per_hair(val_var, n, "val_var", 0.0, 1.0),
        per_hair(mutant_fraction, n, "mutant_fraction", 0.0, 1.0),
        per_hair(mutant_color, n, "mutant_color", 0.0, vector=True),
        per_hair(root_width, n, "root_width", 0.0, lo_open=True),
        per_hair(tip_width, n, "tip_width", 0.0, lo_open=True),
        per_hair(root_opacity, n, "root_opacity", 0.0, 1.0),
        per_hair(tip_opacity, n, "tip_opacity", 0.0, 1.0),
    )
    ends = np.empty((n, ENDS), dtype=np.float64)
    _ends_kernel(ids, np.uint64(seed), *inputs, ends)
    return ends


def hair_shifts(
    hair_ids: object,
    seed: int,
    hue_var: float | np.ndarray,
    sat_var: float | np.ndarray,
    val_var: float | np.ndarray,
    mutant_fraction: float | np.ndarray,
) -> np.ndarray:
    """Each hair's mutant flag (1 or 0) and hue, saturation and value shifts, float64
    (n, 4): the random choices :func:`hair_ends` makes, from the same streams, for a
    colour that does not come from root and tip colours (one inherited from the guides,
    ``[groom].inherit``)."""
    ids = _hair_ids(hair_ids)
    n = ids.shape[0]
    seed = whole(seed, "seed", 0, 2**64 - 1)
    out = np.empty((n, 4), dtype=np.float64)
    _shifts_kernel(
        ids,
        np.uint64(seed),
        per_hair(hue_var, n, "hue_var", 0.0, 180.0),
        per_hair(sat_var, n, "sat_var", 0.0, 1.0),
        per_hair(val_var, n, "val_var", 0.0, 1.0),
        per_hair(mutant_fraction, n, "mutant_fraction", 0.0, 1.0),
        out,
    )
    return out


class EndsProperties(TypedDict):
    """The keyword arguments of :func:`hair_ends` after its first two, which
    :func:`hair_appearance` passes on."""

    root_color: object
    tip_color: object
    hue_var: float | np.ndarray
    sat_var: float | np.ndarray
    val_var: float | np.ndarray
    mutant_fraction: float | np.ndarray
    mutant_color: object
    root_width: float | np.ndarray
    tip_width: float | np.ndarray
    root_opacity: float | np.ndarray
    tip_opacity: float | np.ndarray


def hair_appearance(
    hair_ids: object,
    seed: int,
    vertices: int,
    t: np.ndarray | None = None,
    **properties: Unpack[EndsProperties],
) -> dict[str, np.ndarray]:
    """Point data ``color`` (n·N, 3), ``width``, ``opacity`` (n·N,) float32, in hair order.

    ``properties`` are the keyword arguments of :func:`hair_ends`; each hair's values are
    interpolated to its N vertices (Šik 2012 §2.2.9), the colour in HSV with the hue along
    the shortest route. ``t`` is the curve parameter of each vertex, (N,) for all hairs
    or (n, N) per hair (a cut hair keeps the parameters of its uncut curve, Šik 2012
    §2.2.8); None means i / (N − 1).
    """
    vertices = whole(vertices, "vertices", 2)
    ends = hair_ends(hair_ids, seed, **properties)
    tt = curve_parameter(t, len(ends), int(vertices))
    total = len(ends) * int(vertices)
    color = np.empty((total, 3), dtype=np.float32)
    width = np.empty(total, dtype=np.float32)
    opacity = np.empty(total, dtype=np.float32)
    _look_kernel(ends, tt, color, width, opacity)
    return {"color": color, "width": width, "opacity": opacity}
