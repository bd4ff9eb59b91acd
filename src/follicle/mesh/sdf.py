"""SDF: a grid signed distance field of the skin mesh, for hair-skin collision.

The hair solver pushes strand particles out of the skin every substep. An exact
closest-triangle query per particle is too slow for that, so the skin's current pose is
sampled once per frame into a regular grid of signed distances (negative inside), and a
particle reads its distance and outward normal by trilinear interpolation: a few dozen
flops, callable from inside the solver's own numba kernels (:func:`sdf_sample`).

Building (:meth:`SDF.from_mesh`), fast enough to redo every animation frame:

1. Narrow band: every triangle visits the grid vertices of its bounding box dilated by
   ``band`` voxels; a vertex nearer than ``band`` voxels to it keeps the exact smallest
   distance (closest point on a triangle by Voronoi regions, Ericson, *Real-Time
   Collision Detection* §5.1.5) and that triangle. Triangles are binned per block of 8³
   vertices, blocks run in parallel.
2. Propagation, for the vertices beyond the band: sweeps along ±x, ±y, ±z, slab by
   slab, offer every vertex the closest triangles of its 3×3 neighbours in the slab
   before; it keeps the nearest by exact distance (the + and − sweeps of an axis run in
   parallel). So a far vertex gets the best triangle its neighbours found, not always
   the nearest of all: on the built-in head at the default grid every distance is
   within 0.06 voxel of exact.
3. Sign, from the angle-weighted pseudo-normal of the closest feature (J. A. Bærentzen
   and H. Aanæs, "Signed distance computation using the angle weighted pseudonormal",
   IEEE TVCG 11(3), 2005): the face normal when the closest point is inside a face, the
   mean of the adjacent face normals on an edge, the angle-weighted normal at a vertex;
   negative where (p − closest) · pseudo-normal < 0. Vertices at the same position (UV
   seams) are welded for this. The sign is exact for closed meshes; for an open mesh
   (a head with a neck opening) it is right near the surface, but far from the open
   boundary it is only as good as the boundary's pseudo-normal: the region beyond the
   opening is split along the boundary's normals, not filled or emptied.

The grid lives in a local frame (the frame of the vertices it was built from) with a
rigid world-from-local ``transform``, so a head that only moves rigidly needs no
rebuild: :meth:`SDF.with_transform` gives a view on the same values. Points outside the
grid read the distance to the grid box plus the absolute value at the nearest grid
point: always positive, growing with distance. Every kernel is deterministic: the same
values, byte for byte, with any number of numba threads.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from ..arrays import as_points, frozen, rigid
from ..errors import InputError, ResourceError
from ..frames import normalize
from ..kernels import kernel, prange
from ..validate import positive, whole
from .skin import SkinMesh, closest_weights

__all__ = ["SDF", "skin_sdf", "sdf_sample", "sdf_lookup"]

_SQRT3 = math.sqrt(3.0)

_CELLS_ALONG_LONGEST = 64  # default voxel size: the longest bounds axis / this
_PAD_FRACTION = 0.05  # default padding: this × the bounds' diagonal …
_PAD_MIN_VOXELS = 3  # … but at least this many voxels
_MAX_VERTICES = 256**3  # a bigger grid is refused (64 MiB of float32)
_BLOCK = 8  # the band pass bins triangles per block of this many vertices per axis
_SLIVER = 1e-6  # faces with 2·area <= this × (longest edge)² are dropped (zero area)


class SDF:
    """Signed distances (negative inside) of a triangle mesh on a regular grid.

    Grid vertex (i, j, k) sits at ``origin + voxel · (i, j, k)`` in the local frame;
    ``transform`` maps the local frame to the world, in which queries are given and
    normals returned.
    """

    origin: np.ndarray  # (3,) float64: grid vertex (0, 0, 0) in the local frame
    voxel: float  # grid spacing (same unit as the mesh)
    values: np.ndarray  # (nx, ny, nz) float32 signed distances, read-only
    transform: np.ndarray  # (4, 4) float64 world-from-local, rigid

    def __init__(
        self,
        values: np.ndarray,
        origin: np.ndarray,
        voxel: float,
        transform: np.ndarray | None = None,
    ) -> None:
        """Wrap a grid of signed distances; :meth:`from_mesh` is the usual way to get one."""
        vals = np.asarray(values, dtype=np.float32)
        if vals.ndim != 3 or min(vals.shape) < 2:
            raise InputError(
                f"values: expected a 3-D grid with at least 2 vertices per axis, got {vals.shape}"
            )
        if not np.isfinite(vals).all():
            raise InputError("values: the grid holds NaN or inf; every distance must be finite")
        orig = np.asarray(origin, dtype=np.float64)
        if orig.shape != (3,) or not np.isfinite(orig).all():
            raise InputError(f"origin: expected 3 finite numbers, got {orig.tolist()}")
        self.values = frozen(vals.copy())
        self.origin = frozen(orig.copy())
        self.voxel = positive(voxel, "voxel", unit="m")
        self.transform, self._local_from_world = _rigid(
            np.eye(4) if transform is None else transform
        )

    @classmethod
    def from_mesh(
        cls,
        vertices: np.ndarray,
        faces: np.ndarray,
        voxel_size: float | None = None,
        padding: float | None = None,
        band: int = 2,
    ) -> SDF:
        """The SDF of a triangle mesh (open or closed) in the frame of ``vertices``.

        The grid covers the mesh bounds plus ``padding`` on every side (default: 5 % of
        the bounds' diagonal, at least 3 voxels) with spacing ``voxel_size`` (default:
        the longest bounds axis / 64). Vertices nearer than ``band`` voxels (>= 1) to
        the mesh get exact distances; the rest get the distance to the closest triangle
        found by their neighbours (see the module docstring). A grid of more than 256³
        vertices is a ResourceError naming the smallest ``voxel_size`` that fits.
        """
        verts, tris = _check_mesh(vertices, faces)
        # >= 1: a grid vertex lies within one voxel of every triangle, seeds for all
        band = whole(band, "band", 1)
        corners = verts[tris]
        lo = corners.reshape(-1, 3).min(axis=0)
        hi = corners.reshape(-1, 3).max(axis=0)
        if voxel_size is None:
            voxel = float((hi - lo).max()) / _CELLS_ALONG_LONGEST
        else:
            voxel = positive(voxel_size, "voxel_size", unit="m")
        if padding is not None:
            padding = positive(padding, "padding", allow_zero=True, unit="m")
        dims, origin = _grid(lo, hi, voxel, padding)

        face_normal, face_edge, edge_normal, vertex_normal = _pseudo_normals(verts, tris)
        count = int(np.prod(dims))
        dist2 = np.full(count, np.inf)
        closest = np.full(count, -1, dtype=np.int32)  # triangle per vertex
        reach2 = (band * voxel) ** 2
        _band_kernel(
            verts,
            tris,
            face_normal,
            origin,
            voxel,
            dims,
            *_bin_triangles(corners, origin, voxel, dims, band),
            _BLOCK,
            reach2,
            closest,
            dist2,
        )
        _sweep_kernel(verts, tris, origin, voxel, dims, reach2, closest, dist2)
        values = np.empty(count, dtype=np.float32)
        _sign_kernel(
            verts,
            tris,
            origin,
            voxel,
            dims,
            closest,
            dist2,
            face_normal,
            face_edge,
            edge_normal,
            vertex_normal,
            values,
        )
        return cls(values.reshape(tuple(dims)), origin, voxel)

    def with_transform(self, transform: np.ndarray) -> SDF:
        """A view of this SDF (sharing ``values``) placed in the world by ``transform``.

        ``transform`` is the rigid 4×4 world-from-local matrix, local being the frame of
        the vertices the SDF was built from; it replaces, not composes with, the current
        one. For a head that moves rigidly between rebuilds.
        """
        view = copy.copy(self)
        view.transform, view._local_from_world = _rigid(transform)
        return view

    @property
    def sample_args(self) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
        """``(values, origin, inv_voxel, local_from_world)``: the leading arguments of
        :func:`sdf_sample`, for a solver kernel that samples particle by particle."""
        return self.values, self.origin, 1.0 / self.voxel, self._local_from_world

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distances (M,) float64 at world points (M, 3); negative inside."""
        return self.distance_and_normal(points)[0]

    def distance_and_normal(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distances (M,) and unit outward normals (M, 3) at world points (M, 3).

        The normal is the normalised gradient of the trilinear interpolant (zero where
        that gradient vanishes, which takes exactly balanced grid values).
        """
        q = as_points("points", points)
        dist = np.empty(q.shape[0])
        normal = np.empty((q.shape[0], 3))
        _sample_kernel(*self.sample_args, q, dist, normal)
        return dist, normal

    def __repr__(self) -> str:
        nx, ny, nz = self.values.shape
        return f"SDF(grid={nx}×{ny}×{nz}, voxel={self.voxel:.4g})"


# ------------------------------------------------------------------- checks
def _check_mesh(vertices: object, faces: object) -> tuple[np.ndarray, np.ndarray]:
    """(vertices float64 (V, 3), faces int64 (F, 3)) without zero-area faces, or InputError."""
    verts = np.array(vertices, dtype=np.float64)  # writable: one kernel specialisation
    if verts.ndim != 2 or verts.shape[1] != 3:
        raise InputError(f"vertices: expected shape (V, 3), got {verts.shape}")
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3:
        raise InputError(f"faces: expected shape (F, 3) (triangles), got {f.shape}")
    if verts.shape[0] == 0 or f.shape[0] == 0:
        raise InputError(
            f"vertices, faces: the mesh is empty ({verts.shape[0]} vertices, {f.shape[0]}"
            " faces); give at least one triangle"
        )
    if not np.issubdtype(f.dtype, np.integer):
        raise InputError(f"faces: expected integer vertex indices, got {f.dtype}")
    f = np.ascontiguousarray(f, dtype=np.int64)
    if f.min() < 0 or f.max() >= verts.shape[0]:
        bad = int(np.argmax(((f < 0) | (f >= verts.shape[0])).any(axis=1)))
        raise InputError(
            f"faces: face {bad} = {f[bad].tolist()} indexes outside the {verts.shape[0]}"
            f" vertices (valid 0 … {verts.shape[0] - 1})"
        )
    if not np.isfinite(verts).all():
        bad = int(np.flatnonzero(~np.isfinite(verts).all(axis=1))[0])
        raise InputError(f"vertices: row {bad} is not finite: {verts[bad].tolist()}")
    corners = verts[f]
    edges = corners - np.roll(corners, 1, axis=1)
    longest2 = np.einsum("fkj,fkj->fk", edges, edges).max(axis=1)
    area2 = np.linalg.norm(np.cross(edges[:, 1], edges[:, 2]), axis=1)  # twice the area
    keep = area2 > _SLIVER * longest2
    if not keep.any():
        raise InputError(f"faces: all {f.shape[0]} triangles have zero area; nothing to measure")
    return verts, f[keep]


def _grid(
    lo: np.ndarray, hi: np.ndarray, voxel: float, padding: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """(vertex counts int64 (3,), origin (3,)) of the grid centred on the bounds lo…hi,
    or ResourceError when it would hold more than 256³ vertices (a valid voxel size, too
    fine for the limit)."""

    def counts(h: float) -> np.ndarray:
        pad = max(_PAD_FRACTION * float(np.linalg.norm(hi - lo)), _PAD_MIN_VOXELS * h)
        span = hi - lo + 2.0 * (pad if padding is None else padding)
        with np.errstate(over="ignore"):  # a tiny h: too many cells, not an overflow
            cells = np.minimum(np.ceil(span / h), 2.0**40)
        return np.maximum(cells.astype(np.int64), 1) + 1

    dims = counts(voxel)
    total = math.prod(int(d) for d in dims)  # Python ints: a tiny voxel overflows int64
    if total > _MAX_VERTICES:
        fit = float(f"{voxel * (total / _MAX_VERTICES) ** (1.0 / 3.0):.3g}")
        while math.prod(int(d) for d in counts(fit)) > _MAX_VERTICES:  # smallest 3 digits
            fit = float(f"{fit * 1.01:.3g}")
        raise ResourceError(
            f"voxel_size: {voxel:.4g} gives a {dims[0]}×{dims[1]}×{dims[2]} grid ({total:,}"
            f" vertices), over the limit of 256³; use voxel_size >= {fit:.3g}"
        )
    origin = 0.5 * (lo + hi) - 0.5 * voxel * (dims - 1)
    return dims, origin


def _bin_triangles(
    corners: np.ndarray, origin: np.ndarray, voxel: float, dims: np.ndarray, band: int
) -> tuple[np.ndarray, ...]:
    """Triangles per block of _BLOCK³ grid vertices, for the band pass.

    Returns (tri_lo, tri_hi): per triangle the first and last grid vertex (inclusive,
    int64 (F, 3)) of its bounding box dilated by ``band`` voxels; ``blocks`` (3,), the
    block counts; and CSR lists (block_start, block_tris) of the triangles whose box
    meets each block, in ascending triangle order.
    """
    tri_lo = np.floor((corners.min(axis=1) - origin) / voxel).astype(np.int64) - band
    tri_hi = np.ceil((corners.max(axis=1) - origin) / voxel).astype(np.int64) + band
    np.clip(tri_lo, 0, dims - 1, out=tri_lo)
    np.clip(tri_hi, 0, dims - 1, out=tri_hi)
    blocks = -(-dims // _BLOCK)
    pairs = int(np.prod(tri_hi // _BLOCK - tri_lo // _BLOCK + 1, axis=1).sum())
    pair_block, pair_tri = _block_pairs(tri_lo, tri_hi, blocks, _BLOCK, pairs)
    block_start = np.zeros(int(np.prod(blocks)) + 1, dtype=np.int64)
    np.cumsum(np.bincount(pair_block, minlength=block_start.size - 1), out=block_start[1:])
    block_tris = pair_tri[np.argsort(pair_block, kind="stable")]
    return tri_lo, tri_hi, blocks, block_start, block_tris


def _rigid(transform: object) -> tuple[np.ndarray, np.ndarray]:
    """(world_from_local, local_from_world) of a rigid ``transform``, or InputError."""
    return rigid(transform, hint=": build the SDF from the scaled vertices instead")


def _pseudo_normals(
    verts: np.ndarray, faces: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bærentzen & Aanæs pseudo-normals, with vertices at equal positions welded.

    Returns unit face normals (F, 3); face_edge (F, 3), the edge ids of the edges
    (v0, v1), (v1, v2), (v2, v0) of every face; unit edge normals (E, 3), the mean of
    the adjacent face normals; unit angle-weighted vertex normals (V, 3).
    """
    _, weld = np.unique(verts, axis=0, return_inverse=True)
    weld = weld.reshape(-1)
    wf = weld[faces]
    corners = verts[faces]
    face_normal = normalize(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
    angle = np.empty(faces.shape)
    for k in range(3):
        e1 = corners[:, (k + 1) % 3] - corners[:, k]
        e2 = corners[:, (k + 2) % 3] - corners[:, k]
        angle[:, k] = np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=1), np.sum(e1 * e2, axis=1))

    def accumulate(index: np.ndarray, weight: np.ndarray, size: int) -> np.ndarray:
        """Unit sums of weight × face normal (repeated per corner) grouped by index."""
        vec = (weight[:, :, None] * face_normal[:, None, :]).reshape(-1, 3)
        flat = index.reshape(-1)
        return normalize(
            np.stack([np.bincount(flat, vec[:, j], minlength=size) for j in range(3)], axis=1)
        )

    n_weld = int(weld.max()) + 1
    vertex_normal = accumulate(wf, angle, n_weld)[weld]
    a = wf
    b = np.roll(wf, -1, axis=1)  # edge k joins corner k to corner k + 1
    key = np.minimum(a, b) * n_weld + np.maximum(a, b)
    edges, face_edge = np.unique(key.reshape(-1), return_inverse=True)
    face_edge = face_edge.reshape(faces.shape).astype(np.int64)
    edge_normal = accumulate(face_edge, np.ones(faces.shape), edges.shape[0])
    return face_normal, face_edge, edge_normal, np.ascontiguousarray(vertex_normal)


# ------------------------------------------------------------------- lookup
@kernel(inline="always")
def _grid_place(
    values: np.ndarray,
    origin: np.ndarray,
    inv_voxel: float,
    m: np.ndarray,
    px: float,
    py: float,
    pz: float,
) -> tuple[float, float, float, float, float, float, int, int, int]:
    """A world point in grid units (u), the nearest point of the grid box (c) and the
    cell (i) holding that."""
    ux = (m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3] - origin[0]) * inv_voxel
    uy = (m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3] - origin[1]) * inv_voxel
    uz = (m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3] - origin[2]) * inv_voxel
    sx, sy, sz = values.shape
    cx = min(max(ux, 0.0), sx - 1.0)  # the nearest point of the grid box, in voxels
    cy = min(max(uy, 0.0), sy - 1.0)
    cz = min(max(uz, 0.0), sz - 1.0)
    return ux, uy, uz, cx, cy, cz, min(int(cx), sx - 2), min(int(cy), sy - 2), min(int(cz), sz - 2)


def skin_sdf(mesh: SkinMesh, pose: str = "rest") -> SDF:
    """The grid signed distance field of ``mesh``'s ``pose`` (the default voxel: the
    longest bounds axis / 64), built on first use and kept with the pose's other derived
    data (:meth:`SkinMesh.derived`): the groom's skin collision and the guide editor read
    the same field."""
    return mesh.derived("sdf", pose, lambda v: SDF.from_mesh(v, mesh.faces))


@kernel(inline="always")
def sdf_sample(
    values: np.ndarray,
    origin: np.ndarray,
    inv_voxel: float,
    local_from_world: np.ndarray,
    px: float,
    py: float,
    pz: float,
) -> tuple[float, float, float, float]:
    """Signed distance and unit outward normal at the world point (px, py, pz).

    Arguments (:attr:`SDF.sample_args` gives the first four): ``values`` the (nx, ny,
    nz) float32 grid, each axis >= 2; ``origin`` (3,) float64, grid vertex (0, 0, 0) in
    the local frame; ``inv_voxel`` 1 / voxel size; ``local_from_world`` the rigid
    (4, 4) float64 inverse of the SDF's transform. Returns ``(d, nx, ny, nz)`` floats:
    the trilinear distance and the normalised gradient of the interpolant, in world
    space (zero where the gradient vanishes). Outside the grid: the distance to the grid
    box plus |value| at the nearest grid point, and that sum's gradient (never inside).
    Allocates nothing, so a solver kernel can call it per particle.
    """
    d, nx, ny, nz, _ = sdf_lookup(values, origin, inv_voxel, local_from_world, px, py, pz, math.inf)
    return d, nx, ny, nz


@kernel(inline="always")
def sdf_lookup(
    values: np.ndarray,
    origin: np.ndarray,
    inv_voxel: float,
    local_from_world: np.ndarray,
    px: float,
    py: float,
    pz: float,
    below: float,
) -> tuple[float, float, float, float, float]:
    """:func:`sdf_sample` plus a bound b such that (b − m)/√3 is how far the point may
    move before the sampled distance can fall to m ≥ 0 (inside the box d itself, whose
    trilinear interpolant falls at most √3 per unit moved; outside a scaled-down d), so
    a caller need not look a point up again before then: ``(d, nx, ny, nz, bound)``.
    The normal is worked out only where d < ``below`` (elsewhere 0, 0, 0): a collision
    test needs it only for points it pushes, most lookups find the point clear."""
    m = local_from_world
    ux, uy, uz, cx, cy, cz, ix, iy, iz = _grid_place(values, origin, inv_voxel, m, px, py, pz)
    fx = cx - ix
    fy = cy - iy
    fz = cz - iz
    v = values
    dz00 = v[ix, iy, iz + 1] - v[ix, iy, iz]  # the z differences of the cell's 4 columns
    dz01 = v[ix, iy + 1, iz + 1] - v[ix, iy + 1, iz]
    dz10 = v[ix + 1, iy, iz + 1] - v[ix + 1, iy, iz]
    dz11 = v[ix + 1, iy + 1, iz + 1] - v[ix + 1, iy + 1, iz]
    c00 = v[ix, iy, iz] + dz00 * fz  # along z …
    c01 = v[ix, iy + 1, iz] + dz01 * fz
    c10 = v[ix + 1, iy, iz] + dz10 * fz
    c11 = v[ix + 1, iy + 1, iz] + dz11 * fz
    c0 = c00 + (c01 - c00) * fy  # … then y …
    c1 = c10 + (c11 - c10) * fy
    inside = c0 + (c1 - c0) * fx  # … then x
    d = bound = inside
    ex = ux - cx
    ey = uy - cy
    ez = uz - cz
    out2 = ex * ex + ey * ey + ez * ez
    out = 0.0
    s = 1.0 if inside >= 0.0 else -1.0
    if out2 > 0.0:  # outside the box: |box distance| + |d|; clamped axes follow the box
        out = math.sqrt(out2)
        d = out / inv_voxel + s * inside
        # that sum falls up to 1 + √3 per unit moved (box distance, then the value at the
        # box's nearest point); the box distance alone falls at most 1
        bound = max(out / inv_voxel, d * _SQRT3 / (1.0 + _SQRT3))
    if d >= below:
        return d, 0.0, 0.0, 0.0, bound
    # the interpolant's derivatives per voxel, then per unit length
    gx = (c1 - c0) * inv_voxel
    gy = ((1.0 - fx) * (c01 - c00) + fx * (c11 - c10)) * inv_voxel
    gz = ((1.0 - fx) * (dz00 + (dz01 - dz00) * fy) + fx * (dz10 + (dz11 - dz10) * fy)) * inv_voxel
    if out2 > 0.0:
        gx = ex / out if ex != 0.0 else s * gx
        gy = ey / out if ey != 0.0 else s * gy
        gz = ez / out if ez != 0.0 else s * gz
    g = math.sqrt(gx * gx + gy * gy + gz * gz)
    if g > 0.0:
        gx /= g
        gy /= g
        gz /= g
    # local → world: the transpose of local_from_world's rotation
    wx = m[0, 0] * gx + m[1, 0] * gy + m[2, 0] * gz
    wy = m[0, 1] * gx + m[1, 1] * gy + m[2, 1] * gz
    wz = m[0, 2] * gx + m[1, 2] * gy + m[2, 2] * gz
    return d, wx, wy, wz, bound


@kernel(parallel=True)
def _sample_kernel(
    values: np.ndarray,
    origin: np.ndarray,
    inv_voxel: float,
    local_from_world: np.ndarray,
    points: np.ndarray,
    dist: np.ndarray,
    normal: np.ndarray,
) -> None:
    for i in prange(points.shape[0]):
        d, x, y, z = sdf_sample(
            values, origin, inv_voxel, local_from_world, points[i, 0], points[i, 1], points[i, 2]
        )
        dist[i] = d
        normal[i, 0] = x
        normal[i, 1] = y
        normal[i, 2] = z


# -------------------------------------------------------------------- build
@kernel(inline="always")
def _distance2(
    px: float,
    py: float,
    pz: float,
    verts: np.ndarray,
    faces: np.ndarray,
    t: int,
) -> tuple[float, float, float, float]:
    """(squared distance, wa, wb, wc): p to triangle t, and its closest point's weights."""
    i, j, k = faces[t, 0], faces[t, 1], faces[t, 2]
    wa, wb, wc = closest_weights(
        px,
        py,
        pz,
        verts[i, 0],
        verts[i, 1],
        verts[i, 2],
        verts[j, 0],
        verts[j, 1],
        verts[j, 2],
        verts[k, 0],
        verts[k, 1],
        verts[k, 2],
    )
    dx = px - (wa * verts[i, 0] + wb * verts[j, 0] + wc * verts[k, 0])
    dy = py - (wa * verts[i, 1] + wb * verts[j, 1] + wc * verts[k, 1])
    dz = pz - (wa * verts[i, 2] + wb * verts[j, 2] + wc * verts[k, 2])
    return dx * dx + dy * dy + dz * dz, wa, wb, wc


@kernel
def _block_pairs(
    tri_lo: np.ndarray,
    tri_hi: np.ndarray,
    blocks: np.ndarray,
    size: int,
    count: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` (block, triangle) pairs where triangle t's vertex box (tri_lo …
    tri_hi, inclusive) meets a block of size³ vertices, in ascending triangle order."""
    nby, nbz = blocks[1], blocks[2]
    blk = np.empty(count, dtype=np.int64)
    tri = np.empty(count, dtype=np.int64)
    k = 0
    for t in range(tri_lo.shape[0]):
        for bx in range(tri_lo[t, 0] // size, tri_hi[t, 0] // size + 1):
            for by in range(tri_lo[t, 1] // size, tri_hi[t, 1] // size + 1):
                for bz in range(tri_lo[t, 2] // size, tri_hi[t, 2] // size + 1):
                    blk[k] = (bx * nby + by) * nbz + bz
                    tri[k] = t
                    k += 1
    return blk, tri


@kernel(parallel=True)
def _band_kernel(
    verts: np.ndarray,
    faces: np.ndarray,
    face_normal: np.ndarray,
    origin: np.ndarray,
    voxel: float,
    dims: np.ndarray,
    tri_lo: np.ndarray,
    tri_hi: np.ndarray,
    blocks: np.ndarray,
    block_start: np.ndarray,
    block_tris: np.ndarray,
    size: int,
    reach2: float,
    closest: np.ndarray,
    dist2: np.ndarray,
) -> None:
    """Exact squared distance and closest triangle for every vertex nearer than
    sqrt(reach2) to the mesh; the others keep (-1, inf).

    A triangle visits the vertices of its box (tri_lo … tri_hi, inclusive); the
    distance to its plane, a lower bound, skips the exact test where it cannot win.
    Each block is one parallel task that owns its vertices; its triangles come in
    ascending order and only a strictly smaller distance wins, so ties keep the lowest
    triangle index whatever the thread count.
    """
    ny, nz = dims[1], dims[2]
    nby, nbz = blocks[1], blocks[2]
    for blk in prange(blocks[0] * nby * nbz):
        bx = blk // (nby * nbz)
        by = (blk // nbz) % nby
        bz = blk % nbz
        x_end = min(bx * size + size, dims[0]) - 1  # the block's last vertex per axis
        y_end = min(by * size + size, ny) - 1
        z_end = min(bz * size + size, nz) - 1
        for s in range(block_start[blk], block_start[blk + 1]):
            t = block_tris[s]
            a = faces[t, 0]
            fnx, fny, fnz = face_normal[t, 0], face_normal[t, 1], face_normal[t, 2]
            for x in range(max(tri_lo[t, 0], bx * size), min(tri_hi[t, 0], x_end) + 1):
                px = origin[0] + x * voxel
                for y in range(max(tri_lo[t, 1], by * size), min(tri_hi[t, 1], y_end) + 1):
                    py = origin[1] + y * voxel
                    for z in range(max(tri_lo[t, 2], bz * size), min(tri_hi[t, 2], z_end) + 1):
                        pz = origin[2] + z * voxel
                        v = (x * ny + y) * nz + z
                        bound = min(dist2[v], reach2)
                        h = (
                            (px - verts[a, 0]) * fnx
                            + (py - verts[a, 1]) * fny
                            + (pz - verts[a, 2]) * fnz
                        )
                        if h * h >= bound:
                            continue
                        d2 = _distance2(px, py, pz, verts, faces, t)[0]
                        if d2 < bound:
                            dist2[v] = d2
                            closest[v] = t


@kernel(parallel=True)
def _sweep_kernel(
    verts: np.ndarray,
    faces: np.ndarray,
    origin: np.ndarray,
    voxel: float,
    dims: np.ndarray,
    reach2: float,
    closest: np.ndarray,
    dist2: np.ndarray,
) -> None:
    """Give every vertex beyond the band a closest triangle: sweeps along ±x, then ±y,
    then ±z. The + sweep (in place) and the − sweep (on a copy) of an axis run as two
    parallel tasks from the same start and are merged per vertex (the nearer wins, the
    + sweep's on ties): deterministic."""
    for axis in range(3):
        back_closest = closest.copy()
        back_dist2 = dist2.copy()
        for task in prange(2):
            if task == 0:
                _sweep(verts, faces, origin, voxel, dims, reach2, axis, 1, closest, dist2)
            else:
                _sweep(
                    verts, faces, origin, voxel, dims, reach2, axis, -1, back_closest, back_dist2
                )
        for v in prange(closest.shape[0]):
            if back_dist2[v] < dist2[v]:
                closest[v] = back_closest[v]
                dist2[v] = back_dist2[v]


@kernel
def _sweep(
    verts: np.ndarray,
    faces: np.ndarray,
    origin: np.ndarray,
    voxel: float,
    dims: np.ndarray,
    reach2: float,
    axis: int,
    step: int,
    closest: np.ndarray,
    dist2: np.ndarray,
) -> None:
    """One sweep along ``axis`` in direction ``step`` (±1), slab by slab.

    Every vertex of a slab not already exact (dist2 < reach2) tries the triangles of its
    3×3 neighbours in the slab before and keeps one when it is strictly nearer: a sweep
    carries triangles through a 90° cone, and the six sweeps cover every direction.
    """
    strides = np.array([dims[1] * dims[2], dims[2], 1], dtype=np.int64)
    b = (axis + 1) % 3
    c = (axis + 2) % 3
    sa, sb, sc = strides[axis], strides[b], strides[c]
    p = np.empty(3)
    tried = np.empty(9, dtype=np.int64)
    for k in range(1, dims[axis]):
        i = k if step == 1 else dims[axis] - 1 - k
        p[axis] = origin[axis] + i * voxel
        for jb in range(dims[b]):
            p[b] = origin[b] + jb * voxel
            for jc in range(dims[c]):
                v = i * sa + jb * sb + jc * sc
                if dist2[v] < reach2:
                    continue
                p[c] = origin[c] + jc * voxel
                count = 0
                for db in range(max(jb - 1, 0), min(jb + 2, dims[b])):
                    for dc in range(max(jc - 1, 0), min(jc + 2, dims[c])):
                        t = closest[(i - step) * sa + db * sb + dc * sc]
                        if t < 0 or t == closest[v] or t in tried[:count]:
                            continue
                        tried[count] = t
                        count += 1
                        d2 = _distance2(p[0], p[1], p[2], verts, faces, t)[0]
                        if d2 < dist2[v]:
                            dist2[v] = d2
                            closest[v] = t


@kernel(parallel=True)
def _sign_kernel(
    verts: np.ndarray,
    faces: np.ndarray,
    origin: np.ndarray,
    voxel: float,
    dims: np.ndarray,
    closest: np.ndarray,
    dist2: np.ndarray,
    face_normal: np.ndarray,
    face_edge: np.ndarray,
    edge_normal: np.ndarray,
    vertex_normal: np.ndarray,
    values: np.ndarray,
) -> None:
    """±sqrt(dist2) per vertex: negative where (p − closest point) · pseudo-normal < 0.

    The closest feature follows from the zero weights of the closest point: two zeros a
    vertex, one zero the edge opposite that corner, none the face's interior.
    """
    ny, nz = dims[1], dims[2]
    for x in prange(dims[0]):
        px = origin[0] + x * voxel
        for y in range(ny):
            py = origin[1] + y * voxel
            for z in range(nz):
                pz = origin[2] + z * voxel
                v = (x * ny + y) * nz + z
                t = closest[v]
                _, wa, wb, wc = _distance2(px, py, pz, verts, faces, t)
                if wb == 0.0 and wc == 0.0:
                    n = vertex_normal[faces[t, 0]]
                elif wa == 0.0 and wc == 0.0:
                    n = vertex_normal[faces[t, 1]]
                elif wa == 0.0 and wb == 0.0:
                    n = vertex_normal[faces[t, 2]]
                elif wc == 0.0:
                    n = edge_normal[face_edge[t, 0]]
                elif wa == 0.0:
                    n = edge_normal[face_edge[t, 1]]
                elif wb == 0.0:
                    n = edge_normal[face_edge[t, 2]]
                else:
                    n = face_normal[t]
                i, j, k = faces[t, 0], faces[t, 1], faces[t, 2]
                dot = 0.0
                for e, pe in enumerate((px, py, pz)):
                    dot += (pe - (wa * verts[i, e] + wb * verts[j, e] + wc * verts[k, e])) * n[e]
                d = math.sqrt(dist2[v])
                values[v] = -d if dot < 0.0 else d
