"""The groom benchmark's baseline: hair growth written in plain NumPy/SciPy, no numba, no follicle.

The same steps as follicle's generator, as a competent user would vectorise them:
roots by an area × density CDF and ``np.searchsorted``, guides resampled by arc length
into their root frames, IDW over a ``cKDTree`` (``workers=-1``), frizz and kink from a
vectorised improved Perlin noise, per-hair HSV colour variation. Hairs are processed in
chunks so temporaries stay small. follicle supplies only the inputs (mesh arrays, scalp
texture, guide curves). Run alone: ``.venv/bin/python benchmarks/groom_baseline.py``.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

CHUNK = 65536  # hairs per chunk


@dataclass(frozen=True)
class Settings:
    """The groom settings both implementations get (names as in follicle's GroomParams)."""

    count: int = 1_000_000
    seed: int = 1
    vertices: int = 16
    guide_samples: int = 3
    frizz_root: float = 0.002
    frizz_tip: float = 0.006
    frizz_frequency: tuple[float, float, float] = (40.0, 40.0, 40.0)
    kink_root: float = 0.0
    kink_tip: float = 0.002
    kink_frequency: tuple[float, float, float] = (120.0, 120.0, 120.0)
    hue_variation: float = 8.0
    saturation_variation: float = 0.05
    value_variation: float = 0.1
    root_width: float = 80e-6
    tip_width: float = 30e-6
    root_color: tuple[float, float, float] = (0.03, 0.017, 0.009)
    tip_color: tuple[float, float, float] = (0.085, 0.05, 0.025)
    root_opacity: float = 1.0
    tip_opacity: float = 1.0


# ----------------------------------------------------------------------------- noise
_PERM = np.random.default_rng(2002).permutation(256).astype(np.intp)
_PERM = np.concatenate([_PERM, _PERM])  # doubled: no wrap-around indexing
# improved-noise gradients: the 12 cube edges, 4 repeated to fill 16 hash values
_GX = np.array([1, -1, 1, -1, 1, -1, 1, -1, 0, 0, 0, 0, 1, 0, -1, 0], dtype=np.float64)
_GY = np.array([1, 1, -1, -1, 0, 0, 0, 0, 1, -1, 1, -1, 1, -1, 1, -1], dtype=np.float64)
_GZ = np.array([0, 0, 0, 0, 1, 1, -1, -1, 1, 1, -1, -1, 0, 1, 0, -1], dtype=np.float64)
# offsets decorrelating the three components of noise3
_OFFSETS = np.array([[17.13, 3.71, 29.93], [-11.37, 23.19, -5.83], [7.61, -31.27, 13.49]])


def _fade(t: np.ndarray) -> np.ndarray:
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def _grad(h: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    h = _PERM[h] & 15
    return _GX[h] * x + _GY[h] * y + _GZ[h] * z


def perlin(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Ken Perlin's improved noise (2002) at arrays of points, vectorised; about [-1, 1]."""
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    xi = fx.astype(np.intp) & 255
    yi = fy.astype(np.intp) & 255
    zi = fz.astype(np.intp) & 255
    x, y, z = x - fx, y - fy, z - fz
    u, v, w = _fade(x), _fade(y), _fade(z)
    a = _PERM[xi] + yi
    b = _PERM[xi + 1] + yi
    aa, ab = _PERM[a] + zi, _PERM[a + 1] + zi
    ba, bb = _PERM[b] + zi, _PERM[b + 1] + zi
    x1, y1, z1 = x - 1.0, y - 1.0, z - 1.0

    def lerp(t: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        return p + t * (q - p)

    near = lerp(
        v,
        lerp(u, _grad(aa, x, y, z), _grad(ba, x1, y, z)),
        lerp(u, _grad(ab, x, y1, z), _grad(bb, x1, y1, z)),
    )
    far = lerp(
        v,
        lerp(u, _grad(aa + 1, x, y, z1), _grad(ba + 1, x1, y, z1)),
        lerp(u, _grad(ab + 1, x, y1, z1), _grad(bb + 1, x1, y1, z1)),
    )
    return lerp(w, near, far)


def noise3(p: np.ndarray) -> np.ndarray:
    """Vector noise (m, 3) at points (m, 3): three Perlin values at offset inputs, in [-1, 1]."""
    out = np.empty(p.shape, dtype=np.float64)
    for c in range(3):
        q = p + _OFFSETS[c]
        out[:, c] = perlin(q[:, 0], q[:, 1], q[:, 2])
    return np.clip(out, -1.0, 1.0, out=out)


# ----------------------------------------------------------------------------- colour
def rgb_to_hsv(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) RGB to HSV with hue in degrees [0, 360), s and v in [0, 1] (for v ≤ 1)."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    v = rgb.max(axis=-1)
    c = v - rgb.min(axis=-1)
    safe = np.where(c > 0, c, 1.0)
    h = np.where(
        v == r, (g - b) / safe, np.where(v == g, 2.0 + (b - r) / safe, 4.0 + (r - g) / safe)
    )
    h = np.where(c > 0, (60.0 * h) % 360.0, 0.0)
    s = np.where(v > 0, c / np.where(v > 0, v, 1.0), 0.0)
    return np.stack([h, s, v], axis=-1)


def hsv_to_rgb(h: np.ndarray, s: np.ndarray, v: np.ndarray) -> np.ndarray:
    """HSV (hue in degrees, any range) to RGB (..., 3): c = v − v·s·clip(min(k, 4 − k), 0, 1)."""
    h6 = (h / 60.0) % 6.0
    vs = v * s
    out = np.empty(h.shape + (3,), dtype=np.float32)
    for c, n in enumerate((5.0, 3.0, 1.0)):
        k = (n + h6) % 6.0
        out[..., c] = v - vs * np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0)
    return out


# ----------------------------------------------------------------------------- inputs
def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def _frames(normal: np.ndarray, tangent: np.ndarray) -> np.ndarray:
    """Orthonormal root frames (n, 3, 3), rows tangent, binormal = T × N, normal."""
    n = _unit(normal)
    t = tangent - np.sum(tangent * n, axis=1, keepdims=True) * n
    bad = np.linalg.norm(t, axis=1) < 1e-9  # tangent along the normal: any perpendicular
    if bad.any():
        nb = n[bad]
        axis = np.eye(3)[np.argmin(np.abs(nb), axis=1)]  # the axis least along the normal
        t[bad] = axis - np.sum(axis * nb, axis=1, keepdims=True) * nb
    t = _unit(t)
    return np.stack([t, np.cross(t, n), n], axis=1)


def _surface(mesh: dict, tri: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (n, 3) and frames (n, 3, 3) at triangles with barycentric weights (n, 3)."""
    fv = mesh["faces"][tri]
    pos = np.einsum("nk,nkj->nj", w, mesh["vertices"][fv])
    nrm = np.einsum("nk,nkj->nj", w, mesh["normals"][fv])
    tan = np.einsum("nk,nkj->nj", w, mesh["tangents"][fv])
    return pos, _frames(nrm, tan)


def mesh_arrays(mesh: object) -> dict:
    """The raw arrays of a follicle SkinMesh the baseline needs (vertex data, UVs, scalp map)."""
    return {
        "vertices": np.asarray(mesh.rest_vertices),
        "faces": np.asarray(mesh.faces),
        "normals": np.asarray(mesh.vertex_normals("rest")),
        "tangents": np.asarray(mesh.vertex_tangents("rest")),
        "uvs": np.asarray(mesh.uvs),
        "density": np.asarray(mesh.textures["scalp"].data[:, :, 0], dtype=np.float64),
    }


def guide_arrays(curves: object) -> dict:
    """Guide vertices and offsets, root triangles and barycentrics from a follicle HairCurves."""
    return {
        "points": np.asarray(curves.points, dtype=np.float64),
        "offsets": np.asarray(curves.offsets),
        "root_triangle": np.asarray(curves.curve_data["root_triangle"]),
        "root_bary": np.asarray(curves.curve_data["root_bary"], dtype=np.float64),
    }


def _bilinear(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Clamped bilinear lookup; v = 0 is the last image row, texel centres at (j + ½) / W."""
    hgt, wid = img.shape
    x = np.clip(uv[:, 0] * wid - 0.5, 0.0, wid - 1.0)
    y = np.clip((1.0 - uv[:, 1]) * hgt - 0.5, 0.0, hgt - 1.0)
    x0 = np.minimum(x.astype(np.intp), wid - 2)
    y0 = np.minimum(y.astype(np.intp), hgt - 2)
    fx, fy = x - x0, y - y0
    top = img[y0, x0] * (1 - fx) + img[y0, x0 + 1] * fx
    bottom = img[y0 + 1, x0] * (1 - fx) + img[y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def _bary_weights(bary: np.ndarray) -> np.ndarray:
    """(u, v) barycentrics to the three vertex weights (u, v, 1 − u − v)."""
    return np.stack([bary[:, 0], bary[:, 1], 1.0 - bary[:, 0] - bary[:, 1]], axis=1)


def guide_shapes(mesh: dict, guides: dict, vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Guide roots (S, 3) and shapes resampled by arc length in their root frames (S, n, 3)."""
    pts, offs = guides["points"], guides["offsets"]
    s_new = np.linspace(0.0, 1.0, vertices)
    rel = np.empty((len(offs) - 1, vertices, 3))
    for i in range(len(offs) - 1):
        p = pts[offs[i] : offs[i + 1]]
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        s /= s[-1]
        for c in range(3):
            rel[i, :, c] = np.interp(s_new, s, p[:, c])
    rel -= rel[:, :1]
    roots, frames = _surface(mesh, guides["root_triangle"], _bary_weights(guides["root_bary"]))
    return roots, np.einsum("snk,sak->sna", rel, frames)


# ----------------------------------------------------------------------------- growth
def grow(mesh: dict, guides: dict, settings: Settings, chunk: int = CHUNK) -> dict[str, np.ndarray]:
    """Grow ``settings.count`` hairs: points (V, 3), width, opacity (V,), color, normal (V, 3)."""
    st = settings
    n_v = st.vertices
    rng = np.random.default_rng(st.seed)

    # roots: per-triangle area × density at the UV centroid, then a CDF
    v, f = mesh["vertices"], mesh["faces"]
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    cdf = np.cumsum(area * _bilinear(mesh["density"], mesh["uvs"][f].mean(axis=1)))

    guide_roots, local_guides = guide_shapes(mesh, guides, n_v)
    tree = cKDTree(guide_roots)
    k = min(st.guide_samples + 1, len(guide_roots))

    t = np.linspace(0.0, 1.0, n_v)
    frizz_amp = np.minimum(
        st.frizz_root * 4.0 * (t - t * t) + st.frizz_tip * t * t, max(st.frizz_root, st.frizz_tip)
    )
    kink_amp = (1.0 - t) * st.kink_root + t * st.kink_tip
    hsv_root, hsv_tip = rgb_to_hsv(np.array([st.root_color, st.tip_color]))
    width_t = ((1.0 - t) * st.root_width + t * st.tip_width).astype(np.float32)
    opacity_t = ((1.0 - t) * st.root_opacity + t * st.tip_opacity).astype(np.float32)

    total = st.count * n_v
    out = {
        "points": np.empty((total, 3), np.float32),
        "width": np.empty(total, np.float32),
        "opacity": np.empty(total, np.float32),
        "color": np.empty((total, 3), np.float32),
        "normal": np.empty((total, 3), np.float32),
    }
    for start in range(0, st.count, chunk):
        n = min(chunk, st.count - start)
        rows = slice(start * n_v, (start + n) * n_v)

        # 1. roots: triangle by CDF, barycentric by the square-root trick, frame
        tri = np.minimum(np.searchsorted(cdf, rng.random(n) * cdf[-1], side="right"), len(f) - 1)
        r1, r2 = np.sqrt(rng.random(n)), rng.random(n)
        w = np.stack([1.0 - r1, r1 * (1.0 - r2), r1 * r2], axis=1)
        root, frame = _surface(mesh, tri, w)

        # 3. IDW over the k nearest guide roots, blended in root-local frames
        dist, idx = tree.query(root, k=k, workers=-1)
        if k > 1:
            r = dist[:, -1:]
            with np.errstate(divide="ignore", invalid="ignore"):
                wt = ((r - dist) / (r * dist)) ** 2
            exact = dist[:, 0] <= 1e-12
            wt[exact] = 0.0
            wt[exact, 0] = 1.0
            wt[~np.isfinite(wt).all(axis=1) | (wt.sum(axis=1) <= 0)] = 1.0
            wt /= wt.sum(axis=1, keepdims=True)
        else:
            idx, wt = idx[:, None], np.ones((n, 1))
        local = np.einsum("hk,hkvc->hvc", wt, local_guides[idx])

        # 4. frizz: one noise vector per hair at its root, bent towards the skin
        fz = noise3(root * np.asarray(st.frizz_frequency))
        fz[:, 2] = -np.abs(fz[:, 2])
        z = local[:, :, 2].copy()
        local += fz[:, None, :] * frizz_amp[None, :, None]
        local[:, :, 2] = np.maximum(local[:, :, 2], np.minimum(z, 0.0))

        # place in the hair's frame; kink: noise at every vertex, applied in that frame
        world = root[:, None, :] + np.matmul(local, frame)
        kink = noise3(world.reshape(-1, 3) * np.asarray(st.kink_frequency)).reshape(n, n_v, 3)
        world += np.matmul(kink * kink_amp[None, :, None], frame)
        world[:, 0] = root
        out["points"][rows] = world.reshape(-1, 3)

        # 5. colour: per-hair HSV shifts, root → tip along the shortest hue route
        dh, ds, dv = (
            (rng.random((3, n)) - 0.5)
            * 2.0
            * np.array([[st.hue_variation], [st.saturation_variation], [st.value_variation]])
        )
        h1 = hsv_root[0] - dh
        h2 = hsv_tip[0] - dh
        s1, s2 = np.clip(hsv_root[1] - ds, 0, 1), np.clip(hsv_tip[1] - ds, 0, 1)
        v1, v2 = np.clip(hsv_root[2] - dv, 0, 1), np.clip(hsv_tip[2] - dv, 0, 1)
        hue_route = (h2 - h1 + 180.0) % 360.0 - 180.0
        out["color"][rows] = hsv_to_rgb(
            h1[:, None] + t * hue_route[:, None],
            s1[:, None] + t * (s2 - s1)[:, None],
            v1[:, None] + t * (v2 - v1)[:, None],
        ).reshape(-1, 3)
        out["width"][rows] = np.tile(width_t, n)
        out["opacity"][rows] = np.tile(opacity_t, n)
        out["normal"][rows] = np.repeat(frame[:, 2].astype(np.float32), n_v, axis=0)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--count", type=int, default=100_000)
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()

    from follicle.groom.builtin_guides import builtin_guides
    from follicle.mesh.head import builtin_head

    head = builtin_head()
    mesh, guides = mesh_arrays(head), guide_arrays(builtin_guides("long", head, count=1000))
    settings = Settings(count=args.count)
    best = np.inf
    for _ in range(args.repeat):
        start = time.perf_counter()
        out = grow(mesh, guides, settings)
        best = min(best, time.perf_counter() - start)
    pts = out["points"]
    print(
        f"baseline: {args.count:,} hairs × {settings.vertices} vertices in {best:.3f} s"
        f" ({args.count / best:,.0f} hairs/s)"
    )
    print(
        f"finite: {all(np.isfinite(a).all() for a in out.values())};"
        f" bounds {np.round(pts.min(0).astype(float), 3).tolist()}"
        f" … {np.round(pts.max(0).astype(float), 3).tolist()}"
    )
    print(f"output {sum(a.nbytes for a in out.values()) / 2**20:.0f} MiB")


if __name__ == "__main__":
    main()
