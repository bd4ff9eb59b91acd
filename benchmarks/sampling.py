"""Root sampler benchmark (Šik 2012 §4.1): DensitySampler against rejection sampling and
trimesh.

The mesh is the built-in head subdivided twice (111k triangles), the density a
1024² HDR-like texture (smooth log-noise over 10⁴:1 plus bright specks, the kind of
map where rejection sampling collapses). Every figure comes from this one run and
is printed next to its baseline: a NumPy-vectorised rejection sampler on the same
texture, ``trimesh.sample.sample_surface`` for uniform density, and a fixed numpy
yardstick. Run: ``.venv/bin/python benchmarks/sampling.py [--samples N]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import trimesh
from scipy.ndimage import gaussian_filter

from common import best_of, yardstick
from follicle.mesh.head import builtin_head
from follicle.mesh.sampling import DensitySampler
from follicle.mesh.skin import SkinMesh
from follicle.mesh.texture import Texture


def benchmark_mesh() -> SkinMesh:
    """The built-in head, each triangle split in four twice, UVs carried along."""
    head = builtin_head()
    verts = np.hstack([head.rest_vertices, head.uvs])
    faces = head.faces
    for _ in range(2):
        verts, faces = trimesh.remesh.subdivide(verts, faces)
    return SkinMesh(verts[:, :3], faces, uvs=verts[:, 3:], name="head×16")


def hdr_texture(size: int = 1024, specks: bool = True) -> Texture:
    """Log-noise spanning 10⁴:1 and (``specks``) 300 single texels 50× the brightest noise."""
    rng = np.random.default_rng(1)
    noise = gaussian_filter(rng.standard_normal((size, size)), size / 64, mode="wrap")
    noise = (noise - noise.min()) / np.ptp(noise)
    data = 10.0 ** (4.0 * noise - 4.0)
    at = rng.integers(0, size, (300, 2))
    if specks:
        data[at[:, 0], at[:, 1]] = 50.0
    return Texture(data.astype(np.float32), name="hdr")


def rejection_sample(mesh: SkinMesh, tex: Texture, n: int, seed: int = 0) -> tuple:
    """The textbook alternative (§2.1.2), vectorised: area-CDF proposals, accept ξ·max < f."""
    rng = np.random.default_rng(seed)
    cdf = np.cumsum(mesh.face_areas())
    corners = mesh.uvs[mesh.faces]
    top = float(tex.data[:, :, 0].max())
    tris, barys, have, proposed, rate = [], [], 0, 0, 1.0
    while have < n:  # batches sized by the acceptance seen so far, so little is wasted
        m = int(min(max(1.1 * (n - have) / rate, 4096), 4_000_000))
        tri = np.minimum(np.searchsorted(cdf, rng.random(m) * cdf[-1]), len(cdf) - 1)
        r = np.sqrt(rng.random(m))
        bary = np.stack([1.0 - r, rng.random(m) * r], axis=1)
        w = np.stack([bary[:, 0], bary[:, 1], 1.0 - bary.sum(axis=1)], axis=1)
        uv = np.einsum("nk,nkj->nj", w, corners[tri])
        keep = rng.random(m) * top < tex.sample(uv)
        tris.append(tri[keep])
        barys.append(bary[keep])
        have += int(keep.sum())
        proposed += m
        rate = have / proposed if have else rate / 16
    return np.concatenate(tris)[:n], np.concatenate(barys)[:n], have / proposed


def positions(mesh: SkinMesh, tri: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """3D points of (triangle, bary) samples, as trimesh returns them."""
    v = mesh.rest_vertices[mesh.faces[tri]]
    u, w = bary[:, 0:1], bary[:, 1:2]
    return u * v[:, 0] + w * v[:, 1] + (1.0 - u - w) * v[:, 2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, default=20_000_000)
    args = parser.parse_args()
    n = args.samples

    mesh = benchmark_mesh()
    tex = hdr_texture()
    DensitySampler(mesh, tex).sample(1000)  # JIT warm-up (cached after the first run)
    base = yardstick()

    rows: list[tuple[str, float, str, float]] = []  # figure, value, baseline name, baseline

    def row(name: str, value: float, base_name: str, base_value: float) -> None:
        rows.append((name, value / 1e6, base_name, base_value / 1e6))

    start = time.perf_counter()
    hdr = DensitySampler(mesh, tex)
    pre = time.perf_counter() - start
    pre = min(pre, best_of(lambda: DensitySampler(mesh, tex), repeat=2))
    rate = n / best_of(lambda: hdr.sample(n))
    m_rej = 50_000
    t_rej = best_of(lambda: rejection_sample(mesh, tex, m_rej), repeat=2)
    acceptance = rejection_sample(mesh, tex, 10_000)[2]
    acceptance_smooth = rejection_sample(mesh, hdr_texture(specks=False), 10_000)[2]
    row("HDR 1024²: DensitySampler (M samples/s)", rate, "rejection", m_rej / t_rej)

    smooth = hdr_texture(specks=False)
    smooth_sampler = DensitySampler(mesh, smooth)
    smooth_rate = n / best_of(lambda: smooth_sampler.sample(n), repeat=2)
    t_smooth = best_of(lambda: rejection_sample(mesh, smooth, m_rej), repeat=2)
    row("log-noise without specks (M samples/s)", smooth_rate, "rejection", m_rej / t_smooth)

    halton_rate = n / best_of(lambda: hdr.sample(n, sequence="halton"), repeat=2)
    row("HDR 1024²: Halton sequence (M samples/s)", halton_rate, "random", rate)

    uniform = DensitySampler(mesh)
    m_tm = n // 4
    tm = trimesh.Trimesh(mesh.rest_vertices, mesh.faces, process=False)
    t_tm = best_of(lambda: trimesh.sample.sample_surface(tm, m_tm, seed=1), repeat=2)
    u_rate = n / best_of(lambda: uniform.sample(n))
    u_pos_rate = m_tm / best_of(lambda: positions(mesh, *uniform.sample(m_tm)), repeat=2)
    row("uniform: DensitySampler (M samples/s)", u_rate, "trimesh", m_tm / t_tm)
    row("uniform: DensitySampler + 3D points", u_pos_rate, "trimesh", m_tm / t_tm)

    for factor in (0.25, 1, 4, 16):
        sampler = DensitySampler(mesh, tex, grid_factor=factor)
        r = n / best_of(lambda s=sampler: s.sample(n), repeat=2)
        row(f"HDR: grid_factor {factor} (M samples/s)", r, "factor 4", rate)
    one_cell = DensitySampler(mesh, tex, grid_factor=1 / hdr.sub_triangle_count)
    r = n / best_of(lambda: one_cell.sample(n), repeat=2)
    row("HDR: one cell = plain bisection (M/s)", r, "factor 4", rate)

    print(
        f"mesh {mesh.face_count:,} triangles; texture {tex.width}x{tex.height} HDR"
        f" (max/mean {tex.data.max() / tex.data.mean():,.0f}); {n:,} samples per run"
    )
    print(
        f"preprocessing {pre:.3f} s, {hdr.sub_triangle_count:,} sub-triangles"
        f" (depth ≤ {int(hdr.depths.max())}), memory {hdr.memory_bytes / 2**20:.1f} MiB"
        f" ({hdr.memory_bytes / hdr.sub_triangle_count:.1f} B per sub-triangle with the grid)"
    )
    print(
        f"rejection sampling accepts {acceptance:.2%} of its proposals"
        f" ({acceptance_smooth:.2%} without the specks)"
    )
    print(f"{'figure':<44} {'value':>9} {'baseline':>10} {'value':>9} {'ratio':>8}")
    for name, value, base_name, base_value in rows:
        ratio = value / base_value
        print(f"{name:<44} {value:9.3f} {base_name:>10} {base_value:9.3f} {ratio:8.2f}")
    print(f"{'yardstick: np.sort of 4 M floats (s)':<44} {base:9.4f}")


if __name__ == "__main__":
    main()
