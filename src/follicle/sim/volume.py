"""Hair-hair interaction through a voxel grid: friction and repulsion (Almeida 2014 §3.2,
Le Muzic 2012 §5.1.3).

Strands do not collide with each other one by one; the hair acts as a whole through
two fields on a regular grid (Petrovic et al. 2005, Müller et al. 2012, as in Almeida 2014 §3.2):

* density, eq. 3.2: every particle splats a trilinear "tent" weight, 1 at the particle
  falling linearly to 0 one voxel away, onto the 8 vertices of its cell:
  ``D = Σ (1 − |Px − x|/h)(1 − |Py − y|/h)(1 − |Pz − z|/h)``;
* velocity, eq. 3.3: ``V = Σ w v / D`` with the same weights (0 where D ≤ 1e-12, so
  empty space never divides).

Both sums are smoothed with box-blur passes (Le Muzic 2012 §5.1.3: each vertex becomes the mean of
its 3×3×3 neighbourhood, only neighbours inside the grid counted) before the division,
so V stays a density-weighted mean. Particle velocities are then updated:

* friction, eq. 3.4: ``v ← (1 − s_friction)·v + s_friction·v_grid(P)``, v_grid the
  trilinear interpolation of V, so strands drift with their neighbours;
* repulsion, eq. 3.5–3.7: g is the central-difference gradient of the interpolated
  density at P with radius r = h, normalised; Almeida 2014 writes ``v ← v + s·g/Δt``, but
  the push must go towards lower density (Le Muzic 2012 §5.1.3) and be independent of the grid's
  scale, so here ``v ← v − s_repulsion·ĝ·h/Δt``: s_repulsion = 1 moves a particle one
  voxel in one step. No push where |g| is ~0 (no direction to push in).

With r = h, ``D(P + h·e) − D(P − h·e)`` of the trilinear density is exactly the trilinear
interpolation at P of the vertex differences ``D[i + 1] − D[i − 1]`` (P's cell shifted by
one voxel keeps its fractions). So the gradient is computed once per vertex and
interpolated like the velocity: one lookup per particle instead of six, same values
(inside the grid; like every field here it reads 0 outside).

The grid is fitted around the particles at each call with a margin of one voxel plus one
per blur pass: the blurred sums then never reach the border, where the clamped mean would
pile density up and push the outermost hair inwards; so blurring keeps the total density
(the particle count) and a lone particle feels no push from its own density.

Particles with inverse mass 0 (by default the root, index 0, of every strand) splat like
the others, since they occupy space and carry the head's motion, but are never changed.

Splatting is parallel and deterministic: the particles are cut into a fixed number of
consecutive parts (set by their count and the grid's size, never by the thread count:
at most 8, at least 4,096 particles each, 64 MiB of grids in all), each part adds
its tent weights and momenta into its own float64 grid in particle order, and the parts'
grids are summed in part order. So the same input gives the same bytes with any number of
threads. (Fusing splat and update into the solver's kernel was measured: no faster, as
both are bound by the grid arithmetic, not by reading the hair.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..arrays import FMA, all_finite
from ..errors import InputError
from ..kernels import kernel, prange
from ..threads import threads_for
from ..validate import is_whole, number, positive, whole

__all__ = ["GridSpec", "VolumeGrid", "grid_for", "apply_volume", "volume_step"]

_MAX_CELLS = 128**3  # cap on cells in a grid (2.1 M; 68 MB of int64 sums per thread)
_MIN_VOXEL = 1e-6  # m; voxel size for a single point or a sub-micrometre cloud
_TINY_DENSITY = 1e-12  # D at or below this counts as empty: V = 0 there
_PARTS = 8  # particle parts splatted side by side, each into its own grid …
_PART_BYTES = 64 * 2**20  # … as many as fit in this (at least one) …
_PART_MIN = 4096  # … each of at least this many particles
# items per thread below which a stage keeps to fewer threads (benchmarks/sim_threads.py:
# on an idle machine two threads pay from ~2,000 particles, but with the cores shared a
# parallel region waits for a descheduled thread: the small scene's substeps ran 3× slower
# on two threads than on one; so a thread gets at least this much work)
PARTICLE_GRAIN = 20_000  # the particle kernels: bounds, splat, update
CELL_GRAIN = 50_000  # the grid passes: part sums, blur


@dataclass(frozen=True, eq=False)
class GridSpec:
    """Where the grid is: vertex (i, j, k) lies at ``origin + voxel·(i, j, k)``."""

    origin: np.ndarray  # (3,) float64, world position of vertex (0, 0, 0)
    voxel: float  # voxel size h in metres
    shape: tuple[int, int, int]  # vertices along x, y, z

    def __post_init__(self) -> None:
        origin = np.array(self.origin, dtype=np.float64)
        if origin.shape != (3,) or not np.isfinite(origin).all():
            raise InputError(f"origin: expected 3 finite numbers, got {self.origin!r}")
        voxel = positive(self.voxel, "voxel", unit="m")
        shape = tuple(self.shape)
        if len(shape) != 3 or not all(is_whole(n) and n >= 2 for n in shape):
            raise InputError(f"shape: expected 3 vertex counts >= 2, got {self.shape!r}")
        origin.setflags(write=False)
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "voxel", voxel)
        object.__setattr__(self, "shape", tuple(int(n) for n in shape))


def grid_for(
    points: np.ndarray, resolution: int = 32, voxel_size: float | None = None, margin: int = 1
) -> GridSpec:
    """A grid around ``points`` (..., 3), at least ``margin`` voxels clear on every side.

    The voxel size is ``voxel_size`` when given, else the longest side of the points'
    bounds divided by ``resolution`` (so that many cells span it, plus the margins). Axes
    of zero extent still get one cell (plus margins); a single point gets 1 µm voxels.
    The voxel grows when needed to keep at most 128³ cells. The grid is centred on the
    bounds, so a symmetric cloud gets a symmetric grid.
    """
    pts = _points(points, "points")
    _check_resolution(resolution, voxel_size)
    return _fitted(pts, resolution, voxel_size, whole(margin, "margin", 1))


def _fitted(pts: np.ndarray, resolution: int, voxel_size: float | None, margin: int) -> GridSpec:
    """:func:`grid_for` of validated (M, 3) points."""
    lo, hi = _bounds(pts)
    extent = hi - lo
    h = float(voxel_size) if voxel_size is not None else max(extent.max() / resolution, _MIN_VOXEL)
    cells = _cells(extent, h, margin)
    while np.prod(cells) > _MAX_CELLS:
        h *= max(float(np.cbrt(np.prod(cells) / _MAX_CELLS)), 1.01)
        cells = _cells(extent, h, margin)
    origin = (lo + hi) / 2 - h * cells / 2
    nx, ny, nz = (int(c) + 1 for c in cells)  # the vertices: one more than the cells
    return GridSpec(origin=origin, voxel=h, shape=(nx, ny, nz))


def _cells(extent: np.ndarray, h: float, margin: int) -> np.ndarray:
    """Cells per axis: enough to cover ``extent`` (at least one) plus the margin each side."""
    return np.maximum(np.ceil(extent / h), 1).astype(np.int64) + 2 * margin


@dataclass(frozen=True, eq=False)
class VolumeGrid:
    """Density, velocity and density gradient of the hair on a grid (built by ``splat``)."""

    spec: GridSpec
    density: np.ndarray  # spec.shape, float64, eq. 3.2 (blurred)
    flow: np.ndarray  # spec.shape + (6,), float64: velocity, then density gradient

    @property
    def velocity(self) -> np.ndarray:
        """spec.shape + (3,): eq. 3.3, 0 where D <= 1e-12."""
        return self.flow[..., :3]

    @property
    def gradient(self) -> np.ndarray:
        """spec.shape + (3,): (D[i+1] − D[i−1]) / 2h per axis."""
        return self.flow[..., 3:]

    @classmethod
    def splat(
        cls,
        x: np.ndarray,
        v: np.ndarray,
        spec: GridSpec | None = None,
        blur_passes: int = 1,
    ) -> VolumeGrid:
        """Splat particles ``x`` (S, N, 3) with velocities ``v`` (S, N, 3) onto a grid.

        ``spec`` None places the grid around ``x`` (``grid_for`` at its defaults, margin
        1 + ``blur_passes``); with a given spec, particles outside it add only their
        corners that fall inside. ``blur_passes`` 3×3×3 box blurs smooth the density and
        momentum sums.
        """
        xs = _strands(x, "x")
        vs = _strands(v, "v")
        if vs.shape != xs.shape:
            raise InputError(f"v: expected the shape of x {xs.shape}, got {vs.shape}")
        passes = whole(blur_passes, "blur_passes", 0)
        if spec is None:
            spec = grid_for(xs, margin=1 + passes)
        return _splat_grid(xs, vs, spec, passes)

    def sample_density(self, points: np.ndarray) -> np.ndarray:
        """Trilinearly interpolated density at ``points`` (M, 3), 0 outside the grid: (M,)."""
        return _sample_density(self.density, self.spec.origin, 1 / self.spec.voxel, _query(points))

    def sample_velocity(self, points: np.ndarray) -> np.ndarray:
        """Trilinearly interpolated grid velocity at ``points`` (M, 3), 0 outside: (M, 3)."""
        return _sample_vector(self.flow, 0, self.spec.origin, 1 / self.spec.voxel, _query(points))

    def density_gradient(self, points: np.ndarray) -> np.ndarray:
        """Density gradient at ``points`` (M, 3) by central differences, r = h (eq. 3.7)."""
        return _sample_vector(self.flow, 3, self.spec.origin, 1 / self.spec.voxel, _query(points))


def apply_volume(
    x: np.ndarray,
    v: np.ndarray,
    dt: float,
    friction: float,
    repulsion: float,
    blur_passes: int = 1,
    resolution: int = 32,
    voxel_size: float | None = None,
    inv_mass: np.ndarray | None = None,
) -> VolumeGrid:
    """Hair-hair friction and repulsion: update ``v`` in place and return the grid used.

    ``x`` (S, N, 3) positions; ``v`` (S, N, 3) C-contiguous float32 or float64
    velocities, changed in place; ``dt`` > 0 the step (s); ``friction`` in [0, 1]
    (eq. 3.4); ``repulsion`` >= 0, in voxels per step (see the module docstring);
    ``blur_passes``, ``resolution`` and ``voxel_size`` place and smooth the grid
    (``grid_for``). ``inv_mass`` (S, N): particles
    with 0 are left alone; None pins the roots (index 0 of each strand) only.
    """
    xs = _strands(x, "x")
    in_place = isinstance(v, np.ndarray) and v.dtype in (np.float32, np.float64)
    if not (in_place and v.flags.c_contiguous and v.flags.writeable):
        raise InputError(
            "v: expected a writable C-contiguous float32 or float64 array (it is updated in"
            " place); pass np.ascontiguousarray(v, dtype=np.float32) and keep that array"
        )
    if v.shape != xs.shape:
        raise InputError(f"v: expected the shape of x {xs.shape}, got {v.shape}")
    if not all_finite(v):
        raise InputError("v: contains NaN or inf; fix the velocities")
    dt = positive(dt, "dt", unit="s")
    friction = number(friction, "friction", lo=0.0, hi=1.0)
    repulsion = positive(repulsion, "repulsion", allow_zero=True)
    free = _free_mask(inv_mass, xs.shape[:2])
    passes = whole(blur_passes, "blur_passes", 0)
    _check_resolution(resolution, voxel_size)
    return volume_step(xs, v, free, dt, friction, repulsion, passes, resolution, voxel_size)


def volume_step(
    x: np.ndarray,
    v: np.ndarray,
    free: np.ndarray,
    dt: float,
    friction: float,
    repulsion: float,
    blur_passes: int,
    resolution: int,
    voxel_size: float | None = None,
) -> VolumeGrid:
    """:func:`apply_volume` without its checks, for a caller whose arrays are known
    good (the simulator, every substep: scanning a million particles for NaN and
    bounds in Python took a fifth of the volume's time): ``x``, ``v`` C-contiguous
    (S, N, 3) finite, ``free`` (S, N) bool, the numbers in range."""
    pts = x.reshape(-1, 3)
    with threads_for(len(pts), PARTICLE_GRAIN):
        spec = _fitted(pts, resolution, voxel_size, 1 + blur_passes)
    grid = _splat_grid(x, v, spec, blur_passes)
    h = spec.voxel
    with threads_for(len(pts), PARTICLE_GRAIN):
        _update(
            pts,
            v.reshape(-1, 3),
            free.reshape(-1),
            grid.flow,
            spec.origin,
            1 / h,
            friction,
            repulsion * h / dt,
        )
    return grid


# --- validation ------------------------------------------------------------------------


def _strands(a: object, name: str) -> np.ndarray:
    """(S, N, 3) finite float array as C-contiguous float32 (float64 kept as it is)."""
    arr = np.asarray(a)
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.shape[0] * arr.shape[1] == 0:
        raise InputError(
            f"{name}: expected a non-empty (strands, particles, 3) array, got shape {arr.shape}"
        )
    if not np.issubdtype(arr.dtype, np.floating):
        raise InputError(f"{name}: expected floats (float32 or float64), got {arr.dtype}")
    dtype = np.float64 if arr.dtype == np.float64 else np.float32
    out = np.ascontiguousarray(arr, dtype=dtype)
    if not all_finite(out):
        raise InputError(f"{name}: contains NaN or inf (or values beyond float32); fix them")
    return out


def _points(a: object, name: str) -> np.ndarray:
    """(..., 3) finite float array as (M, 3) C-contiguous float32 or float64, M >= 1."""
    arr = np.asarray(a)
    if arr.ndim < 1 or arr.shape[-1] != 3 or arr.size == 0:
        raise InputError(f"{name}: expected a non-empty (..., 3) array, got shape {arr.shape}")
    if not np.issubdtype(arr.dtype, np.floating):
        raise InputError(f"{name}: expected floats (float32 or float64), got {arr.dtype}")
    dtype = np.float32 if arr.dtype == np.float32 else np.float64
    out = np.ascontiguousarray(arr.reshape(-1, 3), dtype=dtype)
    if not all_finite(out):
        raise InputError(f"{name}: contains NaN or inf; fix them")
    return out


def _query(points: object) -> np.ndarray:
    """Query points for the samplers as (M, 3) float64 (one compiled sampler per field)."""
    return _points(points, "points").astype(np.float64, copy=False)


def _check_resolution(resolution: object, voxel_size: object) -> None:
    """``resolution`` (cells along the longest side) an integer >= 2; ``voxel_size`` None
    or a finite size > 0."""
    whole(resolution, "resolution", 2)
    if voxel_size is not None:
        positive(voxel_size, "voxel_size", unit="m")


def _free_mask(inv_mass: object, shape: tuple[int, int]) -> np.ndarray:
    """(S, N) bool: True where the particle may move (inverse mass > 0)."""
    if inv_mass is None:
        free = np.ones(shape, dtype=np.bool_)
        free[:, 0] = False
        return free
    im = np.asarray(inv_mass)
    if im.shape != shape or not np.issubdtype(im.dtype, np.floating):
        raise InputError(
            f"inv_mass: expected a float array of shape {shape}, got {im.dtype} {im.shape}"
        )
    if not np.isfinite(im).all() or (im < 0).any():
        raise InputError("inv_mass: must be finite and >= 0 (0 pins a particle)")
    return im != 0


def _splat_grid(x: np.ndarray, v: np.ndarray, spec: GridSpec, blur_passes: int) -> VolumeGrid:
    """Splat validated (S, N, 3) float32 arrays onto ``spec`` and blur: the VolumeGrid."""
    if not isinstance(spec, GridSpec):
        raise InputError(f"spec: expected a GridSpec (see grid_for), got {type(spec).__name__}")
    cells = int(np.prod(spec.shape))
    parts = max(1, min(_PARTS, _PART_BYTES // (32 * cells), x.size // (3 * _PART_MIN)))
    grids = np.zeros((parts, *spec.shape, 4))
    with threads_for(x.size // 3, PARTICLE_GRAIN):
        _splat(x.reshape(-1, 3), v.reshape(-1, 3), grids, spec.origin, 1 / spec.voxel)
    with threads_for(cells, CELL_GRAIN):
        sums = _part_sums(grids)
        for _ in range(blur_passes):
            sums = _box_blur(sums)
    density, flow = _resolve(sums, spec.voxel)
    return VolumeGrid(spec=spec, density=density, flow=flow)


# --- kernels ---------------------------------------------------------------------------


@kernel(parallel=True)
def _bounds_kernel(pts, lo, hi):
    """Per chunk of points, the smallest and largest coordinate on each axis."""
    m = pts.shape[0]
    for c in prange(lo.shape[0]):
        a = c * m // lo.shape[0]
        b = (c + 1) * m // lo.shape[0]
        for ax in range(3):
            lo[c, ax] = np.inf
            hi[c, ax] = -np.inf
        for p in range(a, b):
            for ax in range(3):
                value = pts[p, ax]
                lo[c, ax] = min(lo[c, ax], value)
                hi[c, ax] = max(hi[c, ax], value)


def _bounds(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bounds (lo, hi) of finite (M, 3) points, M ≥ 1, as float64, in one parallel pass."""
    chunks = max(1, min(64, len(pts) // 4096))
    lo = np.empty((chunks, 3))
    hi = np.empty((chunks, 3))
    _bounds_kernel(pts, lo, hi)
    return lo.min(axis=0), hi.max(axis=0)


@kernel
def _locate(px, py, pz, origin, inv_h, nx, ny, nz):
    """Cell (i, j, k) holding the point and its fractions (tx, ty, tz) in [0, 1).

    Grid coordinates are clamped to [-2, n + 1] first: far-away points stay far outside
    (all corners off the grid) without overflowing the integer conversion.
    """
    fx = min(max((px - origin[0]) * inv_h, -2.0), nx + 1.0)
    fy = min(max((py - origin[1]) * inv_h, -2.0), ny + 1.0)
    fz = min(max((pz - origin[2]) * inv_h, -2.0), nz + 1.0)
    ix = math.floor(fx)
    iy = math.floor(fy)
    iz = math.floor(fz)
    return ix, iy, iz, fx - ix, fy - iy, fz - iz


@kernel
def _corner(cell, c, nx, ny, nz):
    """Corner ``c`` (0..7, bits x, y, z) of a cell: vertex (i, j, k) and tent weight.

    A corner off the grid has weight 0 (and index 0, safe to read).
    """
    ix, iy, iz, tx, ty, tz = cell
    dx = c & 1
    dy = (c >> 1) & 1
    dz = c >> 2
    i = ix + dx
    j = iy + dy
    k = iz + dz
    if i < 0 or j < 0 or k < 0 or i >= nx or j >= ny or k >= nz:
        return 0, 0, 0, 0.0
    w = (tx if dx else 1.0 - tx) * (ty if dy else 1.0 - ty) * (tz if dz else 1.0 - tz)
    return i, j, k, w


@kernel(inline="always")
def _cell(px, py, pz, origin, inv_h, nx, ny, nz):
    """Cell (i, j, k) and fractions of a point, both clamped into the grid: a point a
    little outside (the solver's grid is placed a substep earlier) reads the border."""
    fx = (px - origin[0]) * inv_h
    fy = (py - origin[1]) * inv_h
    fz = (pz - origin[2]) * inv_h
    ix = min(max(int(fx), 0), nx - 2)
    iy = min(max(int(fy), 0), ny - 2)
    iz = min(max(int(fz), 0), nz - 2)
    return (
        ix,
        iy,
        iz,
        min(max(fx - ix, 0.0), 1.0),
        min(max(fy - iy, 0.0), 1.0),
        min(max(fz - iz, 0.0), 1.0),
    )


@kernel(inline="always")
def _add(cell, w, vx, vy, vz):
    cell[0] += w
    cell[1] += w * vx
    cell[2] += w * vy
    cell[3] += w * vz


@kernel(inline="always")
def _splat_point(grid, origin, inv_h, px, py, pz, vx, vy, vz):
    """Add a particle's tent weight and momentum (eq. 3.2, 3.3) to the sums ``grid``
    (nx, ny, nz, 4); corners off the grid are left out."""
    nx, ny, nz = grid.shape[0], grid.shape[1], grid.shape[2]
    fx = (px - origin[0]) * inv_h
    fy = (py - origin[1]) * inv_h
    fz = (pz - origin[2]) * inv_h
    if 0.0 <= fx < nx - 1 and 0.0 <= fy < ny - 1 and 0.0 <= fz < nz - 1:
        ix, iy, iz = int(fx), int(fy), int(fz)
        tx, ty, tz = fx - ix, fy - iy, fz - iz
        for a in range(2):
            wa = tx if a else 1.0 - tx
            for b in range(2):
                wab = wa * (ty if b else 1.0 - ty)
                for c in range(2):
                    _add(grid[ix + a, iy + b, iz + c], wab * (tz if c else 1.0 - tz), vx, vy, vz)
    elif -1.0 < fx < nx and -1.0 < fy < ny and -1.0 < fz < nz:  # on the border
        cell = _locate(px, py, pz, origin, inv_h, nx, ny, nz)
        for c in range(8):
            i, j, k, w = _corner(cell, c, nx, ny, nz)
            if w > 0.0:
                _add(grid[i, j, k], w, vx, vy, vz)


@kernel(parallel=True, error_model="numpy", fastmath=FMA)
def _splat(x, v, grids, origin, inv_h):
    """Splat particles (M, 3) into the sums ``grids`` (P, nx, ny, nz, 4) of [w, w·vx,
    w·vy, w·vz] (eq. 3.2, numerator of 3.3): part k, the k-th of P consecutive runs of
    particles, into grid k, in particle order."""
    m, parts = x.shape[0], grids.shape[0]
    for k in prange(parts):
        grid = grids[k]
        for p in range(k * m // parts, (k + 1) * m // parts):
            _splat_point(grid, origin, inv_h, x[p, 0], x[p, 1], x[p, 2], v[p, 0], v[p, 1], v[p, 2])


@kernel(parallel=True)
def _part_sums(grids):
    """The parts' sums (P, nx, ny, nz, 4) added in part order: (nx, ny, nz, 4)."""
    flat = grids.reshape(grids.shape[0], -1)
    out = np.empty(flat.shape[1])
    for e in prange(flat.shape[1]):
        total = 0.0
        for k in range(flat.shape[0]):
            total += flat[k, e]
        out[e] = total
    return out.reshape(grids.shape[1:])


@kernel(parallel=True, error_model="numpy")
def _box_blur(src):
    """One box-blur pass: each vertex the mean of its 3×3×3 neighbours inside the grid.

    The neighbourhood and its count factor per axis, so this is three 1-D means of up to
    three values (9 reads per vertex instead of 27).
    """
    nx, ny, nz, nc = src.shape
    a = np.empty_like(src)
    b = np.empty_like(src)
    for i in prange(nx):  # along x: src → a
        i0, i1 = max(i - 1, 0), min(i + 1, nx - 1)
        for j in range(ny):
            for k in range(nz):
                for ch in range(nc):
                    s = 0.0
                    for q in range(i0, i1 + 1):
                        s += src[q, j, k, ch]
                    a[i, j, k, ch] = s / (i1 - i0 + 1)
    for i in prange(nx):  # along y: a → b
        for j in range(ny):
            j0, j1 = max(j - 1, 0), min(j + 1, ny - 1)
            for k in range(nz):
                for ch in range(nc):
                    s = 0.0
                    for q in range(j0, j1 + 1):
                        s += a[i, q, k, ch]
                    b[i, j, k, ch] = s / (j1 - j0 + 1)
    for i in prange(nx):  # along z: b → a
        for j in range(ny):
            for k in range(nz):
                k0, k1 = max(k - 1, 0), min(k + 1, nz - 1)
                for ch in range(nc):
                    s = 0.0
                    for q in range(k0, k1 + 1):
                        s += b[i, j, q, ch]
                    a[i, j, k, ch] = s / (k1 - k0 + 1)
    return a


@kernel
def _resolve(sums, h):
    """Density and flow: velocity (eq. 3.3; 0 where D <= 1e-12), then the vertex density
    gradient.

    The gradient is (D[i + 1] − D[i − 1]) / 2h along each axis, D = 0 off the grid.
    """
    nx, ny, nz, _ = sums.shape
    density = np.ascontiguousarray(sums[..., 0])
    flow = np.zeros((nx, ny, nz, 6))
    inv_2h = 0.5 / h
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                d = density[i, j, k]
                if d > _TINY_DENSITY:
                    for a in range(3):
                        flow[i, j, k, a] = sums[i, j, k, a + 1] / d
                up = density[i + 1, j, k] if i + 1 < nx else 0.0
                down = density[i - 1, j, k] if i > 0 else 0.0
                flow[i, j, k, 3] = (up - down) * inv_2h
                up = density[i, j + 1, k] if j + 1 < ny else 0.0
                down = density[i, j - 1, k] if j > 0 else 0.0
                flow[i, j, k, 4] = (up - down) * inv_2h
                up = density[i, j, k + 1] if k + 1 < nz else 0.0
                down = density[i, j, k - 1] if k > 0 else 0.0
                flow[i, j, k, 5] = (up - down) * inv_2h
    return density, flow


@kernel
def _density_at(density, origin, inv_h, px, py, pz):
    """Trilinear density at a point (0 outside the grid)."""
    nx, ny, nz = density.shape
    cell = _locate(px, py, pz, origin, inv_h, nx, ny, nz)
    d = 0.0
    for c in range(8):
        i, j, k, w = _corner(cell, c, nx, ny, nz)
        d += w * density[i, j, k]
    return d


@kernel
def _vector_at(field, at, origin, inv_h, px, py, pz):
    """Trilinear value of channels at … at + 2 of a vertex field at a point (0 outside)."""
    nx, ny, nz, _ = field.shape
    cell = _locate(px, py, pz, origin, inv_h, nx, ny, nz)
    fx = fy = fz = 0.0
    for c in range(8):
        i, j, k, w = _corner(cell, c, nx, ny, nz)
        fx += w * field[i, j, k, at]
        fy += w * field[i, j, k, at + 1]
        fz += w * field[i, j, k, at + 2]
    return fx, fy, fz


@kernel
def _sample_density(density, origin, inv_h, pts):
    """``_density_at`` for each row of ``pts`` (M, 3)."""
    out = np.empty(pts.shape[0])
    for p in range(pts.shape[0]):
        out[p] = _density_at(density, origin, inv_h, pts[p, 0], pts[p, 1], pts[p, 2])
    return out


@kernel
def _sample_vector(field, at, origin, inv_h, pts):
    """``_vector_at`` for each row of ``pts`` (M, 3)."""
    out = np.empty((pts.shape[0], 3))
    for p in range(pts.shape[0]):
        out[p, 0], out[p, 1], out[p, 2] = _vector_at(
            field, at, origin, inv_h, pts[p, 0], pts[p, 1], pts[p, 2]
        )
    return out


@kernel(inline="always")
def _exchange(flow, origin, inv_h, px, py, pz, vx, vy, vz, friction, push):
    """A particle's velocity after friction (eq. 3.4) and repulsion (eq. 3.5–3.7,
    ``push`` = s_repulsion·h/dt) with the hair around it (``flow`` (nx, ny, nz, 6)).

    Terms with a zero coefficient are skipped, so they leave v bit for bit unchanged.
    """
    nx, ny, nz = flow.shape[0], flow.shape[1], flow.shape[2]
    ix, iy, iz, tx, ty, tz = _cell(px, py, pz, origin, inv_h, nx, ny, nz)
    gx = gy = gz = dx = dy = dz = 0.0
    for a in range(2):
        wa = tx if a else 1.0 - tx
        for b in range(2):
            wab = wa * (ty if b else 1.0 - ty)
            for c in range(2):
                w = wab * (tz if c else 1.0 - tz)
                f = flow[ix + a, iy + b, iz + c]
                gx += w * f[0]
                gy += w * f[1]
                gz += w * f[2]
                dx += w * f[3]
                dy += w * f[4]
                dz += w * f[5]
    if friction > 0.0:
        vx = (1.0 - friction) * vx + friction * gx
        vy = (1.0 - friction) * vy + friction * gy
        vz = (1.0 - friction) * vz + friction * gz
    if push > 0.0:
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        if norm > _TINY_DENSITY * inv_h:  # |D(P + h·e) − D(P − h·e)| ~ 0: no direction
            vx -= push * dx / norm
            vy -= push * dy / norm
            vz -= push * dz / norm
    return vx, vy, vz


@kernel(parallel=True, error_model="numpy", fastmath=FMA)
def _update(x, v, free, flow, origin, inv_h, friction, push):
    """:func:`_exchange` for every free particle of ``x``, ``v`` (M, 3), in place."""
    for p in prange(x.shape[0]):
        if free[p]:
            v[p, 0], v[p, 1], v[p, 2] = _exchange(
                flow,
                origin,
                inv_h,
                x[p, 0],
                x[p, 1],
                x[p, 2],
                float(v[p, 0]),
                float(v[p, 1]),
                float(v[p, 2]),
                friction,
                push,
            )
