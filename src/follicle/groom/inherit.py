"""Attributes from the guides (``[groom].inherit``): a hair takes the guides' point and
curve attributes by the weights it takes their shapes, as Blender's "Interpolate Curves"
node carries the guides' attributes onto the curves it makes, so red-to-blue guides grow
red-to-blue hair.

A point attribute is resampled along each guide by arc length, where the shapes are
(:meth:`~follicle.groom.guides.Guides.point_attribute`), so vertex i of a hair of N
vertices (curve parameter t = i / (N − 1)) meets the guides' values at t; they are
blended with the hair's interpolation weights (Šik 2012 §2.2.4). A cut hair's last
vertex, at t_cut (Šik 2012 §2.2.8), takes the blend interpolated linearly between the
vertices around it. A curve attribute is blended once per hair. Integers and booleans
have no value between two: a hair takes its heaviest guide's (a point attribute that
guide's nearest vertex in arc length). Fibres take their hair's values (Šik 2012 §2.2.7);
clumping and every other shaping moves vertices, not attributes.

``color``, ``width`` and ``opacity`` replace the values of root_/tip_color, _width and
_opacity (from a curve attribute too: one value along the hair); an inherited colour
still takes each hair's hue, saturation and value shifts, and mutant hairs keep
``mutant_color`` (Šik 2012 §2.2.6). Any other name is a new ``point_data`` or
``curve_data`` array of the guides' name and shape, float32 for floating-point values
and the guides' type for the rest. Every value is a pure function of the hair's weights,
so any split of the hair ids gives the same bytes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..kernels import kernel, prange
from .appearance import shifted_rgb
from .guides import Guides

__all__ = ["LOOKS", "Inherited", "inherited", "hair_values", "pack_values"]

# the outputs an inherited attribute of this name replaces: its shape per vertex
LOOKS: dict[str, tuple[int, ...]] = {"color": (3,), "width": (), "opacity": ()}
# what the groom makes itself of the hair's shape and roots
_OWN = frozenset(
    {"points", "normal", "hair_id", "strand_id", "root_uv", "strand_uv"}
    | {"root_triangle", "root_bary"}
)


@dataclass(frozen=True)
class Inherited:
    """One attribute a groom's hairs inherit: on the guides' points or curves, blended
    (floating point and the looks) or the heaviest guide's, and its shape and type in
    the output (per vertex for a point attribute or a look, else per curve)."""

    name: str
    on_points: bool
    blend: bool
    shape: tuple[int, ...]
    dtype: np.dtype

    @property
    def per_vertex(self) -> bool:
        return self.on_points or self.name in LOOKS

    def field(self) -> tuple[np.dtype, tuple[int, ...]]:
        """(dtype, shape per row) of its output array."""
        return self.dtype, self.shape


def _have(guides: Guides) -> str:
    data = guides.curves
    points = sorted(data.point_data) or "none"
    curves = sorted(set(data.curve_data) - _OWN) or "none"
    return f"the guides have point attributes {points} and curve attributes {curves}"


def inherited(guides: Guides, names: Sequence[str]) -> tuple[Inherited, ...]:
    """``[groom].inherit`` checked against ``guides``: what each named attribute is.

    InputError naming the key, the attribute and what the guides have, for a name they
    lack, one the groom makes itself (``normal``, ``hair_id`` …), a value that is not a
    number, or a look of the wrong shape (``color`` 3 numbers, ``width`` and
    ``opacity`` one). A name on both points and curves is the point attribute.
    """
    out = []
    for name in names:
        if name in _OWN:
            raise InputError(
                f"[groom].inherit: {name!r} is made by the groom from the hair's shape and"
                f" roots, not inherited; {_have(guides)}"
            )
        on_points = name in guides.curves.point_data
        if not on_points and name not in guides.curves.curve_data:
            raise InputError(
                f"[groom].inherit: the guides have no attribute {name!r}; {_have(guides)}"
                " (built-in guides have none: load guides from a file that carries them)"
            )
        data = guides.curves.point_data if on_points else guides.curves.curve_data
        values = data[name]
        if values.dtype.kind not in "biuf":
            raise InputError(
                f"[groom].inherit: the guides' {name!r} holds {values.dtype} values, not"
                " numbers; only numbers and booleans blend"
            )
        shape = values.shape[1:]
        if name in LOOKS:
            want = LOOKS[name]
            if shape != want and not (want == () and shape == (1,)):
                raise InputError(
                    f"[groom].inherit: the guides' {name!r} has {shape or 'one'} value(s)"
                    f" per {'vertex' if on_points else 'curve'}, expected"
                    f" {want[0] if want else 'one'} ({name} replaces the groom's own)"
                )
            shape = want
        blend = name in LOOKS or values.dtype.kind == "f"
        dtype = np.dtype(np.float32) if blend else values.dtype
        out.append(Inherited(name, on_points, blend, shape, dtype))
    return tuple(out)


@kernel(parallel=True, nogil=True)
def _blend_kernel(table, idx, w, out):
    """out[h, i] = Σ_j w[h, j] · table[idx[h, j], i] for every component."""
    for h in prange(idx.shape[0]):
        for i in range(out.shape[1]):
            for c in range(out.shape[2]):
                x = 0.0
                for j in range(idx.shape[1]):
                    x += w[h, j] * table[idx[h, j], i, c]
                out[h, i, c] = x


def _guide_table(guides: Guides, item: Inherited, n_total: int) -> np.ndarray:
    """The guides' values (S, V, K): a point attribute at ``n_total`` vertices, a curve
    attribute as one vertex."""
    if item.on_points:
        values = guides.point_attribute(item.name, n_total)
    else:
        values = guides.curves.curve_data[item.name][:, None]
    return values.reshape(values.shape[0], values.shape[1], -1)


def hair_values(
    items: Sequence[Inherited],
    guides: Guides,
    index: np.ndarray,
    weight: np.ndarray,
    n_total: int,
    n: int,
) -> dict[str, np.ndarray]:
    """Each inherited attribute of hairs with guides ``index`` and weights ``weight``
    (m, k): (m, V, K) over the first ``n`` of ``n_total`` vertices (V = n for a point
    attribute, 1 for a curve attribute), float64 blended, else the heaviest guide's."""
    out = {}
    heaviest = None
    for item in items:
        table = _guide_table(guides, item, n_total)[:, :n]
        if item.blend:
            values = np.empty((len(index), table.shape[1], table.shape[2]), np.float64)
            _blend_kernel(
                np.ascontiguousarray(table, np.float64),
                np.ascontiguousarray(index, np.int64),
                np.ascontiguousarray(weight, np.float32),
                values,
            )
        else:
            if heaviest is None:
                heaviest = index[np.arange(len(index)), np.argmax(weight, axis=1)]
            values = table[heaviest]
        out[item.name] = values
    return out


@kernel(inline="always")
def _where(i, last_i, cut, t_end, n_total, last):
    """Row j of a hair's table and the share u of row j + 1 at its vertex i (the cut
    last vertex ``last_i`` lies at ``t_end``, between two rows)."""
    if cut and i == last_i:
        x = t_end * (n_total - 1)
        j = int(np.floor(x))
        if j >= last:
            return last, 0.0
        return j, x - j
    return min(i, last), 0.0


@kernel(inline="always")
def _at(table, h, j, u, c):
    a = table[h, j, c]
    if u == 0.0:
        return a
    return a + u * (table[h, j + 1, c] - a)


@kernel(parallel=True, nogil=True)
def _pack_blend_kernel(table, length, keep, start, t_end, n_total, shifts, out):
    last = table.shape[1] - 1
    for h in prange(table.shape[0]):
        if not keep[h, 0] or (shifts.shape[0] > 0 and shifts[h, 0] != 0.0):
            continue  # dropped, or a mutant hair: it keeps mutant_color
        L = length[h]
        cut = t_end[h] != (L - 1) / (n_total - 1)
        k = start[h]
        for i in range(L):
            if not keep[h, i]:
                continue
            j, u = _where(i, L - 1, cut, t_end[h], n_total, last)
            if shifts.shape[0] > 0:
                r, g, b = shifted_rgb(
                    _at(table, h, j, u, 0),
                    _at(table, h, j, u, 1),
                    _at(table, h, j, u, 2),
                    shifts[h],
                )
                out[k, 0], out[k, 1], out[k, 2] = r, g, b
            else:
                for c in range(table.shape[2]):
                    out[k, c] = _at(table, h, j, u, c)
            k += 1


@kernel(parallel=True, nogil=True)
def _pack_pick_kernel(table, length, keep, start, t_end, n_total, out):
    last = table.shape[1] - 1
    for h in prange(table.shape[0]):
        if not keep[h, 0]:
            continue
        L = length[h]
        cut = t_end[h] != (L - 1) / (n_total - 1)
        k = start[h]
        for i in range(L):
            if not keep[h, i]:
                continue
            j, u = _where(i, L - 1, cut, t_end[h], n_total, last)
            if u > 0.5:  # the nearer row; a tie to the root side
                j += 1
            for c in range(table.shape[2]):
                out[k, c] = table[h, j, c]
            k += 1


def pack_values(
    items: Sequence[Inherited],
    values: dict[str, np.ndarray],
    length: np.ndarray,
    keep: np.ndarray,
    start: np.ndarray,
    t_end: np.ndarray,
    n_total: int,
    shifts: np.ndarray | None,
    out: dict[str, np.ndarray],
) -> None:
    """Write the per-vertex inherited ``values`` (:func:`hair_values`, one row per curve)
    of the kept vertices into ``out`` from vertex ``start[h]`` on, as
    :func:`~follicle.groom.finalize.pack` writes the points; ``shifts``
    (:func:`~follicle.groom.appearance.hair_shifts`, per curve) move an inherited
    colour and leave mutant hairs' alone."""
    for item in items:
        if not item.per_vertex:
            continue
        table = values[item.name]
        target = out[item.name].reshape(len(out[item.name]), -1)  # a view: out is contiguous
        if item.blend:
            colour = shifts if item.name == "color" and shifts is not None else np.zeros((0, 4))
            _pack_blend_kernel(table, length, keep, start, t_end, int(n_total), colour, target)
        else:
            _pack_pick_kernel(table, length, keep, start, t_end, int(n_total), target)
