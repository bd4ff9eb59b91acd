"""DensitySampler: distribution (chi-square against the texture), determinism, structure."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from scipy import stats

from follicle.errors import FollicleError, InputError
from follicle.mesh.sampling import DensitySampler, subtriangle_table
from follicle.mesh.skin import SkinMesh
from follicle.mesh.texture import Texture
from follicle.rng import purpose_id, uniforms

N = 1_000_000


def _plane(uv_scale: float = 1.0) -> SkinMesh:
    """The unit square z = 0 in two triangles, UVs = xy × uv_scale."""
    verts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    return SkinMesh(verts, [[0, 1, 2], [0, 2, 3]], uvs=verts[:, :2] * uv_scale, name="plane")


def _expected_per_cell(tex: Texture, cells: int, uv_scale: float = 1.0) -> np.ndarray:
    """Mass of the bilinear texture over a cells×cells grid on the plane (dense midpoint rule)."""
    n = cells * max(1, 2048 // cells)
    g = (np.arange(n) + 0.5) / n
    u, v = np.meshgrid(g, g)
    f = tex.sample(np.stack([u.ravel(), v.ravel()], axis=1) * uv_scale).reshape(n, n)
    k = n // cells
    mass = f.reshape(cells, k, cells, k).sum(axis=(1, 3))  # [v cell, u cell]
    return mass / mass.sum()


def _counts_per_cell(mesh: SkinMesh, tri, bary, cells: int) -> np.ndarray:
    p = mesh.evaluate(tri, bary).position
    iu = np.minimum((p[:, 0] * cells).astype(int), cells - 1)
    iv = np.minimum((p[:, 1] * cells).astype(int), cells - 1)
    counts = np.zeros((cells, cells))
    np.add.at(counts, (iv, iu), 1)
    return counts


def _chi_square_p(counts: np.ndarray, probability: np.ndarray) -> float:
    """p-value of counts against probabilities; cells expecting < 5 are pooled into one."""
    expected = probability.ravel() * counts.sum()
    counts = counts.ravel()
    small = expected < 5
    obs = np.append(counts[~small], counts[small].sum())
    exp = np.append(expected[~small], expected[small].sum())
    if exp[-1] == 0:
        assert obs[-1] == 0
        obs, exp = obs[:-1], exp[:-1]
    chi2 = float(((obs - exp) ** 2 / exp).sum())
    return float(stats.chi2.sf(chi2, len(obs) - 1))


def _checkerboard(n: int, low: float = 0.1, high: float = 1.0) -> np.ndarray:
    return np.where(np.indices((n, n)).sum(axis=0) % 2 == 0, high, low).astype(np.float32)


def _hdr(n: int, seed: int = 0) -> np.ndarray:
    """Independent texels spanning 10⁴:1 (log-uniform), the worst case for interpolation."""
    return (10.0 ** np.random.default_rng(seed).uniform(-4.0, 0.0, (n, n))).astype(np.float32)


TEXTURES = {
    "checkerboard": _checkerboard(8),
    "gradient": np.tile(np.linspace(0.05, 1.0, 16, dtype=np.float32), (16, 1)),
    "hdr": _hdr(16),
}


@pytest.mark.parametrize("name", sorted(TEXTURES))
def test_chi_square_per_texel_against_the_bilinear_density(name):
    mesh, tex = _plane(), Texture(TEXTURES[name])
    sampler = DensitySampler(mesh, tex)
    tri, bary = sampler.sample(N, seed=11)
    counts = _counts_per_cell(mesh, tri, bary, tex.width)
    assert _chi_square_p(counts, _expected_per_cell(tex, tex.width)) > 0.001


def test_hdr_contrast_reaches_the_dim_texels():
    data = np.full((8, 8), 1e-4, dtype=np.float32)
    data[:4] = 1.0  # top half (high v) is 10⁴ times denser
    mesh, tex = _plane(), Texture(data, wrap="clamp")
    tri, bary = DensitySampler(mesh, tex).sample(N, seed=5)
    v = mesh.evaluate(tri, bary).position[:, 1]
    expected = _expected_per_cell(tex, 8)[:3].sum()  # rows v < 3/8: the dim quarter and more
    dim = np.count_nonzero(v < 3 / 8)
    assert dim > 0
    assert abs(dim - expected * N) < 5 * np.sqrt(expected * N) + 1


def test_a_tiled_uv_mapping_works():
    # the plane maps the texture twice in u and v: texel (i, j) appears four times
    mesh, tex = _plane(uv_scale=2.0), Texture(_hdr(4, seed=8), wrap="repeat")
    tri, bary = DensitySampler(mesh, tex).sample(N, seed=2)
    counts = _counts_per_cell(mesh, tri, bary, 8)
    assert _chi_square_p(counts, _expected_per_cell(tex, 8, uv_scale=2.0)) > 0.001


def _rotated_uv(xy: np.ndarray) -> np.ndarray:
    """UVs rotated 30° and scaled against the plane, so texel edges cut the triangles."""
    a = np.radians(30.0)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    return xy @ rot.T * 0.7 + [0.3, 0.1]


def _rotated_grid_mesh() -> SkinMesh:
    """An 8×8-quad unit plane with :func:`_rotated_uv` UVs."""
    g = np.linspace(0.0, 1.0, 9)
    x, y = np.meshgrid(g, g)
    verts = np.stack([x.ravel(), y.ravel(), np.zeros(81)], axis=1)
    uvs = _rotated_uv(verts[:, :2])
    quads = [(i * 9 + j) for i in range(8) for j in range(8)]
    faces = [f for q in quads for f in ([q, q + 1, q + 10], [q, q + 10, q + 9])]
    return SkinMesh(verts, faces, uvs=uvs, name="rotated")


def _per_texel_fit(mesh: SkinMesh, tex: Texture, refine: int) -> tuple[float, float]:
    """(chi-square p, median relative error) of samples binned per texel on the rotated plane."""
    w = tex.width

    def texel(uv: np.ndarray) -> np.ndarray:
        return (np.floor(uv[:, 1] * w).astype(int) % w) * w + np.floor(uv[:, 0] * w).astype(int) % w

    n = 2048
    g = (np.arange(n) + 0.5) / n
    x, y = np.meshgrid(g, g)
    uv_dense = _rotated_uv(np.stack([x.ravel(), y.ravel()], axis=1))
    expected = np.bincount(texel(uv_dense), weights=tex.sample(uv_dense), minlength=w * w)
    expected /= expected.sum()
    sampler = DensitySampler(mesh, tex, refine=refine)
    tri, bary = sampler.sample(N, seed=1)
    counts = np.bincount(texel(mesh.evaluate(tri, bary).uv), minlength=w * w).astype(float)
    big = expected * N > 50
    error = float(np.median(np.abs(counts[big] / (expected[big] * N) - 1.0)))
    return _chi_square_p(counts, expected), error


@pytest.mark.slow
def test_refining_sharpens_the_density_where_texels_cut_sub_triangles():
    from scipy.ndimage import gaussian_filter

    mesh = _rotated_grid_mesh()
    base = gaussian_filter(np.random.default_rng(0).standard_normal((32, 32)), 1.5, mode="wrap")
    base = (base - base.min()) / np.ptp(base)
    sharp = Texture((10.0 ** (4.0 * base - 4.0)).astype(np.float32))  # 10⁴:1 in ~3 texels
    errors = [_per_texel_fit(mesh, sharp, refine)[1] for refine in (0, 1, 2)]
    assert errors[0] > 0.05 and errors[2] < 0.5 * errors[0]
    gentle = Texture((10.0 ** (base - 1.0)).astype(np.float32))  # 10:1
    assert _per_texel_fit(mesh, gentle, 1)[0] > 0.001


def test_uniform_density_is_area_proportional_on_very_unequal_triangles():
    # a fan whose triangle areas span four orders of magnitude, plus one zero-area sliver
    angles = np.concatenate([[0.0], np.cumsum(np.geomspace(1e-4, 1.0, 12))])
    rim = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    verts = np.vstack([[0.0, 0.0, 0.0], rim, [[2.0, 0.0, 0.0]]])
    faces = [[0, i + 1, i + 2] for i in range(len(angles) - 1)] + [[0, 1, len(verts) - 1]]
    mesh = SkinMesh(verts, faces, name="fan")
    assert mesh.degenerate_faces[-1]
    sampler = DensitySampler(mesh)
    tri, _ = sampler.sample(N, seed=3)
    counts = np.bincount(tri, minlength=mesh.face_count)
    assert counts[-1] == 0
    areas = mesh.face_areas()
    assert _chi_square_p(counts[:-1].astype(float), areas[:-1] / areas.sum()) > 0.001


def test_constant_texture_merges_to_one_sub_triangle_per_triangle():
    mesh = _plane()
    sampler = DensitySampler(mesh, Texture(np.full((64, 64), 0.5, dtype=np.float32)))
    assert sampler.depths.tolist() == [6, 6]  # 2048 texels per triangle → 4⁶ ≥ 2048
    assert sampler.sub_triangle_count == 2
    assert sampler.subs.tolist() == [0, 0]


def test_subdivision_depth_and_merging_of_equal_siblings():
    mesh = _plane()
    data = np.zeros((16, 16), dtype=np.float32)
    data[:, 8:] = 1.0  # right half dense: a whole quadrant of sub-triangles merges
    sampler = DensitySampler(mesh, Texture(data, wrap="clamp"))
    assert sampler.depths.tolist() == [4, 4]  # 128 texels → 4⁴ = 256 sub-triangles
    levels = np.floor(np.log(3 * sampler.subs.astype(float) + 1) / np.log(4) + 1e-9)
    assert levels.min() < 4  # merged parents remain
    assert sampler.sub_triangle_count < 2 * 256 // 2  # less than the unmerged dense half


def test_zero_density_regions_receive_no_samples():
    data = np.zeros((16, 16), dtype=np.float32)
    data[:, 8:] = 1.0
    mesh, tex = _plane(), Texture(data, wrap="clamp")
    tri, bary = DensitySampler(mesh, tex).sample(200_000, seed=9)
    x = mesh.evaluate(tri, bary).position[:, 0]
    # the bilinear density is zero left of the last zero texel's centre (7.5 / 16); the
    # sub-triangles are one texel wide here, so samples stop at the sub-triangle edge 7 / 16
    assert x.min() >= 7 / 16 - 1e-6
    assert np.count_nonzero(x < 7.5 / 16) < 0.01 * len(x)


def test_every_sample_lies_in_its_sub_triangle():
    mesh = _plane()
    sampler = DensitySampler(mesh, Texture(_hdr(32, seed=4)))
    tri, bary, index = sampler.sample(50_000, seed=1, return_index=True)
    np.testing.assert_array_equal(tri, sampler.parents[index])
    u0, v0, s = sampler.table[sampler.subs[index]].astype(np.float64).T
    a = (bary[:, 0] - u0) / s
    b = (bary[:, 1] - v0) / s
    assert a.min() >= -1e-5 and b.min() >= -1e-5 and (a + b).max() <= 1 + 1e-5


@pytest.mark.parametrize("grid_factor", [0.25, 1, 4, 16])
def test_grid_lookup_equals_a_plain_cdf_search(grid_factor):
    sampler = DensitySampler(_plane(), Texture(_hdr(32, seed=6)), grid_factor=grid_factor)
    n = 100_000
    _, _, index = sampler.sample(n, seed=8, return_index=True)
    xi = uniforms(8, np.zeros(1, dtype=np.int64), purpose_id("root"), 2 * n)[0, 0::2]
    target = np.floor(xi * 4294967295.0)
    expected = np.searchsorted(sampler.cdf.astype(np.float64), target, side="right")
    np.testing.assert_array_equal(index, expected)
    assert len(sampler.grid) == max(1, round(grid_factor * sampler.sub_triangle_count)) + 1


def test_subtriangle_table_follows_the_index_rule():
    table = subtriangle_table(3).astype(np.float64)
    assert len(table) == (4**4 - 1) // 3
    np.testing.assert_array_equal(table[0], [0.0, 0.0, 1.0])
    for g in range(1, len(table)):
        parent, j = (g - 1) // 4, (g - 1) % 4 + 1
        pu, pv, ps = table[parent]
        corners = {1: (0, 0), 2: (0.5, 0), 3: (0, 0.5), 4: (0.5, 0.5)}[j]
        np.testing.assert_allclose(table[g, :2], [pu + ps * corners[0], pv + ps * corners[1]])
        assert table[g, 2] == (-0.5 if j == 4 else 0.5) * ps


def test_same_seed_same_bytes_and_index_ranges_are_independent():
    sampler = DensitySampler(_plane(), Texture(_hdr(16)))
    for sequence in ("random", "halton"):
        tri, bary = sampler.sample(3000, seed=4, sequence=sequence)
        again = sampler.sample(3000, seed=4, sequence=sequence)
        assert tri.tobytes() == again[0].tobytes() and bary.tobytes() == again[1].tobytes()
        part = sampler.sample(1000, seed=4, sequence=sequence, start=1500)
        np.testing.assert_array_equal(part[0], tri[1500:2500])
        np.testing.assert_array_equal(part[1], bary[1500:2500])
        other = sampler.sample(3000, seed=5, sequence=sequence)
        assert not np.array_equal(other[1], bary)


def test_halton_samples_are_stratified():
    mesh = _plane()
    sampler = DensitySampler(mesh)
    cells, n = 16, 16 * 16 * 10
    spread = {}
    for sequence in ("halton", "random"):
        counts = _counts_per_cell(mesh, *sampler.sample(n, seed=1, sequence=sequence), cells)
        spread[sequence] = float(((counts - 10.0) ** 2 / 10.0).sum())  # chi², E = 255 if iid
    assert spread["random"] > 150
    assert spread["halton"] < 0.25 * spread["random"]


def test_pdf_region_probability_and_memory():
    mesh, tex = _plane(), Texture(_checkerboard(8))
    sampler = DensitySampler(mesh, tex)
    np.testing.assert_allclose((sampler.pdf * sampler.sub_triangle_areas()).sum(), 1.0)
    lower = np.array([True, False])  # triangle 0: below the diagonal y = x
    p0 = sampler.region_probability(lower)
    assert p0 + sampler.region_probability(~lower) == pytest.approx(1.0, abs=1e-9)
    assert p0 == pytest.approx(0.5, abs=0.01)  # the checkerboard is symmetric about y = x
    tri, _ = sampler.sample(200_000, seed=2)
    assert np.mean(tri == 0) == pytest.approx(p0, abs=4 * np.sqrt(0.25 / 200_000))
    # what it keeps, counted by hand: 32 texels a triangle give depth 3 (4³ ≥ 32), so
    # 2 × 64 sub-triangles of 12 bytes (CDF, parent, index); 4 grid cells a sub-triangle
    # and one more, int32; the position table of depths 0 … 3, (4⁴ − 1) / 3 = 85 rows of
    # 3 float32
    assert sampler.sub_triangle_count == 128
    assert sampler.memory_bytes == 128 * 12 + (4 * 128 + 1) * 4 + 85 * 3 * 4 == 4608
    # total weight (getDensity): ∫ density dA; the tiled checkerboard averages (0.1 + 1) / 2
    assert sampler.total_weight == pytest.approx(0.55, rel=1e-6)


def test_memory_bytes_is_what_building_a_sampler_leaves_allocated():
    """Measured, not the formula restated: tracemalloc's count of what is still allocated
    once the sampler is built (its arrays, its depths and a few small objects)."""
    mesh, tex = _plane(), Texture(_checkerboard(64))
    DensitySampler(mesh, tex)  # the kernels loaded and the mesh's caches filled first
    tracemalloc.start()
    try:
        sampler = DensitySampler(mesh, tex)
        kept = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert sampler.sub_triangle_count == 2 * 4**6  # 2048 texels a triangle: depth 6
    assert sampler.memory_bytes <= kept <= sampler.memory_bytes + 4096, (kept, sampler.memory_bytes)


def test_uniform_and_constant_densities():
    mesh = _plane()
    for density in (None, 3.0):
        sampler = DensitySampler(mesh, density)
        assert sampler.sub_triangle_count == 2
        assert sampler.total_weight == pytest.approx(1.0 if density is None else 3.0)
        np.testing.assert_allclose(sampler.pdf, [1.0, 1.0])


def test_density_from_array_and_float_tiff_path(tmp_path):
    from PIL import Image

    data = _hdr(16, seed=3)
    path = tmp_path / "density.tif"
    Image.fromarray(data, mode="F").save(path)
    from_path = DensitySampler(_plane(), path)
    from_array = DensitySampler(_plane(), data)
    assert from_path.sample(500, seed=1)[1].tobytes() == from_array.sample(500, seed=1)[1].tobytes()


def test_bad_input_is_refused_with_a_named_error(tmp_path):
    mesh = _plane()
    no_uv = SkinMesh(mesh.rest_vertices, mesh.faces, name="bald")
    cases = [
        (lambda: DensitySampler(no_uv, Texture(np.ones((2, 2)))), "mesh 'bald' has no UVs"),
        (lambda: DensitySampler(mesh, np.zeros((4, 4))), "zero everywhere"),
        (lambda: DensitySampler(mesh, -np.ones((4, 4))), "negative values"),
        (lambda: DensitySampler(mesh, 0.0), r"density: must be > 0 \(got 0.0\)"),
        (
            lambda: DensitySampler(mesh, float("nan")),
            r"density: must be finite and > 0 \(got nan\)",
        ),
        (lambda: DensitySampler(mesh, grid_factor=0), "grid_factor"),
        (lambda: DensitySampler("mesh"), "expected a SkinMesh"),
        (lambda: DensitySampler(mesh, tmp_path / "missing.png"), "does not exist"),
        (lambda: DensitySampler(mesh).sample(-1), r"n: expected a whole number ≥ 0 \(got -1\)"),
        (lambda: DensitySampler(mesh).sample(5, seed=1.5), "seed"),
        (lambda: DensitySampler(mesh).sample(5, sequence="sobol"), "sequence"),
    ]
    for make, message in cases:
        with pytest.raises(FollicleError, match=message):
            make()
    # zero density on every triangle that has area: nothing to sample
    verts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], dtype=float)
    mesh2 = SkinMesh(verts, [[0, 1, 2], [0, 1, 3]], uvs=[[0, 0], [0.1, 0], [0, 0.1], [1, 1]])
    data = np.zeros((10, 10), dtype=np.float32)
    data[0, 9] = 1.0  # only near uv (1, 1), which no triangle with area covers
    with pytest.raises(InputError, match="zero on every triangle"):
        DensitySampler(mesh2, Texture(data, wrap="clamp"))
