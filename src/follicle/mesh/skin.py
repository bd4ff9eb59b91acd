"""SkinMesh: the triangle mesh hair grows on, in its rest pose and in one current pose.

A SkinMesh is a value: :meth:`SkinMesh.posed` makes the same skin in another pose (the
"current" pose of that copy), sharing the rest data, and nothing poses a mesh in place,
so a pose is passed to whoever works on it (a Groom's ``generate(pose=…)``, a
Simulator's ``pose``) rather than set on a mesh they share.

Roots are bound to (triangle, barycentric) samples on the rest mesh and evaluated on
either pose (Šik 2012 §2.2.3). Barycentrics follow Šik 2012: ``root = u·v0 + v·v1 +
(1 − u − v)·v2`` with ``bary[:, 0] = u`` and ``bary[:, 1] = v``.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, NamedTuple, TypeVar, cast

import numpy as np
from scipy.spatial import cKDTree

from ..arrays import as_array, budget_runs, frozen, readonly
from ..errors import InputError
from ..frames import normalize
from ..kernels import kernel, prange
from .texture import Texture

if TYPE_CHECKING:
    import trimesh

__all__ = ["SkinMesh", "SurfacePoints", "closest_weights", "MAX_COORDINATE"]

_POSES = ("rest", "current")
_T = TypeVar("_T")
# SkinMesh._trees: (used-vertex tree, triangle-centre tree, centres, radii, used faces)
_Trees = tuple[cKDTree, cKDTree, np.ndarray, np.ndarray, np.ndarray]
# the largest |coordinate| of a mesh vertex, metres (a planet is 6.4e6 m): products of
# coordinates (areas, normals, distances squared) then stay far inside float32 and the
# relative tolerances of float64; a mesh at 1e38 would overflow them to inf or NaN
MAX_COORDINATE = 1e6
# the most candidate triangles closest_points tests at once (about 100 bytes each)
MAX_CANDIDATES = 1 << 20


class SurfacePoints(NamedTuple):
    """Points on the skin with their orthonormal frame; all float64."""

    position: np.ndarray  # (n, 3)
    normal: np.ndarray  # (n, 3)
    tangent: np.ndarray  # (n, 3)
    binormal: np.ndarray  # (n, 3), tangent × normal
    uv: np.ndarray  # (n, 2), zeros when the mesh has no UVs


def _finite_rows(arr: np.ndarray, what: str) -> None:
    ok = np.isfinite(arr).all(axis=1)
    if not ok.all():
        bad = int(np.argmax(~ok))
        raise InputError(f"{what} {bad} is not finite (NaN or inf); fix or remove it")


def _checked_positions(verts: np.ndarray, what: str) -> None:
    """InputError naming the first vertex that is not finite or beyond ±MAX_COORDINATE."""
    _finite_rows(verts, what)
    far = (np.abs(verts) > MAX_COORDINATE).any(axis=1)
    if far.any():
        bad = int(np.argmax(far))
        raise InputError(
            f"{what} {bad} = {verts[bad].tolist()} lies beyond the limit |coordinate| ≤"
            f" {MAX_COORDINATE:g} m; scale the mesh to metres (or give its units: [mesh].units,"
            " load_mesh(..., units=...))"
        )


class SkinMesh:
    """A validated triangle mesh with UVs, textures and cached per-pose derived data.

    ``rest_vertices`` never change; ``vertices`` is this value's current pose (the rest
    pose, or the one :meth:`posed` gave it).
    Zero-area triangles are allowed, flagged in ``degenerate_faces`` and given zero
    area, but a mesh made only of them is rejected.
    """

    def __init__(
        self,
        vertices: object,
        faces: object,
        uvs: object | None = None,
        name: str = "mesh",
        textures: dict[str, Texture] | None = None,
    ) -> None:
        self.name = str(name)
        what = f"mesh '{self.name}'"
        verts = as_array(vertices, f"{what}: vertices", np.float64)
        if verts.ndim != 2 or verts.shape[1] != 3 or len(verts) == 0:
            raise InputError(
                f"{what}: vertices must have shape (V, 3) with V > 0, got {verts.shape}"
            )
        _checked_positions(verts, f"{what}: vertex")
        f = as_array(faces, f"{what}: faces")
        if f.size == 0:
            raise InputError(f"{what} has no faces; give at least one triangle")
        if f.ndim != 2 or f.shape[1] != 3:
            raise InputError(f"{what}: faces must have shape (F, 3) (triangles), got {f.shape}")
        if not np.issubdtype(f.dtype, np.integer):
            if not (np.issubdtype(f.dtype, np.floating) and np.all(np.mod(f, 1) == 0)):
                raise InputError(f"{what}: faces must hold whole vertex indices, got {f.dtype}")
        f = f.astype(np.int64)
        if f.min() < 0 or f.max() >= len(verts):
            bad = int(np.argmax((f < 0).any(axis=1) | (f >= len(verts)).any(axis=1)))
            raise InputError(
                f"{what}: face {bad} = {f[bad].tolist()} indexes outside the {len(verts)}"
                f" vertices (valid 0 … {len(verts) - 1})"
            )
        self.faces = frozen(f)
        self.rest_vertices = frozen(verts)
        self.vertices = self.rest_vertices
        self.uvs: np.ndarray | None = None
        if uvs is not None:
            uv = as_array(uvs, f"{what}: uvs", np.float64)
            if uv.shape != (len(verts), 2):
                raise InputError(
                    f"{what}: uvs must have shape ({len(verts)}, 2), one per vertex, got {uv.shape}"
                )
            _finite_rows(uv, f"{what}: uv")
            self.uvs = frozen(uv)
        self.textures: dict[str, Texture] = dict(textures or {})
        for key, tex in self.textures.items():
            if not isinstance(tex, Texture):
                raise InputError(
                    f"{what}: textures['{key}'] is {type(tex).__name__}, not a Texture"
                )
        self._cache: dict[tuple[str, str], object] = {}
        areas = 0.5 * np.linalg.norm(self._face_cross("rest"), axis=1)
        scale = float(np.ptp(verts, axis=0).max())
        self.degenerate_faces = frozen(areas <= 1e-14 * max(scale, 1e-150) ** 2)
        if self.degenerate_faces.all():
            raise InputError(f"{what}: all {len(f)} faces have zero area; the mesh is degenerate")

    # ------------------------------------------------------------------ pose
    def posed(self, vertices: object | None = None, transform: object | None = None) -> SkinMesh:
        """This skin in another pose, as a new value: new vertex positions (V, 3), or a
        4x4 affine of the rest. The rest pose, faces, UVs and textures are shared; this
        mesh is not changed, so whoever holds it (a Groom, another Simulator) keeps its
        pose. Derived data of the rest pose computed so far is shared too."""
        what = f"mesh '{self.name}'"
        if (vertices is None) == (transform is None):
            raise InputError(f"{what}: posed needs exactly one of vertices= or transform=")
        if transform is not None:
            m = as_array(transform, f"{what}: transform", np.float64)
            if m.shape != (4, 4) or not np.all(np.isfinite(m)):
                raise InputError(f"{what}: transform must be a finite 4x4 matrix, got {m.shape}")
            if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0]):
                raise InputError(f"{what}: transform must be affine (last row 0, 0, 0, 1)")
            verts = self.rest_vertices @ m[:3, :3].T + m[:3, 3]
        else:
            verts = as_array(vertices, f"{what}: vertices", np.float64)
            if verts.shape != self.rest_vertices.shape:
                raise InputError(
                    f"{what}: pose vertices must have shape {self.rest_vertices.shape}"
                    f" (same as the rest pose), got {verts.shape}"
                )
        _checked_positions(verts, f"{what}: pose vertex")  # a huge transform overflows too
        out = copy.copy(self)
        out.vertices = frozen(verts.copy())
        out._cache = {k: v for k, v in self._cache.items() if k[1] == "rest"}
        return out

    def same_skin(self, other: object) -> bool:
        """True when ``other`` is this skin in some pose (the same rest mesh and faces)."""
        if not isinstance(other, SkinMesh):
            return False
        if other.rest_vertices is self.rest_vertices and other.faces is self.faces:
            return True
        return (
            other.rest_vertices.shape == self.rest_vertices.shape
            and other.faces.shape == self.faces.shape
            and np.array_equal(other.rest_vertices, self.rest_vertices)
            and np.array_equal(other.faces, self.faces)
        )

    @property
    def at_rest(self) -> bool:
        """True for the rest pose itself (not a :meth:`posed` copy)."""
        return self.vertices is self.rest_vertices

    def _verts(self, pose: str) -> np.ndarray:
        if pose == "rest":
            return self.rest_vertices
        if pose == "current":
            return self.vertices
        raise InputError(f"pose={pose!r}; use one of {list(_POSES)}")

    def derived(self, what: str, pose: str, make: Callable[[np.ndarray], _T]) -> _T:
        """What ``make`` derives from the vertices of ``pose``, made once and kept with the
        pose under the name ``what`` (the current pose's data is dropped when it moves);
        one ``make`` per name. Other modules keep their own data of a pose here too
        (:func:`follicle.mesh.sdf.skin_sdf`)."""
        self._verts(pose)  # validates pose
        if self.at_rest:
            pose = "rest"  # not posed: the current pose shares the rest pose's data
        key = (what, pose)
        if key not in self._cache:
            self._cache[key] = make(self._verts(pose))
        # each ``what`` is made by one ``make``: the value is what that returns
        return cast(_T, self._cache[key])

    # ------------------------------------------------------------------ sizes
    @property
    def vertex_count(self) -> int:
        return len(self.rest_vertices)

    @property
    def face_count(self) -> int:
        return len(self.faces)

    def used_vertices(self, pose: str = "rest") -> np.ndarray:
        """The vertices faces use (M, 3) in ``pose``: what is drawn and framed, without
        stray points a file may carry."""
        return self._verts(pose)[np.unique(self.faces)]

    def bounds(self, pose: str = "rest") -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds ((3,), (3,)) of the vertices used by faces."""
        used = self.used_vertices(pose)
        return used.min(axis=0), used.max(axis=0)

    def __repr__(self) -> str:
        lo, hi = self.bounds("rest")
        extras = (", uvs" if self.uvs is not None else "") + (
            f", textures={sorted(self.textures)}" if self.textures else ""
        )
        return (
            f"SkinMesh('{self.name}', {self.vertex_count} vertices, {self.face_count} faces"
            f"{extras}, bounds=[{lo.round(3).tolist()} … {hi.round(3).tolist()}])"
        )

    # ------------------------------------------------------------------ derived data
    def _face_cross(self, pose: str) -> np.ndarray:
        def make(v: np.ndarray) -> np.ndarray:
            p0, p1, p2 = (v[self.faces[:, k]] for k in range(3))
            return frozen(np.cross(p1 - p0, p2 - p0))

        return self.derived("face_cross", pose, make)

    def face_areas(self, pose: str = "rest") -> np.ndarray:
        """Triangle areas (F,) float64; zero for degenerate triangles."""

        def make(_v: np.ndarray) -> np.ndarray:
            areas = 0.5 * np.linalg.norm(self._face_cross(pose), axis=1)
            areas[self.degenerate_faces] = 0.0
            return frozen(areas)

        return self.derived("face_areas", pose, make)

    def face_normals(self, pose: str = "rest") -> np.ndarray:
        """Unit face normals (F, 3) by the right-hand rule on (v0, v1, v2); zero if degenerate."""

        def make(_v: np.ndarray) -> np.ndarray:
            n = normalize(self._face_cross(pose).copy())
            n[self.degenerate_faces] = 0.0
            return frozen(n)

        return self.derived("face_normals", pose, make)

    def vertex_normals(self, pose: str = "rest") -> np.ndarray:
        """Area-weighted unit vertex normals (V, 3), welded across UV seams.

        Vertices at the same rest position (split for UVs) share one normal, so
        seams do not show; a vertex with no area around it gets +Y.
        """

        def make(_v: np.ndarray) -> np.ndarray:
            acc = self._area_weighted_sum(self.face_normals(pose), pose)
            group = self._weld_groups()
            welded = np.zeros_like(acc)
            np.add.at(welded, group, acc)
            n = welded[group]
            length = np.linalg.norm(n, axis=1)
            n = n / np.where(length > 0, length, 1.0)[:, None]
            n[length <= 0] = (0.0, 1.0, 0.0)
            return frozen(n)

        return self.derived("vertex_normals", pose, make)

    def _area_weighted_sum(self, per_face: np.ndarray, pose: str) -> np.ndarray:
        """Sum of area × per-face vectors over the faces around each vertex, (V, 3)."""
        weighted = np.repeat(per_face * self.face_areas(pose)[:, None], 3, axis=0)
        acc = np.zeros_like(self.rest_vertices)
        np.add.at(acc, self.faces.ravel(), weighted)
        return acc

    def _weld_groups(self) -> np.ndarray:
        def make(rest: np.ndarray) -> np.ndarray:
            _, inverse = np.unique(rest, axis=0, return_inverse=True)
            return frozen(inverse.reshape(-1).astype(np.int64))

        return self.derived("weld", "rest", make)

    def face_uv_gradient(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-face (∂X/∂u, ∂X/∂v, ok) of per-vertex ``values`` (V, k) linear on each face.

        Šik 2012 §2.2.3: [∂X/∂u; ∂X/∂v] = [[u1-u3, v1-v3], [u2-u3, v2-v3]]⁻¹ · [X1-X3; X2-X3];
        ok is False (and the gradients zero) where the UVs are missing or degenerate.
        """
        nf = len(self.faces)
        k = values.shape[1]
        if self.uvs is None:
            return np.zeros((nf, k)), np.zeros((nf, k)), np.zeros(nf, dtype=bool)
        x1, x2, x3 = (values[self.faces[:, c]] for c in range(3))
        t1, t2, t3 = (self.uvs[self.faces[:, c]] for c in range(3))
        du1, dv1 = (t1 - t3).T
        du2, dv2 = (t2 - t3).T
        det = du1 * dv2 - dv1 * du2
        uv_scale = np.maximum(np.abs(t1 - t3).max(axis=1), np.abs(t2 - t3).max(axis=1))
        ok = (np.abs(det) > 1e-12 * np.maximum(uv_scale, 1e-300) ** 2) & (det != 0)
        ok &= ~self.degenerate_faces
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
        e1, e2 = x1 - x3, x2 - x3
        d_du = (dv2[:, None] * e1 - dv1[:, None] * e2) * inv
        d_dv = (-du2[:, None] * e1 + du1[:, None] * e2) * inv
        return d_du, d_dv, ok

    def face_uv_derivatives(self, pose: str = "rest") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-face (dP/du, dP/dv, ok) of the positions; ok is False where undefined."""
        return self.derived("face_uv_derivatives", pose, self.face_uv_gradient)

    def face_normal_uv_derivatives(
        self, pose: str = "rest"
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-face (dÑ/du, dÑ/dv, ok) of the blended (unnormalised) vertex normals."""

        def make(_v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            return self.face_uv_gradient(self.vertex_normals(pose))

        return self.derived("face_normal_uv_derivatives", pose, make)

    def face_tangents(self, pose: str = "rest") -> np.ndarray:
        """Unit face tangents (F, 3): dP/du, else the edge v0→v1 projected off the normal."""

        def make(v: np.ndarray) -> np.ndarray:
            dpdu, _, ok = self.face_uv_derivatives(pose)
            n = self.face_normals(pose)
            edge = v[self.faces[:, 1]] - v[self.faces[:, 0]]
            t = np.where(ok[:, None], dpdu, edge)
            t = t - np.sum(t * n, axis=1, keepdims=True) * n
            return frozen(normalize(t))

        return self.derived("face_tangents", pose, make)

    def vertex_tangents(self, pose: str = "rest") -> np.ndarray:
        """Area-weighted unit vertex tangents (V, 3), made orthogonal to the vertex normals."""

        def make(_v: np.ndarray) -> np.ndarray:
            acc = self._area_weighted_sum(self.face_tangents(pose), pose)
            n = self.vertex_normals(pose)
            acc = acc - np.sum(acc * n, axis=1, keepdims=True) * n
            return frozen(normalize(acc))

        return self.derived("vertex_tangents", pose, make)

    # ------------------------------------------------------------------ evaluation
    def _check_samples(self, triangles: object, bary: object) -> tuple[np.ndarray, np.ndarray]:
        tri = as_array(triangles, "triangles")
        if tri.ndim != 1 or (tri.size and not np.issubdtype(tri.dtype, np.integer)):
            raise InputError(f"triangles must be a 1-D integer array, got {tri.dtype} {tri.shape}")
        tri = tri.astype(np.int64)
        if tri.size and (tri.min() < 0 or tri.max() >= len(self.faces)):
            raise InputError(
                f"triangles: index out of range for mesh '{self.name}' with {len(self.faces)} faces"
            )
        b = as_array(bary, "bary", np.float64)
        if b.shape != (len(tri), 2):
            raise InputError(f"bary must have shape ({len(tri)}, 2), got {b.shape}")
        if not np.all(np.isfinite(b)):
            raise InputError("bary contains NaN or inf")
        w = 1.0 - b[:, 0] - b[:, 1]
        if b.size and (b.min() < -1e-4 or w.min() < -1e-4):
            raise InputError("bary: coordinates must satisfy u >= 0, v >= 0, u + v <= 1")
        return tri, b

    def evaluate(self, triangles: object, bary: object, pose: str = "rest") -> SurfacePoints:
        """Positions, root frames and UVs at (triangle, barycentric) samples (Šik 2012 §2.2.3).

        Frames as :func:`follicle.frames.root_frames` of the interpolated vertex normal
        and tangent, in one parallel kernel (the groom evaluates millions of roots).
        """
        tri, b = self._check_samples(triangles, bary)
        n = len(tri)
        position, normal, tangent, binormal = (np.empty((n, 3)) for _ in range(4))
        uv = np.zeros((n, 2))
        uvs = readonly(self.uvs if self.uvs is not None else np.zeros((0, 2)))
        _evaluate_kernel(
            self._verts(pose),
            self.vertex_normals(pose),
            self.vertex_tangents(pose),
            uvs,
            self.faces,
            tri,
            b,
            position,
            normal,
            tangent,
            binormal,
            uv,
        )
        return SurfacePoints(position, normal, tangent, binormal, uv)

    def closest_points(
        self, points: object, pose: str = "rest"
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Exact closest surface points: (triangles int64, bary (n, 2), distance (n,)).

        Candidates are the triangles whose bounding sphere comes within the distance
        to the nearest vertex; each is tested exactly, so the result is exact.
        """
        q = as_array(points, "points", np.float64)
        if q.ndim != 2 or q.shape[1] != 3:
            raise InputError(f"points must have shape (n, 3), got {q.shape}")
        _finite_rows(q, "points")
        vtree, ctree, centres, radii, used = self._trees(pose)
        verts = self._verts(pose)
        tri_out = np.zeros(len(q), dtype=np.int64)
        bary_out = np.zeros((len(q), 2))
        dist_out = np.zeros(len(q))
        radius = radii[used].max()
        for s, e, dv in _candidate_runs(q, vtree, ctree, radius):
            qc = q[s:e]
            lists = ctree.query_ball_point(qc, dv + radius + 1e-12, return_sorted=True)
            counts = np.array([len(c) for c in lists], dtype=np.int64)
            cand = used[np.concatenate(lists).astype(np.int64)]
            qi = np.repeat(np.arange(len(qc)), counts)
            gap = np.linalg.norm(qc[qi] - centres[cand], axis=1) - radii[cand]
            keep = gap <= dv[qi] * (1 + 1e-9) + 1e-12
            t, bu, bv, d2 = _closest_kernel(readonly(qc), verts, self.faces, qi[keep], cand[keep])
            tri_out[s:e] = t
            bary_out[s:e, 0], bary_out[s:e, 1] = bu, bv
            dist_out[s:e] = np.sqrt(d2)
        return tri_out, bary_out, dist_out

    def _trees(self, pose: str) -> _Trees:
        """KD-trees over used vertices and triangle centres, plus bounding-sphere radii."""

        def make(v: np.ndarray) -> _Trees:
            used = np.flatnonzero(~self.degenerate_faces)
            tri = v[self.faces]
            centres = tri.mean(axis=1)
            radii = np.linalg.norm(tri - centres[:, None], axis=2).max(axis=1)
            vtree = cKDTree(v[np.unique(self.faces[used])])
            return vtree, cKDTree(centres[used]), centres, radii, used

        return self.derived("trees", pose, make)

    # ------------------------------------------------------------------ export
    def to_trimesh(self, pose: str = "rest") -> trimesh.Trimesh:
        """A trimesh.Trimesh of the given pose (vertices not merged), with UVs if any."""
        import trimesh

        visual = None
        if self.uvs is not None:
            visual = trimesh.visual.TextureVisuals(uv=np.array(self.uvs))
        return trimesh.Trimesh(
            vertices=np.array(self._verts(pose)),
            faces=np.array(self.faces),
            visual=visual,
            process=False,
        )


@kernel(inline="always")
def closest_weights(
    px: float,
    py: float,
    pz: float,
    ax: float,
    ay: float,
    az: float,
    bx: float,
    by: float,
    bz: float,
    cx: float,
    cy: float,
    cz: float,
) -> tuple[float, float, float]:
    """Weights (wa, wb, wc) of the point of triangle abc closest to p, by Voronoi region
    (Ericson, RTCD §5.1.5). A vertex region gives two exact zeros, an edge region one.

    Scalar arguments: about 4× faster per call than array views of the corners, which
    matters for the millions of calls of an SDF build (mesh.sdf).
    """
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0  # vertex a
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0  # vertex b
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        w = d1 / (d1 - d3)
        return 1.0 - w, w, 0.0  # edge ab
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0  # vertex c
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return 1.0 - w, 0.0, w  # edge ac
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - w, w  # edge bc
    inv = 1.0 / (va + vb + vc)  # inside the face
    return va * inv, vb * inv, vc * inv


@kernel(nogil=True)
def _closest_kernel(
    q: np.ndarray, verts: np.ndarray, faces: np.ndarray, qi: np.ndarray, ti: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Best (triangle, u, v, squared distance) per query over candidate pairs (qi, ti).

    Ties keep the first candidate, so the answer does not depend on chunking.
    """
    n = q.shape[0]
    best_t = np.full(n, -1, dtype=np.int64)
    best_u = np.zeros(n)
    best_v = np.zeros(n)
    best_d = np.full(n, np.inf)
    for k in range(qi.shape[0]):
        i = qi[k]
        t = ti[k]
        a = verts[faces[t, 0]]
        b = verts[faces[t, 1]]
        c = verts[faces[t, 2]]
        wa, wb, wc = closest_weights(
            q[i, 0], q[i, 1], q[i, 2], a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]
        )
        d = 0.0
        for j in range(3):
            diff = q[i, j] - (wa * a[j] + wb * b[j] + wc * c[j])
            d += diff * diff
        if d < best_d[i]:
            best_d[i] = d
            best_t[i] = t
            best_u[i] = wa
            best_v[i] = wb
    return best_t, best_u, best_v, best_d


@kernel(parallel=True, nogil=True)
def _evaluate_kernel(
    verts: np.ndarray,
    normals: np.ndarray,
    tangents: np.ndarray,
    uvs: np.ndarray,
    faces: np.ndarray,
    tri: np.ndarray,
    bary: np.ndarray,
    position: np.ndarray,
    normal: np.ndarray,
    tangent: np.ndarray,
    binormal: np.ndarray,
    uv: np.ndarray,
) -> None:
    """Barycentric interpolation plus the root frame of Šik 2012 §2.2.3 for every sample."""
    for k in prange(tri.shape[0]):
        f0, f1, f2 = faces[tri[k], 0], faces[tri[k], 1], faces[tri[k], 2]
        w0, w1 = bary[k, 0], bary[k, 1]
        w2 = 1.0 - w0 - w1
        for a in range(3):
            position[k, a] = w0 * verts[f0, a] + w1 * verts[f1, a] + w2 * verts[f2, a]
            normal[k, a] = w0 * normals[f0, a] + w1 * normals[f1, a] + w2 * normals[f2, a]
            tangent[k, a] = w0 * tangents[f0, a] + w1 * tangents[f1, a] + w2 * tangents[f2, a]
        if uvs.shape[0] > 0:
            for a in range(2):
                uv[k, a] = w0 * uvs[f0, a] + w1 * uvs[f1, a] + w2 * uvs[f2, a]
        nx, ny, nz = normal[k, 0], normal[k, 1], normal[k, 2]
        ln = np.sqrt(nx * nx + ny * ny + nz * nz)
        if ln > 0.0:
            nx, ny, nz = nx / ln, ny / ln, nz / ln
        tx, ty, tz = tangent[k, 0], tangent[k, 1], tangent[k, 2]
        d = tx * nx + ty * ny + tz * nz
        tx, ty, tz = tx - d * nx, ty - d * ny, tz - d * nz
        lt = np.sqrt(tx * tx + ty * ty + tz * tz)
        if lt < 1e-9:  # tangent along the normal: perpendicular from the least aligned axis
            ax, ay, az = abs(nx), abs(ny), abs(nz)
            tx = 1.0 if ax <= ay and ax <= az else 0.0
            ty = 1.0 if tx == 0.0 and ay <= az else 0.0
            tz = 1.0 if tx == 0.0 and ty == 0.0 else 0.0
            d = tx * nx + ty * ny + tz * nz
            tx, ty, tz = tx - d * nx, ty - d * ny, tz - d * nz
            lt = np.sqrt(tx * tx + ty * ty + tz * tz)
        tx, ty, tz = tx / lt, ty / lt, tz / lt
        normal[k, 0], normal[k, 1], normal[k, 2] = nx, ny, nz
        tangent[k, 0], tangent[k, 1], tangent[k, 2] = tx, ty, tz
        binormal[k, 0] = ty * nz - tz * ny
        binormal[k, 1] = tz * nx - tx * nz
        binormal[k, 2] = tx * ny - ty * nx


def _candidate_runs(
    q: np.ndarray, vtree: cKDTree, ctree: cKDTree, radius: float
) -> Iterator[tuple[int, int, np.ndarray]]:
    """(start, end, distance to the nearest vertex of each) runs of the query points
    ``q`` whose candidate triangles (those whose bounding sphere, of at most ``radius``,
    comes within that distance) number at most :data:`MAX_CANDIDATES` together, or one
    point's when it alone has more: a point far from the skin (guides in other units, a
    hostile file) has nearly every triangle as a candidate, and 4,096 such points at
    once held gigabytes of them."""
    for s in range(0, len(q), 4096):
        dv, _ = vtree.query(q[s : s + 4096])
        counts = ctree.query_ball_point(q[s : s + 4096], dv + radius + 1e-12, return_length=True)
        for a, b in budget_runs(counts, MAX_CANDIDATES):
            yield s + a, s + b, dv[a:b]
