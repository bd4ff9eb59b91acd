"""Colliders: one table of shapes and the skin's SDF (Le Muzic 2012 §5.1.2 collision constraints).

A collision is a hard constraint: a vertex found inside a collider grown by the
margin is moved to its surface along the collider's normal there (Le Muzic 2012: the head sphere
first, other shapes for the body; the skin mesh through its signed distance field,
:mod:`follicle.mesh.sdf`). Colliders arrive in world space as one bundle,
:class:`Colliders`: a table of shapes, one row each (``kind`` in column 0, the shape's
numbers after it, see :data:`SHAPES`), and the skin's SDF as the arguments of
:func:`sdf_sample` (an empty grid for none).

A new shape is one entry in :data:`~follicle.sim.settings.SHAPES` (its name and its
fields, which ``[[sim.colliders]]`` then accepts; its name in ``ShapeKind`` too) and
one ``_push_*`` kernel here, called from :func:`collide` for its kind.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import NamedTuple, Protocol

import numpy as np

from ..errors import InputError
from ..kernels import kernel, prange
from ..mesh.sdf import sdf_lookup
from .settings import SHAPES

__all__ = [
    "Colliders",
    "collide",
    "colliders",
    "penetration",
    "clearance",
    "NO_SDF",
]

KINDS = tuple(SHAPES)  # a shape's kind: its place in SHAPES
SPHERE, CAPSULE, PLANE = (KINDS.index(k) for k in ("sphere", "capsule", "plane"))


def _layout(fields: tuple[tuple[str, str], ...]) -> tuple[tuple[str, str, int], ...]:
    """Each field of a shape with its first column in a row (column 0 is the kind)."""
    out, c = [], 1
    for field, kind in fields:
        out.append((field, kind, c))
        c += 1 if kind == "scalar" else 3
    return tuple(out)


LAYOUT = {name: _layout(fields) for name, fields in SHAPES.items()}
COLUMNS = 1 + max(sum(1 if k == "scalar" else 3 for _, k in f) for f in SHAPES.values())


def _frozen(arr: np.ndarray) -> np.ndarray:
    arr.setflags(write=False)
    return arr


# sdf_sample's arguments for "no skin SDF": an empty grid, read-only as a skin's SDF
# hands out its own (numba types a read-only array apart: a writable one here made the
# solver's kernels compile a second time, a minute on first use)
NO_SDF = (
    _frozen(np.zeros((0, 0, 0), np.float32)),
    _frozen(np.zeros(3)),
    1.0,
    _frozen(np.eye(4)),
)


class Colliders(NamedTuple):
    """Everything the hair collides with, in world space, as the kernels take it:
    ``shapes`` (K, COLUMNS) float64, a row a shape (:data:`SHAPES`, columns as
    :data:`LAYOUT` places them); the skin's SDF as :attr:`SDF.sample_args`
    (:data:`NO_SDF` for none)."""

    shapes: np.ndarray
    sdf_values: np.ndarray
    sdf_origin: np.ndarray
    sdf_inv_voxel: float
    sdf_lfw: np.ndarray

    def points(self) -> np.ndarray:
        """(M, 3) the shapes' points (sphere centres, capsule ends, a plane's point)."""
        out = [
            row[c : c + 3]
            for row in self.shapes
            for _, kind, c in LAYOUT[KINDS[int(row[0])]]
            if kind == "point"
        ]
        return np.array(out, np.float64).reshape(-1, 3)


class Shape(Protocol):
    """A collider as :func:`colliders` reads it: its ``kind`` (a name in :data:`SHAPES`);
    the fields that entry names and ``follow`` are read by name (``getattr``)."""

    @property
    def kind(self) -> str: ...


def colliders(
    shapes: Iterable[Shape], sdf: tuple = NO_SDF, transform: np.ndarray | None = None
) -> Colliders:
    """The :class:`Colliders` of ``shapes`` (objects with ``kind`` and the fields
    :data:`SHAPES` names, e.g. ``[[sim.colliders]]`` entries) and ``sdf``, in their
    order. A shape whose ``follow`` is true has its points moved and its directions
    turned by the rigid 4×4 ``transform`` (the head's; None: the identity); each
    direction is made unit length."""
    m = np.eye(4) if transform is None else np.asarray(transform, np.float64)
    rows = []
    for shape in shapes:
        r, t = (m[:3, :3], m[:3, 3]) if getattr(shape, "follow", True) else (np.eye(3), 0.0)
        row = np.zeros(COLUMNS)
        row[0] = KINDS.index(shape.kind)
        for field, kind, c in LAYOUT[shape.kind]:
            value = np.asarray(getattr(shape, field), np.float64)
            if kind == "scalar":
                row[c] = value
            elif kind == "point":
                row[c : c + 3] = r @ value + t
            else:
                turned = r @ value
                length = float(np.linalg.norm(turned))
                if not 0.0 < length < math.inf:  # settings refuse it; a duck-typed shape
                    raise InputError(
                        f"{shape.kind} {field}: {value.tolist()} has no direction (too short"
                        " to make unit length); give e.g. (0, 1, 0)"
                    )
                row[c : c + 3] = turned / length
        rows.append(row)
    return Colliders(np.array(rows, np.float64).reshape(-1, COLUMNS), *sdf)


@kernel(inline="always")
def _push_ball(px, py, pz, cx, cy, cz, r, nx, ny, nz, hit, gap):
    """Project p out of the ball (c, r), its normal then in n; else shrink ``gap`` to
    p's distance from the ball."""
    dx, dy, dz = px - cx, py - cy, pz - cz
    d2 = dx * dx + dy * dy + dz * dz
    if d2 >= r * r:
        return px, py, pz, nx, ny, nz, hit, min(gap, math.sqrt(d2) - r)
    d = math.sqrt(d2)
    if d < 1e-12:  # at the centre: push straight up
        dx, dy, dz, d = 0.0, 1.0, 0.0, 1.0
    ux, uy, uz = dx / d, dy / d, dz / d
    return cx + r * ux, cy + r * uy, cz + r * uz, ux, uy, uz, True, gap


@kernel(inline="always")
def _push_sphere(row, px, py, pz, margin, nx, ny, nz, hit, gap):
    """Out of the sphere (centre, radius) grown by ``margin``."""
    return _push_ball(px, py, pz, row[1], row[2], row[3], row[4] + margin, nx, ny, nz, hit, gap)


@kernel(inline="always")
def _push_capsule(row, px, py, pz, margin, nx, ny, nz, hit, gap):
    """Out of the capsule (a, b, radius) grown by ``margin``: out of the ball about the
    nearest point of its axis."""
    ax, ay, az = row[1], row[2], row[3]
    ex, ey, ez = row[4] - ax, row[5] - ay, row[6] - az
    e2 = ex * ex + ey * ey + ez * ez
    s = 0.0
    if e2 > 0.0:
        s = min(max(((px - ax) * ex + (py - ay) * ey + (pz - az) * ez) / e2, 0.0), 1.0)
    return _push_ball(
        px, py, pz, ax + s * ex, ay + s * ey, az + s * ez, row[7] + margin, nx, ny, nz, hit, gap
    )


@kernel(inline="always")
def _push_plane(row, px, py, pz, margin, nx, ny, nz, hit, gap):
    """Out of the half-space behind the plane (a point on it, its unit normal) moved
    ``margin`` along the normal: the hair stays on the side the normal points to."""
    ux, uy, uz = row[4], row[5], row[6]
    d = (px - row[1]) * ux + (py - row[2]) * uy + (pz - row[3]) * uz - margin
    if d >= 0.0:
        return px, py, pz, nx, ny, nz, hit, min(gap, d)
    return px - d * ux, py - d * uy, pz - d * uz, ux, uy, uz, True, gap


@kernel(inline="always")
def collide(px, py, pz, colliders, margin):
    """p moved out of every collider grown by ``margin``: (x, y, z, nx, ny, nz, hit,
    clearance). ``n`` is the last contact's outward normal. ``clearance`` is 0 after a
    push, else the smallest gap between p and a grown collider (for the SDF, the gap of
    :func:`sdf_lookup`'s bound: divided by √3 it bounds how far p may move before it can
    touch, as each partial derivative of a trilinear interpolant of distances is at
    most 1). ``colliders`` is a :class:`Colliders`; its shapes are taken in row order,
    then the skin SDF, skipped when its grid is empty.
    """
    nx, ny, nz, hit = 0.0, 0.0, 0.0, False
    gap = math.inf
    shapes = colliders.shapes
    for k in range(shapes.shape[0]):
        row = shapes[k]
        kind = int(row[0])
        if kind == SPHERE:
            px, py, pz, nx, ny, nz, hit, gap = _push_sphere(
                row, px, py, pz, margin, nx, ny, nz, hit, gap
            )
        elif kind == CAPSULE:
            px, py, pz, nx, ny, nz, hit, gap = _push_capsule(
                row, px, py, pz, margin, nx, ny, nz, hit, gap
            )
        elif kind == PLANE:
            px, py, pz, nx, ny, nz, hit, gap = _push_plane(
                row, px, py, pz, margin, nx, ny, nz, hit, gap
            )
    values = colliders.sdf_values
    if values.size > 0:
        # one lookup with the normal: the solver only asks for vertices that may touch
        d, gx, gy, gz, bound = sdf_lookup(
            values,
            colliders.sdf_origin,
            colliders.sdf_inv_voxel,
            colliders.sdf_lfw,
            px,
            py,
            pz,
            margin,
        )
        if d < margin and (gx != 0.0 or gy != 0.0 or gz != 0.0):
            depth = margin - d
            px, py, pz = px + depth * gx, py + depth * gy, pz + depth * gz
            nx, ny, nz, hit = gx, gy, gz, True
        gap = min(gap, max(bound - margin, 0.0))
    return px, py, pz, nx, ny, nz, hit, 0.0 if hit else gap


@kernel(parallel=True)
def _clearance_kernel(x, colliders, out):
    for s in prange(x.shape[0]):
        for i in range(x.shape[1]):
            px, py, pz = x[s, i, 0], x[s, i, 1], x[s, i, 2]
            qx, qy, qz, _, _, _, hit, gap = collide(px, py, pz, colliders, 0.0)
            depth = math.sqrt((qx - px) ** 2 + (qy - py) ** 2 + (qz - pz) ** 2)
            out[s, i] = -depth if hit else gap


def clearance(x: np.ndarray, colliders: Colliders) -> np.ndarray:
    """(S, N) distance of each vertex of ``x`` (S, N, 3) from the nearest collider (inf
    for none), or minus its depth inside."""
    out = np.empty(x.shape[:2])
    _clearance_kernel(np.ascontiguousarray(x, np.float64), colliders, out)
    return out


def penetration(x: np.ndarray, colliders: Colliders) -> float:
    """Deepest penetration (m) of any vertex of ``x`` (S, N, 3) into a collider or the
    skin (no margin): how far the deepest vertex would have to move to get out."""
    return max(0.0, -float(clearance(x, colliders).min()))
