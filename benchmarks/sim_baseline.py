"""The dynamics benchmark's baseline: PBD hair in plain NumPy, no numba, no follicle kernels.

One substep of the same constraints as follicle's PBD solver (Verlet under gravity with
damping; even/odd distance constraints, bending to the static point, local and global
shape matching, skin SDF collision, every ``iterations`` times; the two-sided strain
limit; a last collision pass; velocities with the limit's correction and friction at
contacts; then hair-hair friction and repulsion through a voxel grid), written as a
competent NumPy user would: vectorised over all strands at once, with Python loops only
over the iterations, the two segment parities and the vertex index where the algorithm
is sequential root to tip (local shape, strain limit). follicle's settle pass, which
hangs back at length the few segments the last collision pass put off it, is left out:
on the benchmark's scene it costs the baseline nothing, so the ratio only flatters it.
The hold of styled strands (``shape_hold``) is not in it either: compare it with
``shape_hold = 0`` (benchmarks/sim.py does).
Positions and velocities are kept component-major,
(3, N, S), so every vertex slice is contiguous along the strands; buffers are allocated
once, updates are in-place ufuncs, SDF normals are computed only for the vertices within
the margin, the grid is splatted with ``np.bincount``. follicle supplies only the inputs
(Model, SimParams, the SDF's grid) and ``grid_for`` to place the volume grid.

Time it in its own process, or well after any numba work: numba's idle worker threads
keep spinning for a while after a parallel kernel, and on a small machine they slow
NumPy down (BLAS calls most, so there are none here). Run alone:
``.venv/bin/python benchmarks/sim_baseline.py``.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Sequence

import numpy as np
import trimesh

from follicle.curves import HairCurves
from follicle.mesh.sdf import SDF
from follicle.scene import SimParams
from follicle.sim.model import Model
from follicle.sim.volume import grid_for

_TINY = 1e-12  # shorter segments and distances are skipped; emptier grid vertices hold V = 0
_BLUR_PASSES = 1
_RESOLUTION = 32
# the 8 corners of a grid cell, bits x, y, z
_CORNERS = [(c & 1, (c >> 1) & 1, c >> 2) for c in range(8)]


class BaselinePBD:
    """NumPy PBD of the benchmark's constraint set, one substep at a time."""

    def __init__(
        self,
        model: Model,
        params: SimParams,
        sdf: SDF | None = None,
        volume: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        """``params`` a SimParams (Verlet, PBD, no wind or cone); ``volume`` the hair-hair
        (friction, repulsion); ``sdf`` the skin, None for no collisions."""
        p = params
        s, n = model.strands, model.vertices
        it = p.iterations
        self.params = p
        self.volume = (float(volume[0]), float(volume[1]))
        self.times: dict[str, float] = {}  # seconds per phase, summed over substeps
        w = np.ascontiguousarray(model.inv_mass.T, dtype=np.float64)  # (N, S)
        self._free = w > 0.0
        self._freef = self._free.astype(np.float64)
        self._local = np.ascontiguousarray(model.rest_local.transpose(2, 1, 0), np.float64)
        self._static_local = np.ascontiguousarray(model.static_local.T, np.float64)  # (3, S)
        rest = np.ascontiguousarray(model.rest_length.T, np.float64)  # (N − 1, S)

        # distances: per parity the segments' vertex slices, each end's share of the
        # correction k'·w/(wi + wj) (0 where both are pinned) and the rest lengths
        k = _linearised(p.stretch_stiffness, it)
        total = w[:-1] + w[1:]
        share = np.divide(k, total, out=np.zeros_like(total), where=total > 0.0)
        self._pairs = []
        for parity in (0, 1):
            i, j = slice(parity, n - 1, 2), slice(parity + 1, n, 2)
            self._pairs.append(
                (i, j, share[parity::2] * w[i], share[parity::2] * w[j], rest[parity::2])
            )
        m = n // 2  # segments of parity 0, the larger batch
        self._seg = np.empty((3, m, s))
        self._seg_move = np.empty((3, m, s))
        self._seg_len = np.empty((m, s))
        self._seg_ok = np.empty((m, s), dtype=bool)

        # bending of vertices 2 … N−1: coefficient k'/(1 + att·(i − 1)) (0 when pinned)
        kb = _linearised(p.bend_stiffness, it)
        self._bend = kb > 0.0 and n > 2
        att = 1.0 + p.bend_attenuation * np.arange(1, n - 1, dtype=np.float64)
        self._bend_k = (kb / att)[:, None] * self._freef[2:]
        self._bend_rest = p.bend_scale * np.ascontiguousarray(model.bend_rest[:, 2:].T, np.float64)
        self._radial = np.empty((3, max(n - 2, 0), s))
        self._radial_len = np.empty((max(n - 2, 0), s))
        self._radial_ok = np.empty((max(n - 2, 0), s), dtype=bool)

        # shape matching: local stiffness per vertex, global profile per vertex
        self._k_local = _linearised(p.shape_local, it) * self._freef  # (N, S)
        self._shape_local = p.shape_local > 0.0
        t = np.linspace(0.0, 1.0, n)
        start, end = p.shape_global_range
        fade = np.clip((end - t) / max(end - start, 1e-9), 0.0, 1.0)
        profile = _linearised(p.shape_global * np.where(t <= start, 1.0, fade), it)
        self._k_global = profile[:, None] * self._freef  # (N, S)
        self._shape_global = bool((self._k_global[1:] > 0.0).any())

        # strain limit: the longest and shortest each segment may get
        limit = p.stretch_limit
        self._most = None if limit is None else (1.0 + 0.5 * limit) * rest
        self._least = None if limit is None else (1.0 - 0.5 * limit) * rest

        # per-substep state and scratch, (3, N, S) unless noted
        shape = (3, n, s)
        self._x = np.empty(shape)
        self._v = np.empty(shape)
        self._x_old = np.empty(shape)
        self._tmp = np.empty(shape)
        self._target = np.empty(shape)  # skinned rest pose
        self._rest_seg = np.empty((3, n - 1, s))  # target[i + 1] − target[i]
        self._rest_dir = np.empty((3, n - 1, s))  # the same, unit
        self._rest_ok = np.empty((n - 1, s), dtype=bool)  # … where not degenerate
        self._corr = np.zeros(shape)  # the strain limit's moves
        self._static = np.empty((3, s))
        self._row = [np.empty((3, s)) for _ in range(5)]  # vertex-row scratch
        self._line = [np.empty(s) for _ in range(4)]
        self._line_ok = np.empty(s, dtype=bool)
        self._contact_idx = np.zeros(0, dtype=np.intp)
        self._contact_n = np.zeros((3, 0))
        self._sdf = None if sdf is None else _SDFSampler(sdf, n * s)
        self._grid = None if max(self.volume) <= 0.0 else _VolumeGrid(n * s)

    # ------------------------------------------------------------------ substep
    def substep(
        self, x: np.ndarray, v: np.ndarray, roots: np.ndarray, frames: np.ndarray, dt: float
    ) -> None:
        """Advance ``x``, ``v`` (S, N, 3) float64 by ``dt`` seconds in place, the roots
        pinned at ``roots`` (S, 3) with ``frames`` (S, 3, 3) rows tangent, binormal, normal."""
        clock = _Clock(self.times)
        np.copyto(self._x, x.transpose(2, 1, 0))
        np.copyto(self._v, v.transpose(2, 1, 0))
        self._integrate(roots, frames, dt)
        clock("integrate")
        for _ in range(self.params.iterations):
            self._constraints()
            clock("constraints")
            self._collide(record=False)
            clock("collision")
        if self._most is not None:
            self._strain_limit()
        clock("strain")
        self._collide(record=True)
        clock("collision")
        self._velocities(dt)
        np.copyto(x, self._x.transpose(2, 1, 0))
        clock("integrate")
        if self._grid is not None:
            self._grid.apply(self._x, self._v, self._freef, dt, *self.volume)
        np.copyto(v, self._v.transpose(2, 1, 0))
        clock("volume")

    def _integrate(self, roots: np.ndarray, frames: np.ndarray, dt: float) -> None:
        """Steps 1–3: pin the roots, Verlet for free vertices, the skinned rest pose."""
        p, x, v, tmp = self.params, self._x, self._v, self._tmp
        np.copyto(self._x_old, x)
        r = roots.T
        np.subtract(r, x[:, 0], out=v[:, 0])
        v[:, 0] /= dt
        x[:, 0] = r
        np.multiply(v, dt * math.exp(-p.damping * dt), out=tmp)
        tmp += (np.asarray(p.gravity, np.float64) * dt * dt)[:, None, None]
        tmp *= self._freef
        x += tmp
        np.einsum("bs,sba->as", self._static_local, frames, out=self._static)
        self._static += r
        if not (self._shape_local or self._shape_global):
            return
        # target[a] = root[a] + Σ_b local[b]·frame[b, a]
        target, local, scratch = self._target, self._local, self._tmp[0]
        for a in range(3):
            np.multiply(local[0], frames[:, 0, a], out=target[a])
            for b in (1, 2):
                np.multiply(local[b], frames[:, b, a], out=scratch)
                target[a] += scratch
            target[a] += roots[:, a]
        if self._shape_local:
            np.subtract(target[:, 1:], target[:, :-1], out=self._rest_seg)
            length = np.sqrt(np.einsum("ais,ais->is", self._rest_seg, self._rest_seg))
            np.greater_equal(length, _TINY, out=self._rest_ok)
            np.divide(1.0, length, out=length, where=self._rest_ok)
            np.multiply(self._rest_seg, length, out=self._rest_dir)

    def _constraints(self) -> None:
        """Step 4 a–d: distances (even, odd), bending, local shape, global shape."""
        for pair in self._pairs:
            self._distance(*pair)
        if self._bend:
            self._bending()
        if self._shape_local:
            self._local_shape()
        if self._shape_global:
            x, tmp = self._x, self._tmp
            np.subtract(self._target, x, out=tmp)
            tmp *= self._k_global
            x += tmp

    def _distance(
        self, i: slice, j: slice, share_i: np.ndarray, share_j: np.ndarray, rest: np.ndarray
    ) -> None:
        """One parity's segments at once: x[i] += wi·c·d, x[j] −= wj·c·d."""
        x = self._x
        m = rest.shape[0]
        d, length, ok = self._seg[:, :m], self._seg_len[:m], self._seg_ok[:m]
        np.subtract(x[:, j], x[:, i], out=d)
        np.einsum("ams,ams->ms", d, d, out=length)
        np.sqrt(length, out=length)
        np.greater_equal(length, _TINY, out=ok)
        # c·L = k'·(1 − rest/L)/(wi + wj): rest/L := 1 where the segment is degenerate
        np.divide(rest, length, out=length, where=ok)
        np.copyto(length, 1.0, where=~ok)
        np.subtract(1.0, length, out=length)
        d *= length
        move = self._seg_move[:, :m]
        np.multiply(d, share_i, out=move)
        x[:, i] += move
        np.multiply(d, share_j, out=move)
        x[:, j] -= move

    def _bending(self) -> None:
        """Vertices 2 … N−1 pulled to scale × their rest distance from the static point."""
        x = self._x
        d, length, ok = self._radial, self._radial_len, self._radial_ok
        np.subtract(x[:, 2:], self._static[:, None, :], out=d)
        np.einsum("ams,ams->ms", d, d, out=length)
        np.sqrt(length, out=length)
        np.greater_equal(length, _TINY, out=ok)
        np.divide(self._bend_rest, length, out=length, where=ok)
        np.copyto(length, 1.0, where=~ok)
        np.subtract(1.0, length, out=length)
        length *= self._bend_k
        d *= length
        x[:, 2:] -= d

    def _local_shape(self) -> None:
        """Root to tip: vertex i+1 towards x[i] + rest segment i turned by the smallest
        rotation taking rest segment i−1 to the current segment i−1."""
        x, k = self._x, self._k_local
        b, vec, vr, vvr, step = self._row
        lc, c, f, gain = self._line
        ok = self._line_ok
        for i in range(x.shape[1] - 1):
            j = i + 1
            r = self._rest_seg[:, i]
            if i == 0:  # the first segment follows the root frame
                np.add(x[:, 0], r, out=step)
                step -= x[:, 1]
                step *= k[1]
                x[:, 1] += step
                continue
            a = self._rest_dir[:, i - 1]
            np.subtract(x[:, i], x[:, i - 1], out=b)
            np.einsum("as,as->s", b, b, out=lc)
            np.sqrt(lc, out=lc)
            np.greater_equal(lc, _TINY, out=ok)  # skip degenerate segments, current or rest
            ok &= self._rest_ok[i - 1]
            np.divide(b, lc, out=b, where=ok)
            np.multiply(ok, k[j], out=gain)
            # Rodrigues with v = a × b, c = a·b: r' = r + v×r + v×(v×r)/(1 + c)
            _cross(a, b, vec)
            np.einsum("as,as->s", a, b, out=c)
            np.greater(c, -1.0 + 1e-9, out=ok)  # opposite: no unique rotation, leave r
            np.add(c, 1.0, out=f)
            np.divide(1.0, f, out=f, where=ok)
            np.copyto(f, 0.0, where=~ok)
            vec *= ok
            _cross(vec, r, vr)
            _cross(vec, vr, vvr)
            vvr *= f
            np.add(x[:, i], r, out=step)
            step += vr
            step += vvr
            step -= x[:, j]
            step *= gain
            x[:, j] += step

    def _collide(self, record: bool) -> None:
        """Free vertices closer to the skin than the margin pushed out along its normal;
        with ``record``, the contacts (vertex, normal) kept for the velocity update."""
        if self._sdf is None:
            return
        x = self._x.reshape(3, -1)
        depth = self._sdf.distances(x)
        np.subtract(self.params.collision_margin, depth, out=depth)
        np.maximum(depth, 0.0, out=depth)
        depth *= self._freef.reshape(-1)
        idx = np.flatnonzero(depth)  # d < margin: few vertices, their normals only
        normal = self._sdf.normals(idx)
        x[:, idx] += depth[idx] * normal
        if record:
            keep = np.einsum("ak,ak->k", normal, normal) > 0.0  # no normal: no contact
            self._contact_idx, self._contact_n = idx[keep], normal[:, keep]

    def _strain_limit(self) -> None:
        """Step 5, root to tip: a segment outside (1 ± limit/2)·rest is brought to that
        bound by moving its child (a segment shorter than 1e-12 m has no direction and
        stays); the moves are kept for the velocity update."""
        x, corr, most, least = self._x, self._corr, self._most, self._least
        d = self._row[0]
        length, f, g = self._line[0], self._line[1], self._line[2]
        short = self._line_ok
        free = self._freef
        for i in range(1, x.shape[1]):
            np.subtract(x[:, i], x[:, i - 1], out=d)
            np.einsum("as,as->s", d, d, out=length)
            np.sqrt(length, out=length)
            with np.errstate(divide="ignore", invalid="ignore"):
                np.divide(most[i - 1], length, out=f)
                np.divide(least[i - 1], length, out=g)
            np.fmin(f, 1.0, out=f)  # L ≤ most (or 0/0): no move
            np.less(length, least[i - 1], out=short)
            short &= length > _TINY
            np.copyto(f, g, where=short)  # too short: out to least
            f -= 1.0
            f *= free[i]
            np.multiply(d, f, out=corr[:, i])
            x[:, i] += corr[:, i]

    def _velocities(self, dt: float) -> None:
        """Step 7: v = move / dt − s·(the child's limit move) / dt, then no inward speed
        and friction at contacts; pinned vertices keep theirs."""
        p, tmp = self.params, self._tmp
        np.subtract(self._x, self._x_old, out=tmp)
        tmp *= 1.0 / dt
        if self._most is not None:
            tmp[:, :-1] -= (p.stretch_limit_damping / dt) * self._corr[:, 1:]
        idx, n = self._contact_idx, self._contact_n
        if idx.size:
            flat = tmp.reshape(3, -1)
            vel = flat[:, idx]
            vn = np.einsum("ak,ak->k", vel, n)
            vel -= vn * n
            vel *= 1.0 - p.friction
            vel += np.maximum(vn, 0.0) * n
            flat[:, idx] = vel
        np.copyto(self._v, tmp, where=self._free)


# ------------------------------------------------------------------ skin SDF
class _SDFSampler:
    """``follicle.mesh.sdf.sdf_sample`` for many points at once: the trilinear distance
    (outside the grid box: the box distance plus |value| at the nearest grid point) for
    all points, the normal (the normalised gradient of that) only for the few asked for."""

    def __init__(self, sdf: SDF, count: int) -> None:
        rot, move = sdf.transform[:3, :3], sdf.transform[:3, 3]
        local_from_world = np.eye(4)
        local_from_world[:3, :3] = rot.T
        local_from_world[:3, 3] = -rot.T @ move
        inv_voxel = 1.0 / sdf.voxel
        self._voxel = sdf.voxel
        self._inv_voxel = inv_voxel
        # grid coordinates u = A·p + b (voxels); normals back to the world by Rᵀ
        self._a = local_from_world[:3, :3] * inv_voxel
        self._b = ((local_from_world[:3, 3] - sdf.origin) * inv_voxel)[:, None]
        self._to_world = np.ascontiguousarray(local_from_world[:3, :3].T)
        dims = np.array(sdf.values.shape)
        self._top = (dims - 1.0)[:, None]
        self._cell_top = (dims - 2)[:, None]
        sy, sz = int(dims[1]), int(dims[2])
        self._stride = (sy * sz, sz)
        self._offsets = [dx * sy * sz + dy * sz + dz for dx, dy, dz in _CORNERS]
        self._values = sdf.values.astype(np.float64).ravel()
        # kept from the last distances() for normals(): corner values, fractions, box offsets
        self._corner = np.empty((8, count))
        self._frac = np.empty((3, count))
        self._e = np.empty((3, count))
        self._cell = np.empty((3, count), dtype=np.intp)
        self._flat = np.empty(count, dtype=np.intp)
        self._index = np.empty(count, dtype=np.intp)
        self._dz = np.empty((4, count))
        self._cz = np.empty((4, count))
        self._d = np.empty(count)
        self._t = [np.empty(count) for _ in range(2)]
        self._mask = [np.empty(count, dtype=bool) for _ in range(2)]

    def distances(self, points: np.ndarray) -> np.ndarray:
        """Signed distances (M,) at world ``points`` (3, M): a buffer, overwritten by the
        next call."""
        e, frac, cell, index, d = self._e, self._frac, self._cell, self._index, self._d
        t0, t1 = self._t
        _rotate(self._a, points, e, t0)
        e += self._b  # grid coordinates, in voxels
        np.clip(e, 0.0, self._top, out=frac)  # the nearest point of the grid box
        e -= frac  # the offset from the box, 0 inside
        np.copyto(cell, frac, casting="unsafe")  # >= 0: truncation is floor
        np.minimum(cell, self._cell_top, out=cell)
        frac -= cell  # the fractions in the cell
        flat = self._flat
        np.multiply(cell[0], self._stride[0], out=flat)
        np.multiply(cell[1], self._stride[1], out=index)
        flat += index
        flat += cell[2]
        for k, off in enumerate(self._offsets):
            np.add(flat, off, out=index)
            np.take(self._values, index, out=self._corner[k], mode="clip")
        # along z (corners 0 … 3: bits x, y at z = 0), then y, then x
        v, dz, cz = self._corner, self._dz, self._cz
        np.subtract(v[4:], v[:4], out=dz)
        np.multiply(dz, frac[2], out=cz)
        cz += v[:4]  # c00, c10, c01, c11
        np.subtract(cz[2], cz[0], out=t0)
        t0 *= frac[1]
        t0 += cz[0]  # c0
        np.subtract(cz[3], cz[1], out=t1)
        t1 *= frac[1]
        t1 += cz[1]  # c1
        np.subtract(t1, t0, out=d)
        d *= frac[0]
        d += t0
        # outside the box: |box offset| + |d|
        np.einsum("am,am->m", e, e, out=t0)
        outside, negative = self._mask
        np.greater(t0, 0.0, out=outside)
        if outside.any():
            np.less(d, 0.0, out=negative)
            negative &= outside
            np.negative(d, out=d, where=negative)
            np.sqrt(t0, out=t0)
            t0 *= self._voxel
            d += t0
        return d

    def normals(self, idx: np.ndarray) -> np.ndarray:
        """Unit outward world normals (3, K) at the points ``idx`` (K,) of the last
        :meth:`distances`: the normalised gradient of the trilinear interpolant (outside
        the box, of the sum; the box offset's axes follow it); zero where it vanishes."""
        v = self._corner[:, idx]
        fx, fy, fz = self._frac[:, idx]
        e = self._e[:, idx]
        dz = v[4:] - v[:4]
        c00, c10, c01, c11 = v[:4] + dz * fz
        c0 = c00 + (c01 - c00) * fy
        c1 = c10 + (c11 - c10) * fy
        d = c0 + (c1 - c0) * fx
        slope = dz[:2] + (dz[2:] - dz[:2]) * fy  # along z at y, for x = 0 and 1
        g = (
            np.stack(
                [
                    c1 - c0,
                    (1.0 - fx) * (c01 - c00) + fx * (c11 - c10),
                    (1.0 - fx) * slope[0] + fx * slope[1],
                ]
            )
            * self._inv_voxel
        )
        out = np.sqrt(np.einsum("ak,ak->k", e, e))
        g *= np.where((out > 0.0) & (d < 0.0), -1.0, 1.0)
        np.divide(e, out, out=g, where=e != 0.0)
        norm = np.sqrt(np.einsum("ak,ak->k", g, g))
        np.divide(g, norm, out=g, where=norm > 0.0)
        world = np.empty_like(g)
        _rotate(self._to_world, g, world, np.empty_like(norm))
        return world


# ------------------------------------------------------------------ volume
class _VolumeGrid:
    """Hair-hair friction and repulsion through a tent-splatted grid (see the docstring of
    ``follicle.sim.volume``): density and momentum splatted with ``np.bincount``, one
    3×3×3 box blur, V = momentum / density, the density's central-difference gradient per
    grid vertex, both interpolated back trilinearly."""

    def __init__(self, count: int) -> None:
        self._f = np.empty((3, count))
        self._cell = np.empty((3, count), dtype=np.intp)
        self._index = np.empty((8, count), dtype=np.intp)
        self._weight = np.empty((8, count))
        self._scratch = np.empty((8, count))
        self._line = [np.empty(count) for _ in range(2)]

    def apply(
        self,
        x: np.ndarray,
        v: np.ndarray,
        free: np.ndarray,
        dt: float,
        friction: float,
        repulsion: float,
    ) -> None:
        """Update the velocities ``v`` (3, N, S) of the particles ``x`` (3, N, S) where
        ``free`` (N, S) is 1, in place."""
        xf, vf, freef = x.reshape(3, -1), v.reshape(3, -1), free.reshape(-1)
        # grid_for only needs the bounds (it would check all points with a numba kernel)
        bounds = np.stack([xf.min(axis=1), xf.max(axis=1)])
        spec = grid_for(bounds, _RESOLUTION, margin=1 + _BLUR_PASSES)
        h, shape = spec.voxel, spec.shape
        size = int(np.prod(shape))
        self._corners(xf, spec.origin, h, shape)
        idx, w, wv = self._index.reshape(-1), self._weight.reshape(-1), self._scratch
        sums = np.empty((4, size))
        sums[0] = np.bincount(idx, w, minlength=size)
        for a in range(3):  # eq. 3.2 and the numerator of eq. 3.3
            np.multiply(self._weight, vf[a], out=wv)
            sums[1 + a] = np.bincount(idx, wv.reshape(-1), minlength=size)
        grid = sums.reshape(4, *shape)
        for _ in range(_BLUR_PASSES):
            grid = _box_blur(grid)
        density = grid[0]
        velocity = np.zeros_like(grid[1:])
        np.divide(grid[1:], density, out=velocity, where=density > _TINY)
        push = repulsion * h / dt
        if friction > 0.0:  # eq. 3.4: v ← v + s·(V(P) − v)
            step = self._line[0]
            for a in range(3):
                np.subtract(self._sample(velocity[a].reshape(-1)), vf[a], out=step)
                step *= friction
                step *= freef
                vf[a] += step
        if push > 0.0:  # eq. 3.5–3.7: v ← v − s·ĝ·h/dt, ĝ the unit density gradient
            grad = _central_difference(density, h)
            g = [self._sample(grad[a].reshape(-1)).copy() for a in range(3)]
            norm = np.sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
            scale = np.divide(push, norm, out=np.zeros_like(norm), where=norm > _TINY / h)
            scale *= freef
            for a in range(3):
                g[a] *= scale
                vf[a] -= g[a]

    def _corners(self, x: np.ndarray, origin: np.ndarray, h: float, shape: Sequence[int]) -> None:
        """Each particle's 8 cell corners: flat vertex index and tent weight, (8, M)."""
        f, cell = self._f, self._cell
        np.subtract(x, origin[:, None], out=f)
        f *= 1.0 / h
        np.floor(f, out=self._scratch[:3])
        np.copyto(cell, self._scratch[:3], casting="unsafe")
        f -= self._scratch[:3]  # the fractions in the cell
        ny, nz = shape[1], shape[2]
        flat = self._line[0]
        np.multiply(cell[0], ny * nz, out=self._index[0])
        self._index[0] += cell[1] * nz
        self._index[0] += cell[2]
        wx = (1.0 - f[0], f[0])
        wy = (1.0 - f[1], f[1])
        wz = (1.0 - f[2], f[2])
        for k, (dx, dy, dz) in enumerate(_CORNERS):
            if k:
                np.add(self._index[0], dx * ny * nz + dy * nz + dz, out=self._index[k])
            np.multiply(wx[dx], wy[dy], out=flat)
            np.multiply(flat, wz[dz], out=self._weight[k])

    def _sample(self, field: np.ndarray) -> np.ndarray:
        """Trilinear interpolation of a flat vertex field at the particles: (M,) buffer."""
        np.take(field, self._index, out=self._scratch, mode="clip")
        out = self._line[1]
        np.einsum("km,km->m", self._scratch, self._weight, out=out)
        return out


def _box_blur(grid: np.ndarray) -> np.ndarray:
    """Each vertex of (C, nx, ny, nz) the mean of its 3×3×3 neighbours inside the grid,
    separably: a sum of 3 along each axis divided by how many of them are in the grid."""
    for axis in (1, 2, 3):
        n = grid.shape[axis]
        lo = [slice(None)] * 4
        hi = [slice(None)] * 4
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        out = grid.copy()
        out[tuple(hi)] += grid[tuple(lo)]
        out[tuple(lo)] += grid[tuple(hi)]
        count = np.full(n, 3.0)
        count[0] = count[-1] = 2.0
        out /= count.reshape([-1 if a == axis else 1 for a in range(4)])
        grid = out
    return grid


def _central_difference(density: np.ndarray, h: float) -> np.ndarray:
    """(D[i + 1] − D[i − 1]) / 2h along each axis, D = 0 off the grid: (3, nx, ny, nz)."""
    pad = np.pad(density, 1)
    inner = (slice(1, -1),) * 3
    grad = np.empty((3, *density.shape))
    for a in range(3):
        up, down = list(inner), list(inner)
        up[a], down[a] = slice(2, None), slice(None, -2)
        np.subtract(pad[tuple(up)], pad[tuple(down)], out=grad[a])
    grad *= 0.5 / h
    return grad


# ------------------------------------------------------------------ helpers
def _linearised(k: float | np.ndarray, iterations: int) -> float | np.ndarray:
    """The per-iteration stiffness that gives ``k`` after ``iterations`` (Le Muzic 2012 eq. 5.5)."""
    return 1.0 - (1.0 - k) ** (1.0 / iterations)


def _rotate(m: np.ndarray, p: np.ndarray, out: np.ndarray, scratch: np.ndarray) -> None:
    """``out`` = m·p for a 3×3 ``m`` and component-major points (3, M), row by row (a
    BLAS product is faster alone but crawls beside numba's spinning worker threads)."""
    for a in range(3):
        np.multiply(p[0], m[a, 0], out=out[a])
        for b in (1, 2):
            np.multiply(p[b], m[a, b], out=scratch)
            out[a] += scratch


def _cross(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out`` = a × b for component-major (3, …) arrays (``out`` must not alias a, b)."""
    np.multiply(a[1], b[2], out=out[0])
    out[0] -= a[2] * b[1]
    np.multiply(a[2], b[0], out=out[1])
    out[1] -= a[0] * b[2]
    np.multiply(a[0], b[1], out=out[2])
    out[2] -= a[1] * b[0]


class _Clock:
    """Adds the time since the last call to ``times[phase]``."""

    def __init__(self, times: dict[str, float]) -> None:
        self.times = times
        self.last = time.perf_counter()

    def __call__(self, phase: str) -> None:
        now = time.perf_counter()
        self.times[phase] = self.times.get(phase, 0.0) + now - self.last
        self.last = now


# ------------------------------------------------------------------ run alone
def sphere_scene(
    strands: int, vertices: int, radius: float = 0.1, length: float = 0.25
) -> tuple[Model, SDF, np.ndarray]:
    """Straight strands radiating from an icosphere (Fibonacci directions): the model,
    the sphere's SDF and the rest positions (S, N, 3) float64."""
    k = np.arange(strands) + 0.5
    z = 1.0 - 2.0 * k / strands
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    ring = np.sqrt(1.0 - z * z)
    out = np.stack([ring * np.cos(phi), ring * np.sin(phi), z], axis=1)
    t = np.linspace(0.0, length, vertices)
    pts = (radius + t)[None, :, None] * out[:, None, :]
    model = Model.build(HairCurves.from_array(pts), None, None)
    ball = trimesh.creation.icosphere(subdivisions=4, radius=radius)
    x = model.rest_roots[:, None] + model.rest_local.astype(np.float64)
    return model, SDF.from_mesh(ball.vertices, ball.faces), x


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--strands", type=int, default=32_768)
    parser.add_argument("--vertices", type=int, default=32)
    parser.add_argument("--substeps", type=int, default=5)
    args = parser.parse_args()

    model, sdf, x = sphere_scene(args.strands, args.vertices)
    params = SimParams(iterations=4, bend_stiffness=0.3, shape_local=0.2, shape_global=0.1)
    solver = BaselinePBD(model, params, sdf, volume=(0.1, 0.05))
    v = np.zeros_like(x)
    roots, frames, dt = model.rest_roots, model.rest_frames, params.substep
    solver.substep(x, v, roots, frames, dt)  # warm-up: first touch of every buffer
    runs = []
    for _ in range(args.substeps):  # the fastest substep: the least disturbed by neighbours
        solver.times = {}
        start = time.perf_counter()
        solver.substep(x, v, roots, frames, dt)
        runs.append((time.perf_counter() - start, solver.times))
    best, split = min(runs, key=lambda r: r[0])
    median = float(np.median([r[0] for r in runs]))
    phases = ", ".join(f"{k} {t * 1e3:.0f}" for k, t in split.items())
    print(
        f"baseline: {args.strands:,} strands × {args.vertices} vertices,"
        f" {params.iterations} iterations: {best * 1e3:.0f} ms per substep ({phases} ms);"
        f" median {median * 1e3:.0f} ms of {args.substeps}"
    )
    deepest = max(0.0, -float(sdf.distance(x[:, 1:].reshape(-1, 3)).min()))
    print(
        f"finite: {bool(np.isfinite(x).all() and np.isfinite(v).all())};"
        f" {solver._contact_idx.size:,} vertices in contact;"
        f" the deepest free vertex {deepest:.1e} m inside the skin"
    )


if __name__ == "__main__":
    main()
