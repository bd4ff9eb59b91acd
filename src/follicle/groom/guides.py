"""Guides: artist-made guide curves bound to the skin mesh.

Each guide keeps the triangle and barycentric coordinates of its root on the rest
mesh, the rest root frame there, and its vertices relative to the root in that frame
(Šik 2012 §2.2.4 "Interpolation details"): interpolating in root-local frames keeps the
hair shape when the mesh deforms and stops guides on the far side of a thin part from
bleeding through. Guides are resampled by arc length to a common vertex count, and so
are their point attributes (a colour or width the hairs inherit: ``[groom].inherit``).
"""

from __future__ import annotations

import logging
import math
import os

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..kernels import kernel
from ..mesh.skin import SkinMesh
from ..units import (
    Units,
    mesh_factors,
    metres_per_unit,
    off_mesh_factor,
    scale_curves,
    units_fix,
    units_for,
    warn_guide_size,
)
from ..validate import file_path, whole
from .groups import InterpolationGroups, mesh_groups

log = logging.getLogger("follicle")
_FAR = 0.01  # warn when a root is farther from the mesh than this share of its size

__all__ = ["Guides", "load_guides", "bind_roots", "resample_arclength", "resample_attribute"]


@kernel(inline="always")
def _arc(points, a, n, s):
    """Normalised arc length of the ``n`` vertices of ``points`` from ``a`` into ``s``;
    False for a curve of zero length."""
    s[0] = 0.0
    for i in range(1, n):
        dx = points[a + i, 0] - points[a + i - 1, 0]
        dy = points[a + i, 1] - points[a + i - 1, 1]
        dz = points[a + i, 2] - points[a + i - 1, 2]
        s[i] = s[i - 1] + np.sqrt(dx * dx + dy * dy + dz * dz)
    total = s[n - 1]
    if not total > 0.0:
        return False
    for i in range(n):
        s[i] /= total
    return True


@kernel(nogil=True)
def _resample_kernel(points, offsets, values, s_new, out):
    """Each curve's per-vertex ``values`` (P, K) at parameters ``s_new`` of its
    normalised arc length (of ``points``), as np.interp computes it, into ``out``
    (C, n, K); returns the first zero-length curve, or −1. A coincident vertex pair
    (a zero-length segment) is stepped over: its later vertex's value holds from it on."""
    for c in range(offsets.shape[0] - 1):
        a = offsets[c]
        n = offsets[c + 1] - a
        s = np.empty(n)
        if not _arc(points, a, n, s):
            return c
        j = 0
        for k in range(s_new.shape[0]):
            x = s_new[k]
            if x >= s[n - 1]:
                for axis in range(values.shape[1]):
                    out[c, k, axis] = values[a + n - 1, axis]
                continue
            while j + 1 < n and s[j + 1] <= x:
                j += 1
            for axis in range(values.shape[1]):
                f0 = values[a + j, axis]
                slope = (values[a + j + 1, axis] - f0) / (s[j + 1] - s[j])
                out[c, k, axis] = slope * (x - s[j]) + f0
    return -1


@kernel(nogil=True)
def _nearest_kernel(points, offsets, s_new, out):
    """The vertex (global index) of each curve nearest in normalised arc length to each
    of the parameters ``s_new``, into ``out`` (C, n); a tie goes to the root side."""
    for c in range(offsets.shape[0] - 1):
        a = offsets[c]
        n = offsets[c + 1] - a
        s = np.empty(n)
        if not _arc(points, a, n, s):
            return c
        j = 0
        for k in range(s_new.shape[0]):
            x = s_new[k]
            while j + 1 < n and s[j + 1] <= x:
                j += 1
            near = j
            if j + 1 < n and s[j + 1] - x < x - s[j]:
                near = j + 1
            out[c, k] = a + near
    return -1


def _zero_length(bad: int, what: str) -> None:
    if bad >= 0:
        raise InputError(f"{what} {bad} has zero length; remove it or give it a shape")


def resample_arclength(curves: HairCurves, vertices: int, what: str = "guide") -> np.ndarray:
    """Every curve resampled to ``vertices`` points evenly spaced by arc length, (C, n, 3);
    InputError naming the first curve of zero length (a ``what``: guide, hair)."""
    vertices = whole(vertices, "vertices", 2, what="a whole number of vertices per curve")
    out = np.empty((curves.curve_count, vertices, 3), dtype=np.float64)
    points = np.ascontiguousarray(curves.points, dtype=np.float64)
    offsets = np.ascontiguousarray(curves.offsets, dtype=np.int64)
    s_new = np.linspace(0.0, 1.0, vertices)
    _zero_length(_resample_kernel(points, offsets, points, s_new, out), what)
    return out


def resample_attribute(
    curves: HairCurves, name: str, vertices: int, what: str = "guide"
) -> np.ndarray:
    """Point attribute ``name`` of every curve at ``vertices`` points evenly spaced by arc
    length, as :func:`resample_arclength` places the points: (C, n, *shape).

    Floating-point values are interpolated linearly in arc length (float64); integers
    and booleans, which have no value between two, take the nearest vertex's.
    """
    vertices = whole(vertices, "vertices", 2, what="a whole number of vertices per curve")
    values = curves.point_data[name]
    shape = values.shape[1:]
    flat = values.reshape(len(values), -1)
    points = np.ascontiguousarray(curves.points, dtype=np.float64)
    offsets = np.ascontiguousarray(curves.offsets, dtype=np.int64)
    s_new = np.linspace(0.0, 1.0, vertices)
    if values.dtype.kind == "f":
        out = np.empty((curves.curve_count, vertices, flat.shape[1]), dtype=np.float64)
        _zero_length(
            _resample_kernel(points, offsets, np.ascontiguousarray(flat, np.float64), s_new, out),
            what,
        )
    else:
        near = np.empty((curves.curve_count, vertices), dtype=np.int64)
        _zero_length(_nearest_kernel(points, offsets, s_new, near), what)
        out = flat[near]
    return out.reshape(curves.curve_count, vertices, *shape)


def _bound(curves: HairCurves) -> bool:
    return "root_triangle" in curves.curve_data and "root_bary" in curves.curve_data


def bind_roots(
    curves: HairCurves, mesh: SkinMesh, name: str = "guides", units: Units = "m", warn: bool = True
) -> HairCurves:
    """``curves`` with ``curve_data['root_triangle']``/``['root_bary']``: each guide's first
    vertex bound to the closest point of ``mesh``'s rest pose.

    With ``warn``, roots farther than 1 % of the mesh's size are logged, naming ``name``;
    when scaling them by 100 or 1000 puts them on the mesh the line says which units
    (relative to the ``units`` the guides were read in) would, and when the mesh's own
    size warning (:func:`follicle.units.warn_mesh_size`) explains the gap it says nothing.
    """
    roots = curves.points[curves.offsets[:-1]]
    triangles, bary, dist = mesh.closest_points(roots, pose="rest")
    lo, hi = mesh.bounds("rest")
    size = float(np.linalg.norm(hi - lo))
    if warn and dist.max() > _FAR * size:
        _warn_off_mesh(roots, dist, mesh, size, name, units)
    data = {**curves.curve_data, "root_triangle": triangles, "root_bary": bary}
    return HairCurves(curves.points, curves.offsets, curves.point_data, data)


def _warn_off_mesh(
    roots: np.ndarray, dist: np.ndarray, mesh: SkinMesh, size: float, name: str, units: Units
) -> None:
    """Log the roots farther than ``_FAR`` × ``size`` from the mesh, with the units that
    would put them on it; nothing when the mesh is off by that factor (its own size
    warning says what to set)."""
    hint = ""
    factor = off_mesh_factor(roots, lambda p: mesh.closest_points(p, pose="rest")[2], _FAR * size)
    if factor is not None:
        if any(math.isclose(factor * f, 1.0) for f in mesh_factors(size)):
            return
        hint = f"; scaled by {factor:g} they lie on it: " + units_fix(
            "the guides are", "[guides].units", "load_guides", units, factor
        )
    log.warning(
        "%s: %d root(s) lie off mesh '%s' (farthest: guide %d, %.4g away, %.1f%% of the mesh"
        " size); they are bound to the closest surface point%s",
        name,
        int((dist > _FAR * size).sum()),
        mesh.name,
        int(np.argmax(dist)),
        float(dist.max()),
        100.0 * float(dist.max()) / size,
        hint,
    )


class Guides:
    """Guide curves bound to ``mesh``'s rest pose, each in an interpolation group.

    Roots come from ``curve_data['root_triangle']``/``['root_bary']`` when present,
    else from the closest point of the rest mesh to each guide's first vertex
    (:func:`bind_roots`, with a warning when that is far; ``curves`` then holds the
    binding). ``groups`` assigns each guide the group at its root
    UV (one group when None). ``local`` holds the shapes at ``vertices`` (default:
    the longest guide's count); :meth:`local_shapes` gives any other count.
    """

    def __init__(
        self,
        curves: HairCurves,
        mesh: SkinMesh,
        vertices: int | None = None,
        groups: InterpolationGroups | None = None,
    ) -> None:
        if curves.curve_count == 0:
            raise InputError("guides: need at least one guide curve")
        self.mesh = mesh
        n = whole(vertices, "vertices", 2, allow_none=True) or int(curves.counts.max())
        if not _bound(curves):
            curves = bind_roots(curves, mesh)
        self.curves = curves
        self.triangles = curves.curve_data["root_triangle"].astype(np.int64)
        self.bary = curves.curve_data["root_bary"].astype(np.float64)
        if self.triangles.min() < 0 or self.triangles.max() >= len(mesh.faces):
            raise InputError(
                f"guides: root_triangle refers to triangles outside mesh '{mesh.name}'"
                f" ({len(mesh.faces)} faces); were the guides made for another mesh?"
            )
        frame = mesh.evaluate(self.triangles, self.bary, pose="rest")
        self.root_positions = frame.position
        self.normals, self.tangents, self.binormals = frame.normal, frame.tangent, frame.binormal
        self.groups = groups if groups is not None else InterpolationGroups()
        self.group = self.groups.group_of(frame.uv)
        self._local: dict[int, np.ndarray] = {}
        self._rest: dict[int, np.ndarray] = {}
        self._attributes: dict[tuple[str, int], np.ndarray] = {}
        self.local = self.local_shapes(n)

    def local_shapes(self, vertices: int) -> np.ndarray:
        """Guide shapes resampled by arc length to ``vertices``, in root frames (S, V, 3).

        x along the root tangent, y the binormal, z the normal (Šik 2012 §2.2.4).
        """
        if vertices not in self._local:
            rel = self.rest_shapes(vertices).astype(np.float64)
            frames = np.stack([self.tangents, self.binormals, self.normals], axis=1)  # (S, 3, 3)
            self._local[vertices] = np.einsum("snk,sak->sna", rel, frames).astype(np.float32)
        return self._local[vertices]

    def rest_shapes(self, vertices: int) -> np.ndarray:
        """Guide shapes resampled to ``vertices``, world axes, root at the origin (S, V, 3)."""
        if vertices not in self._rest:
            rel = resample_arclength(self.curves, vertices)
            self._rest[vertices] = (rel - rel[:, :1, :]).astype(np.float32)
        return self._rest[vertices]

    def point_attribute(self, name: str, vertices: int) -> np.ndarray:
        """Point attribute ``name`` of the guides (``curves.point_data``) at the
        ``vertices`` points :meth:`rest_shapes` places by arc length, (S, V, *shape):
        :func:`resample_attribute`, made once per count."""
        key = (name, vertices)
        if key not in self._attributes:
            self._attributes[key] = resample_attribute(self.curves, name, vertices)
        return self._attributes[key]

    def posed(self, positions: object, pose: SkinMesh | None = None) -> Guides:
        """These guides with new shapes ``positions`` (S, N, 3), given on ``pose`` (the
        guides' mesh in some pose, e.g. a Simulator's ``sim.pose``; None: the rest pose):
        each strand is carried to the rest pose through its root's frame, so interpolated
        hairs follow it (Šik 2012 §2.2.4: hairs blend root-local shapes).
        The guides' point attributes come along resampled to the N vertices by arc length
        (:meth:`point_attribute`, in their own type), their curve attributes as they are: a
        settled guide keeps the colour the file gave it (``[groom].inherit``).
        """
        x = np.asarray(positions, dtype=np.float64)
        if x.ndim != 3 or x.shape[0] != self.count or x.shape[1] < 2 or x.shape[2] != 3:
            raise InputError(
                f"positions: expected ({self.count}, N ≥ 2, 3) guide vertices (one strand per"
                f" guide), got shape {x.shape}; simulate these guides, not another set"
            )
        if not np.isfinite(x).all():
            raise InputError("positions: contain NaN or inf; the simulation blew up")
        skin = self.mesh if pose is None else pose
        if not self.mesh.same_skin(skin):
            raise InputError(
                f"pose: expected the guides' mesh '{self.mesh.name}' in some pose, got"
                f" {type(pose).__name__}"
            )
        cur = skin.evaluate(self.triangles, self.bary, pose="current")
        now = np.stack([cur.tangent, cur.binormal, cur.normal], axis=1)
        rest = np.stack([self.tangents, self.binormals, self.normals], axis=1)
        local = np.einsum("sna,ska->snk", x - cur.position[:, None], now)
        shapes = self.root_positions[:, None] + np.einsum("snk,ska->sna", local, rest)
        n = x.shape[1]
        point = {
            name: self.point_attribute(name, n).astype(values.dtype).reshape(-1, *values.shape[1:])
            for name, values in self.curves.point_data.items()
        }
        data = {**self.curves.curve_data, "root_triangle": self.triangles, "root_bary": self.bary}
        curves = HairCurves.from_array(shapes, point, data)
        return Guides(curves, self.mesh, groups=self.groups)

    @property
    def count(self) -> int:
        return self.local.shape[0]

    @property
    def vertex_count(self) -> int:
        return self.local.shape[1]

    def __repr__(self) -> str:
        return f"Guides({self.count} guides × {self.vertex_count} vertices on '{self.mesh.name}')"


def load_guides(
    source: str | os.PathLike[str] | HairCurves,
    mesh: SkinMesh,
    vertices: int | None = None,
    groups: InterpolationGroups | None = None,
    units: Units = "m",
) -> Guides:
    """Guides from ``builtin:long|short|curly``, a curves file, or HairCurves, bound to ``mesh``.

    ``units`` are those of the file or HairCurves (``"m"``, ``"cm"``, ``"mm"``, ``"in"``
    or metres per unit; :mod:`follicle.units`): points and widths are converted to
    metres. Built-in guides are in metres and take no other units. Guides whose size
    suggests other units, alone or next to the mesh, are logged as a warning naming
    the setting that fixes them, and then their roots' distance from the mesh is not
    logged again.
    """
    from ..io.dispatch import load_curves
    from .builtin_guides import builtin_guides

    if isinstance(source, HairCurves):
        name, curves = "guides", scale_curves(source, metres_per_unit(units))
    elif str(file_path(source, "load_guides source")).startswith("builtin:"):
        units_for(str(source), units)  # built-in guides are metres: other units are an error
        if groups is None:  # they part where the mesh says (the built-in head's mid-plane)
            groups = mesh_groups(mesh)
        return Guides(builtin_guides(str(source).split(":", 1)[1], mesh), mesh, vertices, groups)
    else:
        name, curves = os.fspath(source), load_curves(source, units)
    if curves.curve_count:  # none: Guides says so
        lo, hi = mesh.bounds("rest")
        warned = warn_guide_size(curves, float(np.linalg.norm(hi - lo)), units, name)
        if not _bound(curves):
            curves = bind_roots(curves, mesh, name, units, warn=not warned)
    return Guides(curves, mesh, vertices, groups)
