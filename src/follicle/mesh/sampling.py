"""DensitySampler: points on a triangle mesh distributed by a density texture (Šik 2012 §2.1).

Preprocessing subdivides every triangle until its sub-triangles are smaller than a
texel of the density texture (depth from the texel count, eq. 2.3), gives each the
mean of the bilinear texture over it (the paper takes one sample at the barycentre;
see ``_leaf_value``) and merges four equal siblings back into their parent (Fig. 2.3).
A sub-triangle is stored as (parent triangle, sub-triangle index) with
``index(child) = 4·index(parent) + j``, j = 1…4, plus one shared table of
sub-triangle positions (Fig. 2.4, 2.5), and a 32-bit CDF value: 12 bytes. The
CDF is fixed point (steps of 2⁻³²) rather than float32, so even a 10⁴:1 texture
on millions of sub-triangles keeps every probability to 2.3·10⁻¹⁰.

Sampling takes exactly two numbers per sample (§2.1.5): the first picks the
sub-triangle through a uniform grid over the CDF's codomain and a bisection inside
the cell (§2.1.6) and, rescaled inside the chosen interval, is reused with the
second to place the point in the sub-triangle. Sample k is a pure function of
(seed, k): Halton (2, 3) with a seeded Cranley–Patterson shift for guides, a
counter-based splitmix64 stream for hairs (§2.1.7).
"""

from __future__ import annotations

import logging
import os
from numbers import Real
from pathlib import Path

import numpy as np

from ..arrays import readonly
from ..errors import InputError
from ..kernels import kernel, prange
from ..rng import halton_point, purpose_id, stream_key, uniform
from ..validate import number, positive, whole
from .skin import SkinMesh
from .texture import Texture, bilinear

__all__ = ["DensitySampler", "MAX_DEPTH", "SEQUENCES"]

log = logging.getLogger("follicle")

MAX_DEPTH = 11  # 4^11 ≈ 4.2 M sub-triangles per input triangle; the table stays ≤ 67 MB
SEQUENCES = ("random", "halton")
_FIXED = 4294967295.0  # CDF scale: 2^32 − 1, the largest uint32
_ROOT_STREAM = purpose_id("root")
_HALTON_SHIFT = purpose_id("halton shift")


def _table_size(depth: int) -> int:
    """Sub-triangles at depths 0 … depth: (4^(depth+1) − 1) / 3."""
    return (4 ** (depth + 1) - 1) // 3


# ---------------------------------------------------------------------- preprocessing
def subtriangle_table(depth: int) -> np.ndarray:
    """Positions of every sub-triangle index up to ``depth`` (Fig. 2.5), float32 (n, 3).

    Row g is (u0, v0, s): sub-triangle g has corners (u0, v0) + s·{(0,0), (1,0), (0,1)}
    in its parent's barycentric (u, v). Children j = 1, 2, 3 are the corner halves at
    parent corners 0, 1, 2; child 4 is the middle one, turned over (s < 0).
    """
    table = np.empty((_table_size(depth), 3), dtype=np.float64)
    table[0] = (0.0, 0.0, 1.0)
    head, tail = 0, 1
    offsets = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5], [0.5, 0.5]])
    signs = np.array([0.5, 0.5, 0.5, -0.5])
    while tail < len(table):  # level by level: all parents of a level at once
        count = tail - head
        parent = table[head:tail]
        kids = np.empty((count, 4, 3))
        kids[:, :, :2] = parent[:, None, :2] + parent[:, None, 2:3] * offsets[None]
        kids[:, :, 2] = parent[:, None, 2] * signs[None]
        table[tail : tail + 4 * count] = kids.reshape(-1, 3)
        head, tail = tail, tail + 4 * count
    return table.astype(np.float32)


@kernel(nogil=True)
def _level(g: int) -> int:
    """Subdivision depth of sub-triangle index g (0 for the whole triangle)."""
    level = 0
    while g > 0:
        g = (g - 1) // 4
        level += 1
    return level


# Edge midpoints of a sub-triangle's four children (in units of its corner frame) and
# their weights: the midpoint rule, exact for quadratics, on each child. The six
# boundary half-edges count once, the three inner edges are shared by two children.
_RULE_POINTS = np.array(
    [
        [0.25, 0.0],
        [0.75, 0.0],
        [1.0 - 0.25, 0.25],
        [0.25, 0.75],
        [0.0, 0.75],
        [0.0, 0.25],
        [0.5, 0.25],
        [0.25, 0.5],
        [0.25, 0.25],
    ]
)
_RULE_WEIGHTS = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0]) / 12.0


@kernel(nogil=True)
def _leaf_value(
    data: np.ndarray, repeat: bool, uvs: np.ndarray, t: int, table: np.ndarray, g: int
) -> float:
    """Mean bilinear density over sub-triangle g of triangle t.

    The paper samples the texture at the barycentre. The bilinear reconstruction
    kinks along texel-centre lines, so a barycentre sample misses a texel's mass by
    up to 20 % (a one-texel checkerboard); integrating the bilinear texture with the
    midpoint rule on the four children is exact wherever each child lies between
    texel centres, e.g. on texel-aligned UVs.
    """
    s = np.float64(table[g, 2])
    total = 0.0
    for c in range(_RULE_POINTS.shape[0]):
        bu = table[g, 0] + s * _RULE_POINTS[c, 0]
        bv = table[g, 1] + s * _RULE_POINTS[c, 1]
        bw = 1.0 - bu - bv
        u = bu * uvs[t, 0, 0] + bv * uvs[t, 1, 0] + bw * uvs[t, 2, 0]
        v = bu * uvs[t, 0, 1] + bv * uvs[t, 1, 1] + bw * uvs[t, 2, 1]
        total += _RULE_WEIGHTS[c] * bilinear(data, repeat, u, v, 0)
    return total


@kernel(nogil=True)
def _merged_leaves(
    data: np.ndarray,
    repeat: bool,
    uvs: np.ndarray,
    t: int,
    depth: int,
    table: np.ndarray,
    scratch: np.ndarray,
    out_sub: np.ndarray,
    out_val: np.ndarray,
    at: int,
) -> int:
    """Subdivide triangle t to ``depth``, merge equal siblings (Fig. 2.3), emit leaves.

    ``scratch[g]`` holds the value of sub-triangle g, NaN where its children differ.
    Leaves with positive density are written at ``at`` when ``out_sub`` is long
    enough (the fill pass) and only counted otherwise; returns the count.
    """
    first = (4**depth - 1) // 3
    last = (4 ** (depth + 1) - 1) // 3
    for g in range(first, last):
        scratch[g] = _leaf_value(data, repeat, uvs, t, table, g)
    for level in range(depth - 1, -1, -1):
        for g in range((4**level - 1) // 3, (4 ** (level + 1) - 1) // 3):
            c = 4 * g + 1
            v = scratch[c]
            same = v == scratch[c + 1] and v == scratch[c + 2] and v == scratch[c + 3]
            scratch[g] = v if same else np.nan
    write = out_sub.shape[0] > 0
    count = 0
    stack = np.empty(3 * depth + 1, dtype=np.int64)
    stack[0] = 0
    top = 1
    while top > 0:
        top -= 1
        g = stack[top]
        v = scratch[g]
        if v == v:  # uniform: a leaf
            if v > 0.0:
                if write:
                    out_sub[at + count] = g
                    out_val[at + count] = v
                count += 1
        else:
            for j in range(4, 0, -1):
                stack[top] = 4 * g + j
                top += 1
    return count


@kernel(parallel=True, nogil=True)
def _subdivide(
    data: np.ndarray,
    repeat: bool,
    uvs: np.ndarray,
    depths: np.ndarray,
    areas: np.ndarray,
    table: np.ndarray,
    counts: np.ndarray,
    offsets: np.ndarray,
    out_sub: np.ndarray,
    out_val: np.ndarray,
    out_parent: np.ndarray,
    out_weight: np.ndarray,
) -> None:
    """Count (``out_sub`` empty) or emit the merged leaves of every triangle."""
    nf = depths.shape[0]
    blocks = min(nf, 256)
    empty_sub = np.empty(0, dtype=np.int32)
    empty_val = np.empty(0, dtype=np.float64)
    for b in prange(blocks):
        lo = b * nf // blocks
        hi = (b + 1) * nf // blocks
        deepest = 0
        for t in range(lo, hi):
            deepest = max(deepest, depths[t])
        scratch = np.empty((4 ** (deepest + 1) - 1) // 3, dtype=np.float64)
        for t in range(lo, hi):
            if areas[t] <= 0.0:
                counts[t] = 0
                continue
            if out_sub.shape[0] == 0:
                counts[t] = _merged_leaves(
                    data,
                    repeat,
                    uvs,
                    t,
                    depths[t],
                    table,
                    scratch,
                    empty_sub,
                    empty_val,
                    np.int64(0),
                )
                continue
            at = offsets[t]
            n = _merged_leaves(
                data, repeat, uvs, t, depths[t], table, scratch, out_sub, out_val, at
            )
            for k in range(at, at + n):
                out_parent[k] = t
                out_weight[k] = out_val[k] * areas[t] / 4.0 ** _level(out_sub[k])


@kernel(nogil=True)
def _build_grid(cdf: np.ndarray, cells: int) -> np.ndarray:
    """lo[k] = first i with cdf[i] > ceil(k·2³²/cells), k = 0 … cells (§2.1.6)."""
    lo = np.empty(cells + 1, dtype=np.int32)
    n = cdf.shape[0]
    i = 0
    for k in range(cells + 1):
        x_min = (np.uint64(k) * np.uint64(4294967296) + np.uint64(cells - 1)) // np.uint64(cells)
        while i < n and np.uint64(cdf[i]) <= x_min:
            i += 1
        lo[k] = i
    return lo


@kernel(nogil=True)
def _sub_values(
    data: np.ndarray,
    repeat: bool,
    uvs: np.ndarray,
    parents: np.ndarray,
    subs: np.ndarray,
    table: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Density value and depth of every stored sub-triangle (recomputed, not stored)."""
    values = np.empty(parents.shape[0], dtype=np.float64)
    levels = np.empty(parents.shape[0], dtype=np.int64)
    for i in range(parents.shape[0]):
        values[i] = _leaf_value(data, repeat, uvs, parents[i], table, subs[i])
        levels[i] = _level(subs[i])
    return values, levels


# --------------------------------------------------------------------------- sampling
_BATCH = 512  # samples per batch: the grid loads of a batch overlap in memory


@kernel(parallel=True, nogil=True)
def _sample_kernel(
    records: np.ndarray,
    grid: np.ndarray,
    table: np.ndarray,
    seed: np.uint64,
    halton: bool,
    start: np.uint64,
    tri: np.ndarray,
    bary: np.ndarray,
    index: np.ndarray,
) -> None:
    """Samples start … start+n−1 into ``tri``, ``bary`` (and ``index`` when it is long).

    ``records`` rows are (fixed-point CDF, parent triangle, sub-triangle index). Work
    goes in batches of three passes (draw and look up the grid cell, bisect inside
    the cell, place the point) so that the cache misses of a batch overlap instead
    of waiting on each other.
    """
    n = tri.shape[0]
    cells = np.uint64(grid.shape[0] - 1)
    last = records.shape[0] - 1
    key = stream_key(seed, 0, _ROOT_STREAM)
    shift_key = stream_key(seed, 0, _HALTON_SHIFT)
    shift0 = uniform(shift_key, 0)
    shift1 = uniform(shift_key, 1)
    for batch in prange((n + _BATCH - 1) // _BATCH):
        m0 = batch * _BATCH
        size = min(n, m0 + _BATCH) - m0
        xs = np.empty(_BATCH)
        second = np.empty(_BATCH)
        lo = np.empty(_BATCH, dtype=np.int64)
        hi = np.empty(_BATCH, dtype=np.int64)
        first = start + np.uint64(m0)
        if halton:  # the branch stays outside the loops: it halves the speed inside
            for j in range(size):
                xi0, second[j] = halton_point(first + np.uint64(j), shift0, shift1)
                xs[j] = xi0 * _FIXED
        else:
            for j in range(size):
                k = np.uint64(2) * (first + np.uint64(j))
                xs[j] = uniform(key, k) * _FIXED
                second[j] = uniform(key, k + np.uint64(1))
        for j in range(size):
            cell = (np.uint64(xs[j]) * cells) >> np.uint64(32)
            lo[j] = grid[cell]
            hi[j] = min(np.int64(grid[cell + np.uint64(1)]), last)
        for j in range(size):  # first i with cdf[i] > x, inside the cell's range
            x = np.uint64(xs[j])
            a, b = lo[j], hi[j]
            while a < b:
                mid = (a + b) >> 1
                if np.uint64(records[mid, 0]) > x:
                    b = mid
                else:
                    a = mid + 1
            lo[j] = a
        for j in range(size):
            a = lo[j]
            low = np.float64(records[a - 1, 0]) if a > 0 else 0.0
            reuse = (xs[j] - low) / (np.float64(records[a, 0]) - low)  # ξ₁ rescaled
            root = np.sqrt(min(max(reuse, 0.0), 1.0))
            g = records[a, 2]
            scale = np.float64(table[g, 2])
            tri[m0 + j] = records[a, 1]
            bary[m0 + j, 0] = table[g, 0] + scale * (1.0 - root)
            bary[m0 + j, 1] = table[g, 1] + scale * (second[j] * root)
            if index.shape[0] > 0:
                index[m0 + j] = a


# ---------------------------------------------------------------------------- class
def _as_density(density: object) -> Texture | float | None:
    if density is None or isinstance(density, Texture):
        return density
    if isinstance(density, (bool, Real)):  # a bool is refused as a number
        return positive(density, "density")
    if isinstance(density, (str, os.PathLike)):
        return Texture.load(Path(density))
    return Texture(density, name="density")


class DensitySampler:
    """Samples (triangle, barycentric) points on a mesh's rest pose by area × density.

    ``density`` is None or a number (uniform by area), a :class:`Texture`, an image
    path or an array; the texture's first channel is the density (≥ 0, any range:
    HDR is fine). ``grid_factor`` sets the grid cells per sub-triangle (§4.1.1: 4).
    ``refine`` adds subdivision levels below the texel size: each quarters the
    sub-triangles' area (and multiplies memory by up to 4) and sharpens the density
    where sub-triangles do not line up with texels (measurements: the docs' How-to › Root
    placement).
    Roots bound to rest-pose samples stay put on an animated mesh (§2.2.3).
    """

    def __init__(
        self, mesh: SkinMesh, density: object = None, grid_factor: float = 4, refine: int = 0
    ) -> None:
        if not isinstance(mesh, SkinMesh):
            raise InputError(f"mesh: expected a SkinMesh, got {type(mesh).__name__}")
        grid_factor = number(grid_factor, "grid_factor", lo=0.0, hi=64.0, lo_open=True)
        refine = whole(refine, "refine", 0, 4)
        self.mesh = mesh
        self.density = _as_density(density)
        areas = np.ascontiguousarray(mesh.face_areas("rest"), dtype=np.float64)
        if isinstance(self.density, Texture):
            self.depths, parents, subs, weights = self._subdivide(mesh, self.density, areas, refine)
        else:
            self.depths = np.zeros(len(areas), dtype=np.int64)
            parents = np.flatnonzero(areas > 0).astype(np.int32)
            subs = np.zeros(len(parents), dtype=np.int32)
            weights = areas[parents] * (1.0 if self.density is None else self.density)
        total = float(weights.sum())
        if not total > 0:
            raise InputError(
                f"mesh '{mesh.name}': the density is zero on every triangle, so nothing can be"
                " sampled; paint some density where hair should grow"
            )
        self.total_weight = total
        records = np.empty((len(parents), 3), dtype=np.uint32)
        cdf = np.minimum(np.rint(np.cumsum(weights) * (_FIXED / total)), _FIXED)
        cdf[-1] = _FIXED
        records[:, 0] = cdf
        records[:, 1] = parents
        records[:, 2] = subs
        self._records = records
        self.table = subtriangle_table(int(self.depths.max()))
        cells = max(1, min(int(round(grid_factor * len(parents))), 2**31 - 2))
        self.grid = _build_grid(readonly(self.cdf), cells)
        for arr in (records, self.table, self.grid, self.depths):
            arr.setflags(write=False)

    @property
    def cdf(self) -> np.ndarray:
        """Fixed-point CDF (uint32, last = 2³² − 1) over the sub-triangles."""
        return self._records[:, 0]

    @property
    def parents(self) -> np.ndarray:
        """Input triangle of each sub-triangle (uint32)."""
        return self._records[:, 1]

    @property
    def subs(self) -> np.ndarray:
        """Sub-triangle index (``4·parent + j``) of each sub-triangle (uint32)."""
        return self._records[:, 2]

    def _subdivide(
        self, mesh: SkinMesh, tex: Texture, areas: np.ndarray, refine: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if mesh.uvs is None:
            raise InputError(
                f"mesh '{mesh.name}' has no UVs, so density texture '{tex.name}' cannot be"
                " mapped; give the mesh UVs or use a constant density"
            )
        values = tex.data[:, :, 0]
        if values.min() < 0:
            row, col = np.unravel_index(int(np.argmin(values)), values.shape)
            raise InputError(
                f"density texture '{tex.name}' has negative values (min {values.min():g} at"
                f" row {row}, column {col}); densities must be ≥ 0"
            )
        if not values.max() > 0:
            raise InputError(f"density texture '{tex.name}' is zero everywhere; paint density")
        uvs = np.ascontiguousarray(mesh.uvs[mesh.faces])  # (F, 3, 2)
        e1, e2 = uvs[:, 0] - uvs[:, 2], uvs[:, 1] - uvs[:, 2]
        texels = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) * tex.width * tex.height
        # eq. 2.3: the smallest d with 4^d ≥ texelCount(T)
        depths = np.ceil(np.log2(np.maximum(texels, 1.0)) / 2.0 - 1e-9).astype(np.int64) + refine
        if depths.max() > MAX_DEPTH:
            log.warning(
                "mesh '%s': %d triangle(s) map more than 4^%d texels of '%s'; they are"
                " subdivided to depth %d only, so the density is averaged over several texels",
                mesh.name,
                int((depths > MAX_DEPTH).sum()),
                MAX_DEPTH,
                tex.name,
                MAX_DEPTH,
            )
            depths = np.minimum(depths, MAX_DEPTH)
        table = subtriangle_table(int(depths.max()))
        counts = np.zeros(len(areas), dtype=np.int64)
        args = (tex.data, tex.wrap == "repeat", uvs, depths, areas, table, counts)
        nothing = np.empty(0, dtype=np.int32)
        _subdivide(*args, counts, nothing, np.empty(0), nothing, np.empty(0))
        offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        total = int(counts.sum())
        subs = np.empty(total, dtype=np.int32)
        values_out = np.empty(total, dtype=np.float64)
        parents = np.empty(total, dtype=np.int32)
        weights = np.empty(total, dtype=np.float64)
        _subdivide(*args, offsets, subs, values_out, parents, weights)
        return depths, parents, subs, weights

    # ------------------------------------------------------------------ queries
    @property
    def sub_triangle_count(self) -> int:
        return len(self.parents)

    @property
    def memory_bytes(self) -> int:
        """Bytes kept for sampling: 12 per sub-triangle, the grid and the position table."""
        return self._records.nbytes + self.grid.nbytes + self.table.nbytes

    def _probabilities(self) -> np.ndarray:
        """Probability of each sub-triangle (float64, sums to 1), from the fixed-point CDF."""
        cdf = self.cdf.astype(np.float64)
        return np.diff(cdf, prepend=0.0) / _FIXED

    def _values_and_levels(self) -> tuple[np.ndarray, np.ndarray]:
        if not isinstance(self.density, Texture):
            constant = 1.0 if self.density is None else self.density
            n = self.sub_triangle_count
            return np.full(n, constant), np.zeros(n, dtype=np.int64)
        tex, mesh = self.density, self.mesh
        assert mesh.uvs is not None  # _subdivide refused a density texture without UVs
        return _sub_values(
            tex.data,
            tex.wrap == "repeat",
            np.ascontiguousarray(mesh.uvs[mesh.faces]),
            self.parents,
            self.subs,
            self.table,
        )

    def sub_triangle_areas(self) -> np.ndarray:
        """Area of each sub-triangle on the rest pose, float64 (n_s,)."""
        levels = self._values_and_levels()[1]
        return self.mesh.face_areas("rest")[self.parents] / 4.0**levels

    @property
    def pdf(self) -> np.ndarray:
        """Probability density per unit rest area on each sub-triangle (eq. 2.2), float64."""
        return self._values_and_levels()[0] / self.total_weight

    def region_probability(self, triangle_mask: object) -> float:
        """Probability that a sample lands on the masked triangles (getDensity, §3.1.4)."""
        mask = np.asarray(triangle_mask)
        if mask.shape != (self.mesh.face_count,) or mask.dtype != np.bool_:
            raise InputError(
                f"triangle_mask: expected a bool array of shape ({self.mesh.face_count},),"
                f" got {mask.dtype} {mask.shape}"
            )
        return float(self._probabilities()[mask[self.parents]].sum())

    def __repr__(self) -> str:
        density = self.density.name if isinstance(self.density, Texture) else self.density
        return (
            f"DensitySampler(mesh '{self.mesh.name}', density={density!r},"
            f" {self.sub_triangle_count} sub-triangles, depth ≤ {int(self.depths.max())},"
            f" {self.memory_bytes / 1e6:.1f} MB)"
        )

    # ------------------------------------------------------------------ sampling
    def sample(
        self,
        n: int,
        seed: int = 0,
        sequence: str = "random",
        start: int = 0,
        return_index: bool = False,
    ) -> tuple[np.ndarray, ...]:
        """Samples ``start … start+n-1``: (triangle int32 (n,), bary float32 (n, 2)).

        ``bary`` follows Šik 2012 §2.2.3 (point = u·v0 + v·v1 + (1−u−v)·v2). ``sequence``
        is "random" (counter-based, for hairs) or "halton" (low discrepancy, for
        guides). ``return_index`` adds each sample's sub-triangle (int32, an index
        into :attr:`pdf`).
        """
        n, start, seed = whole(n, "n", 0), whole(start, "start", 0), whole(seed, "seed", 0)
        if sequence not in SEQUENCES:
            raise InputError(f"sequence={sequence!r}; use one of {list(SEQUENCES)}")
        tri = np.empty(n, dtype=np.int32)
        bary = np.empty((n, 2), dtype=np.float32)
        index = np.empty(n if return_index else 0, dtype=np.int32)
        _sample_kernel(
            self._records,
            self.grid,
            self.table,
            np.uint64(seed & 0xFFFFFFFFFFFFFFFF),
            sequence == "halton",
            np.uint64(start),
            tri,
            bary,
            index,
        )
        return (tri, bary, index) if return_index else (tri, bary)
