"""HairCurves: the one container of hair curves that every stage passes on.

Curve ``i`` is ``points[offsets[i]:offsets[i + 1]]``; its vertices are Catmull-Rom
control points the curve passes through (root first). Per-vertex attributes live in
``point_data`` (``width`` (P,), ``color`` (P, 3) linear RGB, ``opacity`` (P,),
``normal`` (P, 3)), per-curve ones in ``curve_data`` (``root_uv`` (C, 2), ``hair_id``
(C,), ``strand_id``, ``group`` ...). Widths are diameters, units metres, +Y up.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from .arrays import all_finite, as_array, point_bounds
from .errors import InputError

__all__ = ["HairCurves"]


def _as_points(points: object, name: str = "points") -> np.ndarray:
    arr = as_array(points, name, np.float32)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InputError(f"{name}: expected an array of shape (P, 3), got shape {arr.shape}")
    return np.ascontiguousarray(arr)


def _data(data: Mapping[str, object] | None, name: str) -> dict[str, np.ndarray]:
    """Attribute arrays by name, each made an array (InputError naming it otherwise)."""
    if data is None:
        return {}
    if not isinstance(data, Mapping):
        raise InputError(
            f"{name}: expected a mapping of names to arrays, got {type(data).__name__}"
        )
    return {k: as_array(v, f"{name}[{k!r}]", numbers=False) for k, v in data.items()}


class HairCurves:
    """Hair curves as flat vertex arrays with per-vertex and per-curve attributes.

    A thin holder of arrays, validated on construction: offsets start at 0, rise by at
    least 2 (every curve has two or more vertices) and end at ``len(points)``; points
    and floating-point attributes are finite; attribute lengths match P or C.
    """

    __slots__ = ("points", "offsets", "point_data", "curve_data")

    def __init__(
        self,
        points: object,
        offsets: object,
        point_data: Mapping[str, object] | None = None,
        curve_data: Mapping[str, object] | None = None,
    ) -> None:
        self.points = _as_points(points)
        offs = as_array(offsets, "offsets")
        if offs.ndim != 1 or offs.size < 1:
            raise InputError(
                f"offsets: expected a 1-D array of C + 1 entries, got shape {offs.shape}"
            )
        if offs.size and not np.issubdtype(offs.dtype, np.integer):
            if not np.all(np.equal(np.mod(offs, 1), 0)):
                raise InputError("offsets: entries must be whole numbers")
        self.offsets = np.ascontiguousarray(offs, dtype=np.int64)
        self.point_data = _data(point_data, "point_data")
        self.curve_data = _data(curve_data, "curve_data")
        self._validate()

    # ---------------------------------------------------------------- construction
    @classmethod
    def from_polylines(
        cls,
        polylines: Iterable[object],
        point_data: Mapping[str, object] | None = None,
        curve_data: Mapping[str, object] | None = None,
    ) -> HairCurves:
        """Build from a sequence of (n_i, 3) vertex arrays, one per curve."""
        try:
            each = iter(polylines)
        except TypeError:
            raise InputError(
                f"polylines: expected a sequence of (n, 3) arrays, got {type(polylines).__name__}"
            ) from None
        arrays = [_as_points(p, f"polylines[{i}]") for i, p in enumerate(each)]
        counts = np.array([len(a) for a in arrays], dtype=np.int64)
        offsets = np.zeros(len(arrays) + 1, dtype=np.int64)
        np.cumsum(counts, out=offsets[1:])
        points = np.concatenate(arrays) if arrays else np.zeros((0, 3), np.float32)
        return cls(points, offsets, point_data, curve_data)

    @classmethod
    def from_array(
        cls,
        array: object,
        point_data: Mapping[str, object] | None = None,
        curve_data: Mapping[str, object] | None = None,
    ) -> HairCurves:
        """Build from an (S, N, 3) array of S curves with N vertices each."""
        arr = as_array(array, "array", np.float32)
        if arr.ndim != 3 or arr.shape[2] != 3:
            raise InputError(f"array: expected shape (S, N, 3), got {arr.shape}")
        s, n, _ = arr.shape
        offsets = np.arange(s + 1, dtype=np.int64) * n
        return cls(arr.reshape(s * n, 3), offsets, point_data, curve_data)

    @classmethod
    def concatenate(cls, parts: Sequence[HairCurves]) -> HairCurves:
        """Join several HairCurves; every part must carry the same attribute names."""
        if not parts:
            raise InputError("concatenate: need at least one HairCurves")
        pkeys, ckeys = set(parts[0].point_data), set(parts[0].curve_data)
        for i, part in enumerate(parts):
            if set(part.point_data) != pkeys or set(part.curve_data) != ckeys:
                raise InputError(
                    f"concatenate: part {i} has attributes {sorted(part.point_data)}"
                    f" / {sorted(part.curve_data)}, expected {sorted(pkeys)} / {sorted(ckeys)}"
                )
        shifts = np.cumsum([0] + [len(p.points) for p in parts[:-1]])
        offsets = np.concatenate(
            [parts[0].offsets[:1]] + [p.offsets[1:] + s for p, s in zip(parts, shifts, strict=True)]
        )
        return cls(
            np.concatenate([p.points for p in parts]),
            offsets,
            {k: np.concatenate([p.point_data[k] for p in parts]) for k in pkeys},
            {k: np.concatenate([p.curve_data[k] for p in parts]) for k in ckeys},
        )

    # ---------------------------------------------------------------- validation
    def _validate(self) -> None:
        offs, n_points = self.offsets, len(self.points)
        if offs[0] != 0 or offs[-1] != n_points:
            raise InputError(
                f"offsets: must start at 0 and end at the point count {n_points},"
                f" got {offs[0]} … {offs[-1]}"
            )
        steps = np.diff(offs)
        if steps.size and steps.min() < 2:
            bad = int(np.argmax(steps < 2))
            raise InputError(
                f"offsets: curve {bad} has {int(steps[bad])} vertices; every curve needs at least 2"
                " (offsets must rise by 2 or more)"
            )
        if not all_finite(self.points):
            bad = int(np.argmax(~np.isfinite(self.points).all(axis=1)))
            raise InputError(f"points: vertex {bad} is not finite (NaN or inf)")
        for kind, data, size in (
            ("point_data", self.point_data, n_points),
            ("curve_data", self.curve_data, self.curve_count),
        ):
            for key, arr in data.items():
                if arr.ndim == 0 or arr.shape[0] != size:
                    raise InputError(
                        f"{kind}['{key}']: expected {size} rows, got shape {arr.shape}"
                    )
                if np.issubdtype(arr.dtype, np.floating) and not all_finite(arr):
                    raise InputError(f"{kind}['{key}']: contains NaN or inf")

    # ---------------------------------------------------------------- views
    @property
    def curve_count(self) -> int:
        return len(self.offsets) - 1

    @property
    def point_count(self) -> int:
        return len(self.points)

    @property
    def counts(self) -> np.ndarray:
        """Vertex count of every curve, int64 (C,)."""
        return np.diff(self.offsets)

    def __len__(self) -> int:
        return self.curve_count

    def curve(self, i: int) -> np.ndarray:
        """The (n, 3) vertices of curve ``i`` (a view)."""
        return self.points[self.offsets[i] : self.offsets[i + 1]]

    def curve_index(self) -> np.ndarray:
        """For every vertex, the index of its curve, int64 (P,)."""
        return np.repeat(np.arange(self.curve_count, dtype=np.int64), self.counts)

    def uniform_count(self) -> int | None:
        """The shared vertex count if every curve has the same, else None."""
        counts = self.counts
        return int(counts[0]) if counts.size and np.all(counts == counts[0]) else None

    def as_array(self) -> np.ndarray:
        """(S, N, 3) view of curves that all have N vertices."""
        n = self.uniform_count()
        if n is None:
            raise InputError("as_array: curves have different vertex counts; resample them first")
        return self.points.reshape(self.curve_count, n, 3)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds of the vertices, ((3,), (3,)) float64.

        For the exact bounds of the smooth Catmull-Rom curves use
        :func:`follicle.spline.bounds`.
        """
        if not self.point_count:
            raise InputError("bounds: the curves are empty")
        return point_bounds(self.points)  # float32 extremes are exact in float64

    def __getitem__(self, key: int | slice | Sequence[int] | np.ndarray) -> HairCurves:
        """Select curves by index, slice, index array or boolean mask."""
        if isinstance(key, (int, np.integer)):
            i = int(key) + (self.curve_count if key < 0 else 0)
            if not 0 <= i < self.curve_count:
                raise IndexError(f"curve index {key} out of range for {self.curve_count} curves")
            idx = np.array([i])
        elif isinstance(key, slice):
            idx = np.arange(self.curve_count)[key]
        else:
            idx = np.asarray(key)
            if idx.dtype == bool:
                if idx.shape != (self.curve_count,):
                    raise InputError(f"mask: expected {self.curve_count} entries, got {idx.shape}")
                idx = np.flatnonzero(idx)
            idx = idx.astype(np.int64)
        counts = self.counts[idx]
        offsets = np.zeros(len(idx) + 1, dtype=np.int64)
        np.cumsum(counts, out=offsets[1:])
        vert = _gather_vertices(self.offsets, idx, counts, int(offsets[-1]))
        return HairCurves(
            self.points[vert],
            offsets,
            {k: v[vert] for k, v in self.point_data.items()},
            {k: v[idx] for k, v in self.curve_data.items()},
        )

    def copy(self) -> HairCurves:
        return HairCurves(
            self.points.copy(),
            self.offsets.copy(),
            {k: v.copy() for k, v in self.point_data.items()},
            {k: v.copy() for k, v in self.curve_data.items()},
        )

    def replaced(self, index: object, other: HairCurves) -> HairCurves:
        """A copy with the curves at ``index`` (distinct, ascending) written over by the
        curves of ``other``, in order, which have the same vertex counts and attribute
        names (a few curves grown again, without joining every array anew)."""
        idx = np.asarray(index, dtype=np.int64)
        if idx.shape != (other.curve_count,):
            raise InputError(f"index: expected {other.curve_count} curve indices, got {idx.shape}")
        if len(idx) and (idx[0] < 0 or idx[-1] >= self.curve_count or np.any(np.diff(idx) <= 0)):
            raise InputError(
                f"index: expected ascending distinct indices in [0, {self.curve_count})"
            )
        if not np.array_equal(self.counts[idx], other.counts):
            raise InputError("other: its curves' vertex counts differ from those they replace")
        if set(other.point_data) != set(self.point_data) or set(other.curve_data) != set(
            self.curve_data
        ):
            raise InputError("other: the curves must carry the same attribute names")
        vert = _gather_vertices(self.offsets, idx, other.counts, other.point_count)
        out = self.copy()
        out.points[vert] = other.points
        for k, v in out.point_data.items():
            v[vert] = other.point_data[k]
        for k, v in out.curve_data.items():
            v[idx] = other.curve_data[k]
        return out

    def with_points(self, points: object) -> HairCurves:
        """The same curves and attributes with new vertex positions (same P)."""
        return HairCurves(points, self.offsets, self.point_data, self.curve_data)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, HairCurves):
            return NotImplemented
        return (
            np.array_equal(self.points, other.points)
            and np.array_equal(self.offsets, other.offsets)
            and _dicts_equal(self.point_data, other.point_data)
            and _dicts_equal(self.curve_data, other.curve_data)
        )

    __hash__ = None  # type: ignore[assignment]  # mutable arrays: unhashable

    def __repr__(self) -> str:
        counts = self.counts
        if counts.size:
            lo, hi = int(counts.min()), int(counts.max())
            verts = f"{lo}" if lo == hi else f"{lo}–{hi}"
            b0, b1 = self.bounds()
            box = f", bounds=[{b0.round(3).tolist()} … {b1.round(3).tolist()}]"
        else:
            verts, box = "0", ""
        attrs = ", ".join(
            [f"{k}{list(v.shape[1:]) or ''}" for k, v in self.point_data.items()]
            + [f"{k}{list(v.shape[1:]) or ''}*" for k, v in self.curve_data.items()]
        )
        return (
            f"HairCurves({self.curve_count} curves, {self.point_count} points,"
            f" {verts} vertices/curve{box}{', attrs: ' + attrs if attrs else ''})"
        )


def _gather_vertices(
    offsets: np.ndarray, idx: np.ndarray, counts: np.ndarray, total: int
) -> np.ndarray:
    """Vertex indices of curves ``idx`` in order (vectorised ranges)."""
    starts = offsets[idx]
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    new_starts = np.zeros(len(idx), dtype=np.int64)
    np.cumsum(counts[:-1], out=new_starts[1:])
    return np.repeat(starts - new_starts, counts) + np.arange(total, dtype=np.int64)


def _dicts_equal(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray]) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
