"""Strand data for the GPU: lines-adjacency segment indices, draw order, curve parameter,
strand seeds, vertex tangents."""

from __future__ import annotations

import numpy as np

from .camera import Camera

__all__ = [
    "segment_indices",
    "back_to_front",
    "curve_param",
    "strand_seeds",
    "vertex_tangents",
    "StrandTables",
]


def segment_indices(offsets: np.ndarray) -> np.ndarray:
    """Lines-adjacency indices (S, 4) uint32 for every segment of every curve.

    Segment i of a curve with vertices P_0 … P_{n-1} gets (P_{i-1}, P_i, P_{i+1},
    P_{i+2}) with the indices clamped to the curve, i.e. its end points duplicated
    as phantom neighbours (Šik 2012 §2.2.1, Fig. 2.8). Vectorised: no loop over curves.
    """
    offsets = np.asarray(offsets, dtype=np.int64)
    counts = np.diff(offsets)
    nseg = counts - 1
    total = int(nseg.sum())
    if total == 0:
        return np.zeros((0, 4), dtype=np.uint32)
    seg_starts = np.zeros(len(nseg), dtype=np.int64)
    np.cumsum(nseg[:-1], out=seg_starts[1:])
    first = np.repeat(offsets[:-1], nseg)  # first vertex of each segment's curve
    last = np.repeat(offsets[1:] - 1, nseg)  # last vertex of each segment's curve
    local = np.arange(total, dtype=np.int64) - np.repeat(seg_starts, nseg)
    idx = (first + local)[:, None] + np.arange(-1, 3, dtype=np.int64)[None, :]
    np.clip(idx, first[:, None], last[:, None], out=idx)
    return idx.astype(np.uint32)


def back_to_front(segments: np.ndarray, points: np.ndarray, camera: Camera) -> np.ndarray:
    """Segments ordered farthest first by the view depth of their middle.

    For ``oit=False``: hair blended "over" without writing depth must be drawn back to
    front to keep the nearer strands on top.
    """
    middle = 0.5 * (points[segments[:, 1]] + points[segments[:, 2]])
    depth = middle.astype(np.float64) @ (camera.basis()[2])
    return segments[np.argsort(-depth, kind="stable")]


def curve_param(offsets: np.ndarray, n_points: int) -> np.ndarray:
    """Per vertex, its index along the curve / (n - 1): 0 at the root, 1 at the tip."""
    counts = np.diff(offsets)
    starts = np.repeat(offsets[:-1], counts)
    denom = np.repeat(np.maximum(counts - 1, 1), counts)
    return ((np.arange(n_points, dtype=np.int64) - starts) / denom).astype(np.float32)


def strand_seeds(offsets: np.ndarray) -> np.ndarray:
    """Per vertex, a number in [0, 1) fixed per curve (the golden-ratio sequence over the
    curve index): neighbouring strands get well-spread noise in the shaders."""
    counts: np.ndarray = np.diff(np.asarray(offsets, dtype=np.int64))
    seeds = np.modf(np.arange(len(counts), dtype=np.float64) * 0.6180339887498949)[0]
    return np.repeat(seeds.astype(np.float32), counts)


def vertex_tangents(points: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Per vertex (N, 3) float32, the tangent the geometry shader gives a Catmull-Rom step
    there: (P_{i+1} − P_{i−1}) / 2, a curve's end points their own neighbours; where
    that vanishes (a hairpin), the difference to the next vertex (the previous at a tip)."""
    p = np.asarray(points, dtype=np.float32)
    offsets = np.asarray(offsets, dtype=np.int64)
    out = np.empty_like(p)
    out[1:-1] = 0.5 * (p[2:] - p[:-2])
    first, last = offsets[:-1], offsets[1:] - 1
    keep = first <= last  # curves with vertices
    first, last = first[keep], last[keep]
    out[first] = 0.5 * (p[np.minimum(first + 1, last)] - p[first])
    out[last] = 0.5 * (p[last] - p[np.maximum(last - 1, first)])
    flat = np.flatnonzero(np.einsum("ij,ij->i", out, out) < 1e-24)
    if len(flat):
        curve = np.searchsorted(offsets, flat, side="right") - 1
        tip = flat == offsets[curve + 1] - 1
        ahead = p[np.minimum(flat + 1, len(p) - 1)] - p[flat]
        behind = p[flat] - p[np.maximum(flat - 1, offsets[curve])]
        out[flat] = np.where(tip[:, None], behind, ahead)
    return out


class StrandTables:
    """What a renderer derives from a curve layout alone — the curve parameter and seeds
    per vertex, and (asked for) the lines-adjacency segments — kept for the next frame,
    which usually has the same curves (the viewer, a simulation's frames)."""

    def __init__(self) -> None:
        self._offsets: np.ndarray | None = None
        self._tables: dict[str, np.ndarray] = {}

    def _for(self, offsets: np.ndarray) -> dict[str, np.ndarray]:
        if self._offsets is None or not np.array_equal(self._offsets, offsets):
            self._offsets = np.array(offsets)
            self._tables = {}
        return self._tables

    def param_and_seeds(self, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`curve_param` and :func:`strand_seeds` of ``offsets``."""
        tables = self._for(offsets)
        if "t" not in tables:
            tables["t"] = curve_param(offsets, int(offsets[-1]))
            tables["seed"] = strand_seeds(offsets)
        return tables["t"], tables["seed"]

    def segments(self, offsets: np.ndarray) -> np.ndarray:
        """:func:`segment_indices` of ``offsets``."""
        tables = self._for(offsets)
        if "segments" not in tables:
            tables["segments"] = segment_indices(offsets)
        return tables["segments"]
