"""displace: root positions and frames on a displaced mesh (Šik 2012 §2.2.3 "Mesh displacement"),
checked on flat planes by hand, on a curved cylinder against finite differences of
displaced positions, for orthonormality, rigid invariance and input errors."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.errors import InputError
from follicle.mesh.displacement import displace
from follicle.mesh.head import SCALP_TEXTURE, builtin_head
from follicle.mesh.sampling import DensitySampler
from follicle.mesh.skin import SkinMesh
from follicle.mesh.texture import Texture


def _grid_faces(rows: int, cols: int) -> np.ndarray:
    """Two counter-clockwise triangles per cell of a rows x cols vertex grid."""
    idx = np.arange(rows * cols).reshape(rows, cols)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    return np.concatenate(
        [np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)]
    )


def _plane(size: float = 2.0, n: int = 5, mirror: bool = False) -> SkinMesh:
    """The square [0, size]² at z = 0, normal +z, uv = (x, y) / size (u = 1 - x/size mirrored)."""
    x, y = np.meshgrid(np.linspace(0, size, n), np.linspace(0, size, n))
    verts = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], axis=1)
    uvs = verts[:, :2] / size
    if mirror:
        uvs[:, 0] = 1.0 - uvs[:, 0]
    return SkinMesh(verts, _grid_faces(n, n), uvs=uvs, name="plane")


def _plane_samples(mesh: SkinMesh, lo: float, hi: float, count: int = 40):
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(lo, hi, size=(count, 2)), np.zeros(count)])
    tri, bary, dist = mesh.closest_points(pts)
    assert dist.max() < 1e-12
    return tri, bary


def _ramp_texture(slope: float, width: int = 64) -> Texture:
    """Texel centres hold slope·u, so bilinear sampling is exactly slope·u inside the image."""
    row = slope * (np.arange(width) + 0.5) / width  # dyadic: exact in float32
    return Texture(np.tile(row, (4, 1)), wrap="clamp", name="ramp")


def _check_frames(sp) -> None:
    for vec in (sp.normal, sp.tangent, sp.binormal):
        np.testing.assert_allclose(np.linalg.norm(vec, axis=1), 1.0, atol=1e-9)
    for a, b in ((sp.normal, sp.tangent), (sp.normal, sp.binormal), (sp.tangent, sp.binormal)):
        assert np.abs(np.sum(a * b, axis=1)).max() < 1e-9
    np.testing.assert_allclose(sp.binormal, np.cross(sp.tangent, sp.normal), atol=1e-9)


def _angles_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    cos = np.sum(a * b, axis=1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


# ---------------------------------------------------------------------- flat planes
def test_constant_displacement_lifts_plane_and_keeps_frame():
    mesh = _plane()
    tri, bary = _plane_samples(mesh, 0.0, 2.0)
    c, scale = 0.25, 1.5
    texture = Texture(np.full((8, 8), c), name="flat")
    base = mesh.evaluate(tri, bary, "current")
    sp = displace(mesh, tri, bary, texture, scale=scale)
    np.testing.assert_allclose(sp.position, base.position + [0.0, 0.0, c * scale], atol=1e-9)
    np.testing.assert_allclose(sp.normal, base.normal, atol=1e-9)
    np.testing.assert_allclose(sp.normal, np.tile([0.0, 0.0, 1.0], (len(tri), 1)), atol=1e-9)
    np.testing.assert_allclose(sp.tangent, base.tangent, atol=1e-9)
    np.testing.assert_allclose(sp.binormal, base.binormal, atol=1e-9)
    np.testing.assert_array_equal(sp.uv, base.uv)


@pytest.mark.parametrize("mirror", [False, True])
def test_linear_ramp_tilts_normal(mirror):
    # plane of side 2 with uv = xy/2: D = scale·a·u is the height field
    # z = k·x with k = scale·a/2, or z = scale·a·(1 - x/2) with mirrored u (slope -k)
    size, a, scale = 2.0, 0.5, 1.5
    mesh = _plane(size, mirror=mirror)
    tri, bary = _plane_samples(mesh, 0.2, 1.7)  # u in [0.1, 0.85]: away from the image edges
    sp = displace(mesh, tri, bary, _ramp_texture(a), scale=scale)
    k = scale * a / size * (-1.0 if mirror else 1.0)
    u = sp.uv[:, 0]
    np.testing.assert_allclose(sp.position[:, 2], scale * a * u, atol=1e-6)
    np.testing.assert_allclose(sp.position[:, :2], mesh.evaluate(tri, bary).position[:, :2])
    expected_n = np.array([-k, 0.0, 1.0]) / np.hypot(k, 1.0)
    np.testing.assert_allclose(sp.normal, np.tile(expected_n, (len(tri), 1)), atol=1e-6)
    expected_t = np.array([1.0, 0.0, k]) / np.hypot(k, 1.0) * (-1.0 if mirror else 1.0)
    np.testing.assert_allclose(sp.tangent, np.tile(expected_t, (len(tri), 1)), atol=1e-6)
    _check_frames(sp)


def test_undefined_uv_derivatives_keep_normal_but_move_position():
    verts = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    mesh = SkinMesh(verts, [[0, 1, 2]], uvs=np.full((3, 2), 0.5), name="flatuv")
    texture = _ramp_texture(0.5)
    sp = displace(mesh, [0, 0], [[0.2, 0.3], [0.5, 0.1]], texture, scale=2.0)
    base = mesh.evaluate([0, 0], [[0.2, 0.3], [0.5, 0.1]])
    np.testing.assert_allclose(sp.normal, base.normal, atol=1e-12)
    np.testing.assert_allclose(sp.tangent, base.tangent, atol=1e-12)
    np.testing.assert_allclose(sp.position, base.position + [0.0, 0.0, 2.0 * 0.5 * 0.5])


# ---------------------------------------------------------------------- curved surface
R = 1.0
THETA0, THETA_SPAN = 0.3, np.pi / 2


def _cylinder(n_theta: int = 65, n_z: int = 33) -> SkinMesh:
    """A quarter cylinder of radius R about z, outward normals, u = angle, v = z in [0, 1]."""
    theta, z = np.meshgrid(np.linspace(0, THETA_SPAN, n_theta) + THETA0, np.linspace(0, 1, n_z))
    verts = np.stack([R * np.cos(theta), R * np.sin(theta), z], axis=-1).reshape(-1, 3)
    uvs = np.stack([(theta - THETA0) / THETA_SPAN, z], axis=-1).reshape(-1, 2)
    return SkinMesh(verts, _grid_faces(n_z, n_theta), uvs=uvs, name="cylinder")


def _wavy_texture(width: int = 2048, height: int = 1024) -> Texture:
    """D = 0.8 + 0.2 sin(2πu) + 0.1 cos(2πv) at the texel centres: a large offset and slopes."""
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height
    data = 0.8 + 0.2 * np.sin(2 * np.pi * u)[None, :] + 0.1 * np.cos(2 * np.pi * v)[:, None]
    return Texture(data, wrap="clamp", name="wavy")


def _interior_samples(mesh: SkinMesh, count: int, seed: int = 7):
    """Random samples well inside the mesh (uv in [0.1, 0.9]²), barycentrics away from edges."""
    rng = np.random.default_rng(seed)
    uv_c = mesh.uvs[mesh.faces].mean(axis=1)
    inside = np.flatnonzero(((uv_c > 0.1) & (uv_c < 0.9)).all(axis=1))
    tri = rng.choice(inside, size=count)
    b = rng.uniform(0.25, 0.45, size=(count, 2))
    return tri, b


@pytest.mark.parametrize(
    ("n_theta", "n_z", "facet_deg", "smooth_deg"), [(65, 33, 0.5, 0.25), (9, 5, 2.0, 3.0)]
)
def test_curved_normal_matches_finite_differences_of_displaced_positions(
    n_theta, n_z, facet_deg, smooth_deg
):
    # the coarse mesh needs ∂N of the *unit* normal: the raw vertex normal blend is ~1° off;
    # the slopes follow the smooth normal, so against the faceted positions the error grows
    # with the facet angle (facet_deg), and smooth_deg bounds it against the smooth cylinder
    mesh, texture, scale = _cylinder(n_theta, n_z), _wavy_texture(), 1.0
    tri, bary = _interior_samples(mesh, 60)
    sp = displace(mesh, tri, bary, texture, scale=scale)

    # displaced positions of nearby samples in the same triangle, by P' = P + D·N directly
    h = 0.05
    offsets = np.array([[0.0, 0.0], [h, 0.0], [-h, 0.0], [0.0, h], [0.0, -h]])
    nb = (bary[:, None, :] + offsets[None, :, :]).reshape(-1, 2)
    nt = np.repeat(tri, len(offsets))
    near = mesh.evaluate(nt, nb, "current")
    p = near.position.reshape(-1, 5, 3)
    nrm = near.normal.reshape(-1, 5, 3)
    d = scale * texture.sample(near.uv).reshape(-1, 5, 1)
    np.testing.assert_allclose(
        displace(mesh, nt, nb, texture, scale=scale).position.reshape(-1, 5, 3),
        p + d * nrm,
        atol=1e-12,
    )

    def fd_normal(x: np.ndarray) -> np.ndarray:
        n = np.cross(x[:, 1] - x[:, 2], x[:, 3] - x[:, 4])
        return n * np.sign(np.sum(n * nrm[:, 0], axis=1))[:, None]

    reference = fd_normal(p + d * nrm)
    error = _angles_deg(sp.normal, reference)
    assert error.max() < facet_deg, error.max()
    _check_frames(sp)

    # the case discriminates: each term of the chain rule moves the normal by much more
    without_dn = fd_normal(p + d * nrm[:, :1])  # N frozen: no D·∂N/∂u
    without_dd = fd_normal(p + d[:, :1] * nrm)  # D frozen: no (∂D/∂u)·N
    assert np.median(_angles_deg(reference, without_dn)) > 5.0
    assert np.median(_angles_deg(reference, without_dd)) > 15.0

    # and against the smooth surface (faceting error only) (R + D)·radial + z·ẑ, D analytic
    u, v = sp.uv.T
    theta = THETA0 + THETA_SPAN * u
    radial = np.stack([np.cos(theta), np.sin(theta), np.zeros_like(u)], axis=1)
    along = np.stack([-np.sin(theta), np.cos(theta), np.zeros_like(u)], axis=1)
    dd = 0.8 + 0.2 * np.sin(2 * np.pi * u) + 0.1 * np.cos(2 * np.pi * v)
    slope_u = 0.2 * 2 * np.pi * np.cos(2 * np.pi * u)
    slope_v = -0.1 * 2 * np.pi * np.sin(2 * np.pi * v)
    dx_du = slope_u[:, None] * radial + ((R + dd) * THETA_SPAN)[:, None] * along
    dx_dv = slope_v[:, None] * radial + [0.0, 0.0, 1.0]
    smooth = _angles_deg(sp.normal, np.cross(dx_du, dx_dv))
    assert smooth.max() < smooth_deg, smooth.max()
    assert np.median(smooth) < 0.2


def test_frames_orthonormal_on_head_with_scalp_displacement():
    mesh = builtin_head()
    tri, b = DensitySampler(mesh).sample(500, seed=11)
    sp = displace(mesh, tri, b, mesh.textures[SCALP_TEXTURE], scale=0.01)
    _check_frames(sp)
    assert np.all(np.sum(sp.normal * mesh.evaluate(tri, b).normal, axis=1) > 0.0)


def test_rigid_transform_of_displaced_roots():
    mesh = builtin_head()
    texture = mesh.textures[SCALP_TEXTURE]
    rng = np.random.default_rng(5)
    tri = rng.integers(0, mesh.face_count, size=300)
    b = rng.uniform(0.0, 0.5, size=(300, 2))
    axis = np.array([0.3, -0.8, 0.5]) / np.linalg.norm([0.3, -0.8, 0.5])
    angle = 1.1
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rot, (0.4, -1.2, 2.5)
    rest = displace(mesh, tri, b, texture, scale=0.02, pose="rest")
    cur = displace(mesh.posed(transform=m), tri, b, texture, scale=0.02, pose="current")
    np.testing.assert_allclose(cur.position, rest.position @ rot.T + m[:3, 3], atol=1e-5)
    np.testing.assert_allclose(cur.normal, rest.normal @ rot.T, atol=1e-5)
    np.testing.assert_allclose(cur.tangent, rest.tangent @ rot.T, atol=1e-5)
    np.testing.assert_allclose(cur.binormal, rest.binormal @ rot.T, atol=1e-5)
    np.testing.assert_array_equal(cur.uv, rest.uv)
    # the displacement really changed something
    assert _angles_deg(rest.normal, mesh.evaluate(tri, b, "rest").normal).max() > 1.0


# ---------------------------------------------------------------------- errors
def test_errors_name_mesh_and_texture():
    verts = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    texture = _ramp_texture(0.5)
    with pytest.raises(InputError, match="mesh 'nouv' has no UVs.*'ramp' cannot be mapped"):
        displace(SkinMesh(verts, [[0, 1, 2]], name="nouv"), [0], [[0.2, 0.2]], texture)
    mesh = _plane()
    with pytest.raises(InputError, match=r"'ramp' scale: must be finite \(got nan\)"):
        displace(mesh, [0], [[0.2, 0.2]], texture, scale=float("nan"))
    with pytest.raises(InputError, match=r"'ramp' scale: expected a number \(got 'big'\)"):
        displace(mesh, [0], [[0.2, 0.2]], texture, scale="big")
    with pytest.raises(InputError, match="must be a Texture, got ndarray"):
        displace(mesh, [0], [[0.2, 0.2]], np.ones((4, 4)))
    with pytest.raises(InputError, match="pose"):
        displace(mesh, [0], [[0.2, 0.2]], texture, pose="bind")
    with pytest.raises(InputError, match="bary"):
        displace(mesh, [0], [[0.9, 0.9]], texture)
