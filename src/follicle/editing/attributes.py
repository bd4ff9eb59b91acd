"""The guides' own attributes through brush strokes: a colour or width a file gave the
guides (``[groom].inherit`` carries them onto the hairs) stays with them as they are
edited.

The editor holds each guide at V vertices evenly spaced by arc length, so it holds a
point attribute at those vertices too, resampled as the shapes are
(:meth:`~follicle.groom.guides.Guides.point_attribute`). Comb, smooth, puff and part
move vertices and keep every segment's length, so a vertex keeps its value: the colour
at a quarter of the guide's length stays there. Cut and length resample the guide by
arc length (:func:`~follicle.groom.brushes.resized`), and its values with it: a cut
guide keeps the colours of the part left, one grown longer holds its tip's value over
the new part. Delete drops the guides' rows; an added guide takes its neighbours'
values by the weights it takes their shapes (Šik 2012 §2.2.4), the heaviest
neighbour's for integers and booleans, which have no value between two.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..groom.guides import Guides

__all__ = ["Attributes"]

_ROOTS = ("root_triangle", "root_bary")  # the binding, the editor's own state


def _between(values: np.ndarray, row: np.ndarray, share: np.ndarray) -> np.ndarray:
    """Per-vertex ``values`` (S, V, ...) at ``share`` of the way from vertex ``row`` to
    ``row + 1`` (S, V): linear for floating point, the nearer vertex otherwise."""
    g = np.arange(len(values))[:, None]
    if values.dtype.kind != "f":
        return values[g, row + (share > 0.5)]
    a, b = values[g, row], values[g, row + 1]
    f = share.reshape(*share.shape, *(1,) * (values.ndim - 2))
    return (a + f * (b - a)).astype(values.dtype)


def _blend(values: np.ndarray, near: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Rows ``near`` (n, k) of ``values`` blended by ``weight`` (n, k): weighted for
    floating point, the heaviest's otherwise."""
    if values.dtype.kind != "f":
        return values[near[np.arange(len(near)), np.argmax(weight, axis=1)]]
    w = weight.reshape(*weight.shape, *(1,) * (values.ndim - 1))
    return (w * values[near]).sum(axis=1).astype(values.dtype)


@dataclass(frozen=True)
class Attributes:
    """The guides' point attributes (S, V, ...) at the editor's V vertices a guide and
    their curve attributes (S, ...), but the root binding. Never changed in place: each
    stroke that changes them makes new ones, so an undo step keeps its own."""

    point: Mapping[str, np.ndarray]
    curve: Mapping[str, np.ndarray]

    @classmethod
    def of(cls, guides: Guides, vertices: int) -> Attributes:
        """``guides``' attributes, point attributes resampled to ``vertices`` a guide by
        arc length (in their own type: float32 colours stay float32)."""
        data = guides.curves
        point = {
            name: guides.point_attribute(name, vertices).astype(values.dtype)
            for name, values in data.point_data.items()
        }
        curve = {k: v for k, v in data.curve_data.items() if k not in _ROOTS}
        return cls(point, curve)

    def rows(self, keep: np.ndarray) -> Attributes:
        """Those of the guides ``keep`` (indices), in that order."""
        return Attributes(
            {k: v[keep] for k, v in self.point.items()},
            {k: v[keep] for k, v in self.curve.items()},
        )

    def resized(self, which: np.ndarray, row: np.ndarray, share: np.ndarray) -> Attributes:
        """Guides ``which`` resampled as :func:`~follicle.groom.brushes.resized` placed
        their new vertices (``row``, ``share``, one row a guide of ``which``)."""
        if not self.point:
            return self
        point = {}
        for name, values in self.point.items():
            new = values.copy()
            new[which] = _between(values[which], row, share)
            point[name] = new
        return Attributes(point, self.curve)

    def added(
        self, near: np.ndarray, weight: np.ndarray, row: np.ndarray, share: np.ndarray
    ) -> Attributes:
        """These with new guides after them, each the blend of guides ``near`` (n, k) by
        ``weight`` (n, k), its point attributes then resampled as its shape was
        (``row``, ``share`` (n, V): :func:`~follicle.groom.brushes.resized`)."""
        point = {
            k: np.concatenate([v, _between(_blend(v, near, weight), row, share)])
            for k, v in self.point.items()
        }
        curve = {k: np.concatenate([v, _blend(v, near, weight)]) for k, v in self.curve.items()}
        return Attributes(point, curve)

    def data(self) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """``point_data`` (S·V, ...) and ``curve_data`` for a HairCurves of the guides."""
        point = {k: v.reshape(-1, *v.shape[2:]) for k, v in self.point.items()}
        return point, dict(self.curve)
