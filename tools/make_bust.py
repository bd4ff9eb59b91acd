"""Build ``src/follicle/mesh/data/bust.npz``, the built-in bust, from its signed distance
field (:func:`follicle.mesh.bust.bust_field`); optionally render pictures of it.

    .venv/bin/pip install scikit-image fast-simplification shapely  # dev-only, not runtime
    .venv/bin/python tools/make_bust.py                       # writes the .npz
    .venv/bin/python tools/make_bust.py --no-mesh --pictures /tmp/bust  # the views

Steps: the field is sampled on a grid of ``--voxel`` metres, only in blocks near the
surface (the others get the sign of their centre); marching cubes (Lorensen and Cline
1987, scikit-image) gives the surface, quadric decimation (Garland and Heckbert 1997,
fast-simplification) brings it to ``--triangles``, and every vertex is projected back onto
the field's zero set by Newton steps, four times after sliding half way to its neighbours'
mean (even triangles). The mesh is then cut along the planes z = 0 and y = 0 through
the UV centre (splitting the triangles that cross them; the new vertices projected back
within their plane) so the spherical UV map (:mod:`follicle.mesh.bust`) has its seam
(the half plane z = 0, y < 0) and its poles (in the ears) on vertices: each quarter
gets its own UVs, vertices are welded where position and UV agree, and a pole vertex
gets one copy per triangle, its v the mean of the triangle's other two. The scalp map is
baked per texel: the texel's direction is traced to the outermost surface point along
it, where the built-in head's hairline rule
(:func:`follicle.mesh.head._scalp_density_at`) gives the density.

The face and ears may be reshaped, the hair-bearing scalp may not (guides and settled
grooms rest on it): ``tests/test_bust.py`` checks the field within 0.5 mm of the scalp's
surface under every scalp texel, kept in ``tests/data/bust_scalp_radius.npz``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from follicle.mesh.bust import BUST_BOTTOM, BUST_DATA, UV_CENTRE, bust_field, ear_distance
from follicle.mesh.head import _scalp_density_at

if TYPE_CHECKING:
    import trimesh

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "src" / "follicle" / "mesh" / BUST_DATA
LO = np.array([-0.26, BUST_BOTTOM - 0.012, -0.17])
HI = np.array([0.26, 0.14, 0.17])
BLOCK = 16
SCALP_SIZE = 256
EAR_CLEAR = (0.010, 0.020)  # m from an ear's flap: no hair within the first, full beyond


def sample_grid(voxel: float) -> tuple[np.ndarray, np.ndarray]:
    """The field on a grid over [LO, HI]: exact in blocks near the surface, ±1 cm else."""
    shape = np.ceil((HI - LO) / voxel).astype(int) + 1
    shape = ((shape + BLOCK - 1) // BLOCK) * BLOCK
    vol = np.empty(shape, dtype=np.float32)
    nb = shape // BLOCK
    bi = np.stack(np.meshgrid(*[np.arange(n) for n in nb], indexing="ij"), -1).reshape(-1, 3)
    centres = LO + (bi * BLOCK + (BLOCK - 1) / 2) * voxel
    dc = bust_field(centres)
    near = np.abs(dc) < 1.5 * (BLOCK * voxel * np.sqrt(3) / 2) + 0.004
    local = np.stack(np.meshgrid(*[np.arange(BLOCK)] * 3, indexing="ij"), -1).reshape(-1, 3)
    for b, d in zip(bi[~near], dc[~near], strict=True):
        i, j, k = b * BLOCK
        vol[i : i + BLOCK, j : j + BLOCK, k : k + BLOCK] = np.sign(d) * 0.01
    todo = bi[near]
    for s in range(0, len(todo), 64):
        chunk = todo[s : s + 64]
        idx = (chunk[:, None, :] * BLOCK + local[None]).reshape(-1, 3)
        vals = bust_field(LO + idx * voxel).astype(np.float32)
        vol[idx[:, 0], idx[:, 1], idx[:, 2]] = vals
    print(f"grid {tuple(shape)}, {near.sum()} of {len(bi)} blocks evaluated")
    return vol, LO


def project(verts: np.ndarray, steps: int = 4, keep: np.ndarray | None = None) -> np.ndarray:
    """Newton steps towards the field's zero set: p ← p − f ∇f / |∇f|²; where ``keep``
    (n, 3) bool is set, that coordinate is held (a vertex slides within its cut plane)."""
    h = 1e-5
    for _ in range(steps):
        f = bust_field(verts)
        grad = np.stack(
            [(bust_field(verts + h * e) - bust_field(verts - h * e)) / (2 * h) for e in np.eye(3)],
            axis=1,
        )
        if keep is not None:
            grad[keep] = 0.0
        verts = verts - (f / np.maximum(np.sum(grad * grad, axis=1), 1e-12))[:, None] * grad
    return verts


def surface(voxel: float, triangles: int) -> trimesh.Trimesh:
    import fast_simplification
    import trimesh
    from skimage.measure import marching_cubes

    vol, origin = sample_grid(voxel)
    v, f, _, _ = marching_cubes(vol, level=0.0, spacing=(voxel,) * 3)
    v = v + origin
    mesh = trimesh.Trimesh(v, f, process=True)
    if mesh.volume < 0:
        mesh.invert()
    print(f"marching cubes: {len(mesh.faces)} triangles")
    parts = mesh.split(only_watertight=False)
    mesh = max(parts, key=lambda m: len(m.faces))
    v, f = fast_simplification.simplify(
        np.asarray(mesh.vertices), np.asarray(mesh.faces, dtype=np.int32), target_count=triangles
    )
    mesh = trimesh.Trimesh(unfold(relax(project(v), f), f), f, process=True)
    print(f"decimated: {len(mesh.faces)} triangles")
    return mesh


def folded(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """The faces whose normal leans against the field's gradient at their centre (a
    fold left by decimation and projection in tight places: ears, lids, nostrils; a
    renderer shades them dark, Cycles as black specks): (F,) bool."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    normal = np.cross(b - a, c - a)
    centre = (a + b + c) / 3
    h = 1e-5
    grad = np.stack(
        [(bust_field(centre + h * e) - bust_field(centre - h * e)) / (2 * h) for e in np.eye(3)],
        axis=1,
    )
    cos = np.sum(normal * grad, axis=1) / np.maximum(
        np.linalg.norm(normal, axis=1) * np.linalg.norm(grad, axis=1), 1e-20
    )
    return cos < 0.2


def unfold(v: np.ndarray, f: np.ndarray, rounds: int = 40) -> np.ndarray:
    """Untangle :func:`folded` faces: their vertices and their neighbours' move to their
    neighbours' mean and back onto the surface, a round at a time, until none is left."""
    import trimesh

    mesh = trimesh.Trimesh(v, f, process=False)
    adj = mesh.edges_sparse.astype(float)
    adj = ((adj + adj.T) > 0).astype(float)
    degree = np.asarray(adj.sum(axis=1)).ravel()
    done = 0
    while done < rounds:
        bad = folded(v, f)
        if not bad.any():
            break
        done += 1
        moving = np.zeros(len(v), bool)
        moving[f[bad].ravel()] = True
        moving |= (adj @ moving.astype(float)) > 0  # and their neighbours
        mean = (adj @ v) / degree[:, None]
        v = v.copy()
        v[moving] = project(mean[moving], steps=3)
    print(f"unfolded: {int(folded(v, f).sum())} folded faces left after {done} rounds")
    return v


def relax(v: np.ndarray, f: np.ndarray, rounds: int = 4) -> np.ndarray:
    """Even out the triangles: move each vertex half way to its neighbours' mean within
    its tangent plane, then back onto the surface."""
    import trimesh

    for _ in range(rounds):
        mesh = trimesh.Trimesh(v, f, process=False)
        adj = mesh.edges_sparse.astype(float)
        adj = ((adj + adj.T) > 0).astype(float)
        mean = (adj @ v) / np.asarray(adj.sum(axis=1))
        n = mesh.vertex_normals
        step = mean - v
        step -= np.sum(step * n, axis=1)[:, None] * n
        v = project(v + 0.5 * step, steps=2)
    return v


def uv_of(p: np.ndarray, sy: float, sz: float) -> np.ndarray:
    """Spherical UVs of points in the quarter (sign y, sign z); signed zeros put points on
    the planes on this quarter's side of the seam."""
    r = np.linalg.norm(p, axis=1)
    u = np.arccos(np.clip(p[:, 0] / r, -1.0, 1.0)) / np.pi
    v = 0.5 + np.arctan2(sz * np.abs(p[:, 2]), sy * np.abs(p[:, 1])) / (2 * np.pi)
    return np.stack([u, v], axis=1)


def cut_and_map(mesh: trimesh.Trimesh, snap: float) -> tuple[np.ndarray, ...]:
    """Vertices, faces and UVs with the seam and poles on vertices (see the module doc)."""
    import trimesh

    v = np.array(mesh.vertices) - UV_CENTRE  # about the UV centre from here on
    v[np.abs(v[:, 1]) < snap, 1] = 0.0  # no slivers where the planes pass near vertices
    v[np.abs(v[:, 2]) < snap, 2] = 0.0
    mesh = trimesh.Trimesh(v, mesh.faces, process=False)
    verts, faces, uvs = [], [], []
    count = 0
    for sy in (1.0, -1.0):
        half = trimesh.intersections.slice_mesh_plane(mesh, (0, sy, 0), (0, 0, 0))
        for sz in (1.0, -1.0):
            q = trimesh.intersections.slice_mesh_plane(half, (0, 0, sz), (0, 0, 0))
            p = np.array(q.vertices)
            p[np.abs(p[:, 1]) < 1e-9, 1] = 0.0
            p[np.abs(p[:, 2]) < 1e-9, 2] = 0.0
            # new vertices on the cuts lie on chords: back onto the surface, in their planes
            keep = np.zeros(p.shape, dtype=bool)
            keep[:, 1], keep[:, 2] = p[:, 1] == 0.0, p[:, 2] == 0.0
            on = keep.any(axis=1)
            p[on] = project(p[on] + UV_CENTRE, keep=keep[on]) - UV_CENTRE
            verts.append(p)
            uvs.append(uv_of(p, sy, sz))
            faces.append(np.asarray(q.faces) + count)
            count += len(p)
    p, f, uv = np.concatenate(verts), np.concatenate(faces), np.concatenate(uvs)
    # poles: one copy per triangle, v from the triangle's other corners
    pole = (p[:, 1] == 0.0) & (p[:, 2] == 0.0)
    extra_p, extra_uv = [], []
    for t in np.flatnonzero(pole[f].any(axis=1)):
        corners = f[t]
        others = corners[~pole[corners]]
        for c in range(3):
            if pole[corners[c]]:
                extra_p.append(p[corners[c]])
                extra_uv.append((uv[corners[c], 0], uv[others, 1].mean()))
                f[t, c] = len(p) + len(extra_p) - 1
    p = np.concatenate([p, np.array(extra_p).reshape(-1, 3)])
    uv = np.concatenate([uv, np.array(extra_uv).reshape(-1, 2)])
    # weld equal (position, uv)
    key = np.round(np.concatenate([p * 1e7, uv * 1e7], axis=1)).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    f = inverse.reshape(-1)[f]
    p, uv = p[first], uv[first]
    used, f = np.unique(f, return_inverse=True)
    f = f.reshape(-1, 3)
    p, uv = p[used], uv[used]
    # drop the zero-area triangles a slice can leave
    area = np.linalg.norm(np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]]), axis=1)
    f = f[area > 1e-12]
    return p + UV_CENTRE, f, uv


def outermost(d: np.ndarray) -> np.ndarray:
    """The outermost zero of the field along rays from the UV centre in directions d."""
    c = np.asarray(UV_CENTRE)
    t = np.full(len(d), 0.6)
    for _ in range(200):
        f = bust_field(c + d * t[:, None])
        t = t - np.maximum(f, 2e-4) * (f > 0)
    lo, hi = t, t + 2e-4  # f(lo) <= 0 < f(hi) up to the last step
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        inside = bust_field(c + d * mid[:, None]) <= 0
        lo, hi = np.where(inside, mid, lo), np.where(inside, hi, mid)
    return c + d * lo[:, None]


def scalp_map(n: int) -> np.ndarray:
    """The scalp map, n × n: the head's hairline rule at each texel's outermost surface
    point, kept off the ears (none within 10 mm of an ear's flap, full from 20 mm; the
    UV poles lie in the ears, where texels of ear and head crowd together)."""
    p = texel_points(n)
    lo, hi = EAR_CLEAR
    x = np.clip((ear_distance(p) - lo) / (hi - lo), 0.0, 1.0)
    return (_scalp_density_at(p) * x * x * (3.0 - 2.0 * x)).reshape(n, n)


def texel_points(n: int) -> np.ndarray:
    c = (np.arange(n) + 0.5) / n
    u = np.broadcast_to(c[None, :], (n, n)).ravel()
    v = np.broadcast_to(1.0 - c[:, None], (n, n)).ravel()
    a, phi = np.pi * u, 2 * np.pi * (v - 0.5)
    d = np.stack([np.cos(a), np.sin(a) * np.cos(phi), np.sin(a) * np.sin(phi)], axis=1)
    return outermost(d)


def pictures(folder: Path) -> None:
    """Front, three-quarter, side and back views, bare and with 20,000 hairs from
    builtin:long, 800² (``bust_VIEW.png``, ``bust_VIEW_hair.png``); the bare front and
    the three-quarter view with hair also as the small pictures of ``docs/``."""
    from PIL import Image

    import follicle
    from follicle.render.camera import Camera

    bust = follicle.load_mesh("builtin:bust")
    target = np.array([0.0, -0.10, 0.0])
    views = {
        "front": (0.0, 0.0, 1.0),
        "three_quarter": (0.7, 0.1, 0.75),
        "side": (1.0, 0.0, 0.0),
        "back": (0.0, 0.1, -1.0),
    }
    hair = follicle.Groom(bust, follicle.load_guides("builtin:long", bust)).generate(20000)
    folder.mkdir(parents=True, exist_ok=True)
    for name, direction in views.items():
        eye = target + 1.05 * np.asarray(direction) / np.linalg.norm(direction)
        cam = Camera(eye=eye, target=target, fov_y=35.0)
        for what, curves in (("", None), ("_hair", hair)):
            out = folder / f"bust_{name}{what}.png"
            image = follicle.render_image(
                curves, mesh=bust, engine="cpu", size=(800, 800), camera=cam, out=out
            )
            print("wrote", out)
            if (name, what) in (("front", ""), ("three_quarter", "_hair")):
                small = Image.fromarray(image[:, :, :3]).resize((480, 480), Image.LANCZOS)
                small.quantize(colors=128).save(ROOT / "docs" / f"bust_{name}.png", optimize=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--voxel", type=float, default=0.0014)
    ap.add_argument("--triangles", type=int, default=37000)
    ap.add_argument("--pictures", type=Path, default=None)
    ap.add_argument("--no-mesh", action="store_true", help="only render the pictures")
    ap.add_argument(
        "--scalp-only", action="store_true", help="bake the scalp map again, keep the mesh"
    )
    args = ap.parse_args()
    if args.scalp_only:
        with np.load(OUT) as data:
            arrays = dict(data)
        arrays["scalp"] = scalp_map(SCALP_SIZE).astype(np.float32)
        np.savez_compressed(OUT, **arrays)
        print(f"wrote {OUT}: the scalp map baked again, {OUT.stat().st_size} bytes")
    elif not args.no_mesh:
        mesh = surface(args.voxel, args.triangles)
        p, f, uv = cut_and_map(mesh, snap=0.25 * args.voxel)
        scalp = scalp_map(SCALP_SIZE)
        OUT.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(
            OUT,
            vertices=p.astype(np.float32),
            faces=f.astype(np.int32),
            uvs=uv.astype(np.float32),
            scalp=scalp.astype(np.float32),
        )
        print(f"wrote {OUT}: {len(p)} vertices, {len(f)} triangles, {OUT.stat().st_size} bytes")
    if args.pictures is not None:
        pictures(args.pictures)


if __name__ == "__main__":
    main()
