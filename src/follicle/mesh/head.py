"""The built-in head: a smooth human head and neck made by code, UV-mapped, with a scalp map.

The surface is star-shaped around the origin: ``r = R(d)`` for every unit direction
``d``. ``R`` is a soft union of ellipsoids (cranium, face, jaw, chin) and a neck
cylinder, plus smooth features (brows, eye sockets, nose, lips, cheeks, ears). The
mesh samples ``R`` on a latitude-longitude grid, denser on the face; the same ``R``
gives :func:`head_signed_distance` for combing guides and for tests.
Metres, +Y up, the face looks towards +Z; the crown is at y ≈ 0.12, the chin at
y ≈ -0.11 and the bottom of the neck at y ≈ -0.23.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import InputError
from .skin import SkinMesh
from .texture import Texture

__all__ = [
    "builtin_head",
    "head_inside",
    "head_signed_distance",
    "parting_texture",
    "scalp_texture",
    "SCALP_TEXTURE",
    "HEAD_CENTER",
]

SCALP_TEXTURE = "scalp"
PARTING_TEXTURE = "parting"  # the interpolation groups its built-in guides part along
HEAD_CENTER = np.zeros(3)  # the star centre of the radial function

_N_THETA = 52  # latitude bands (pole to pole)
_N_PHI = 68  # longitude bands
_SCALP_SIZE = 256

# (centre, semi-axes) of the ellipsoids united into the base shape
_ELLIPSOIDS = (
    ((0.0, 0.016, -0.012), (0.079, 0.104, 0.099)),  # cranium
    ((0.0, -0.022, 0.024), (0.066, 0.066, 0.068)),  # mid face, cheeks
    ((0.0, -0.062, 0.016), (0.056, 0.050, 0.068)),  # jaw
    ((0.0, -0.086, 0.048), (0.024, 0.026, 0.036)),  # chin
)
_NECK = (0.0, -0.022, 0.054, -0.232)  # axis x, axis z, radius, bottom y
_SOFT = 0.006  # blend width of the soft union (m)


def _smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _ellipsoid_exit(d: np.ndarray, centre: tuple, axes: tuple) -> np.ndarray:
    """Distance along unit rays d from the origin to where they leave an ellipsoid (0: miss)."""
    c = np.asarray(centre)
    s2 = np.asarray(axes) ** 2
    a = np.sum(d * d / s2, axis=1)
    b = -2.0 * np.sum(d * c / s2, axis=1)
    cc = np.sum(c * c / s2) - 1.0
    disc = b * b - 4.0 * a * cc
    t = (-b + np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a)
    return np.where(disc > 0.0, np.maximum(t, 0.0), 0.0)


def _neck_exit(d: np.ndarray) -> np.ndarray:
    """Exit distance of downward rays from a vertical neck cylinder with a rounded bottom."""
    cx, cz, radius, bottom = _NECK
    dx, dy, dz = d[:, 0], d[:, 1], d[:, 2]
    a = dx * dx + dz * dz
    b = -2.0 * (dx * cx + dz * cz)
    cc = cx * cx + cz * cz - radius * radius
    disc = np.maximum(b * b - 4.0 * a * cc, 0.0)
    side = (-b + np.sqrt(disc)) / (2.0 * np.maximum(a, 1e-12))
    side = np.where(a > 1e-12, side, 1e3)
    down = dy < -1e-9
    cap = np.where(down, bottom / np.where(down, dy, -1.0), 1e3)
    k = 0.012  # rounds the edge between the side and the bottom
    m = np.minimum(side, cap)
    t = m - k * np.log(np.exp(-(side - m) / k) + np.exp(-(cap - m) / k))
    return np.where(down, np.maximum(t, 0.0), 0.0)


def _base_radius(d: np.ndarray) -> np.ndarray:
    parts = [_ellipsoid_exit(d, c, s) for c, s in _ELLIPSOIDS] + [_neck_exit(d)]
    r = np.stack(parts, axis=1)
    top = r.max(axis=1, keepdims=True)
    return (top + _SOFT * np.log(np.sum(np.exp((r - top) / _SOFT), axis=1, keepdims=True)))[:, 0]


def _gauss(p: np.ndarray, centre: tuple, sigma: tuple) -> np.ndarray:
    q = (p - np.asarray(centre)) / np.asarray(sigma)
    return np.exp(-0.5 * np.sum(q * q, axis=1))


def _features(p: np.ndarray) -> np.ndarray:
    """Radial offsets (m) of the facial features and ears at base-surface points p."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ax = np.abs(x)
    front = _smoothstep(0.03, 0.07, z)
    pm = np.stack([ax, y, z], axis=1)  # mirrored, so each pair is written once
    off = np.zeros(len(p))
    # brow ridge, eye sockets, eyeballs, cheekbones
    off += 0.006 * _gauss(pm, (0.030, 0.031, 0.09), (0.020, 0.007, 0.04)) * front
    off -= 0.012 * _gauss(pm, (0.032, 0.010, 0.09), (0.014, 0.010, 0.04)) * front
    off += 0.005 * _gauss(pm, (0.032, 0.008, 0.09), (0.007, 0.005, 0.04)) * front
    off += 0.007 * _gauss(pm, (0.046, -0.014, 0.07), (0.014, 0.012, 0.04)) * front
    # nose: a ridge from the brows to the tip, wider at the bottom, plus nostril wings
    ridge = _smoothstep(0.032, -0.022, y) * _smoothstep(-0.046, -0.03, y)
    width = 0.006 + 0.006 * _smoothstep(0.02, -0.03, y)
    off += 0.024 * ridge * np.exp(-0.5 * (x / width) ** 2) * front
    off += 0.006 * _gauss(pm, (0.013, -0.036, 0.09), (0.006, 0.005, 0.04)) * front
    # lips, mouth line and corners, chin
    off += 0.005 * _gauss(pm, (0.0, -0.056, 0.09), (0.017, 0.005, 0.04)) * front
    off += 0.005 * _gauss(pm, (0.0, -0.070, 0.09), (0.014, 0.005, 0.04)) * front
    off -= 0.003 * _gauss(pm, (0.0, -0.063, 0.09), (0.020, 0.002, 0.04)) * front
    off -= 0.003 * _gauss(pm, (0.022, -0.062, 0.09), (0.005, 0.005, 0.04)) * front
    off += 0.005 * _gauss(pm, (0.0, -0.100, 0.08), (0.014, 0.010, 0.04)) * front
    # ears: a flat-topped flap on each side with a hollow (concha)
    side = _smoothstep(0.05, 0.07, ax)
    e = ((y - 0.002) / 0.024) ** 2 + ((z + 0.014) / 0.013) ** 2
    off += 0.018 * np.exp(-(e**2)) * side
    off -= 0.006 * _gauss(pm, (0.09, -0.004, -0.010), (0.05, 0.007, 0.006)) * side
    return off


def _radius(d: np.ndarray) -> np.ndarray:
    """R(d): distance from the origin to the head surface along unit directions d (n, 3)."""
    r0 = _base_radius(d)
    return r0 + _features(d * r0[:, None])


def _direction(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Unit direction for polar angle theta (from +Y) and azimuth phi (0 at -Z, π at +Z)."""
    st = np.sin(theta)
    return np.stack([-st * np.sin(phi), np.cos(theta), -st * np.cos(phi)], axis=-1)


def _as_points(points: object) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim == 1 and p.shape == (3,):
        p = p[None]
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"points must have shape (n, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise InputError("points contain NaN or inf")
    return p


def _radial_excess(p: np.ndarray) -> np.ndarray:
    rho = np.linalg.norm(p, axis=1)
    d = np.where(rho[:, None] > 1e-12, p / np.maximum(rho, 1e-12)[:, None], (0.0, 1.0, 0.0))
    return rho - _radius(d)


def head_signed_distance_and_normal(points: object) -> tuple[np.ndarray, np.ndarray]:
    """Approximate signed distance (negative inside) and outward unit gradient at points."""
    p = _as_points(points)
    f = _radial_excess(p)
    h = 1e-5
    grad = np.empty_like(p)
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        grad[:, k] = (_radial_excess(p + e) - _radial_excess(p - e)) / (2 * h)
    g = np.linalg.norm(grad, axis=1)
    g = np.where(g > 1e-9, g, 1.0)
    return f / g, grad / g[:, None]


def head_signed_distance(points: object) -> np.ndarray:
    """Approximate signed distance (m) to the built-in head, negative inside, (n,) float64.

    First order: the radial excess |p| − R(p/|p|) divided by its gradient length;
    accurate near the surface, where combing and tests need it.
    """
    return head_signed_distance_and_normal(points)[0]


def head_inside(points: object) -> np.ndarray:
    """True for points strictly inside the built-in head (n,) bool."""
    return _radial_excess(_as_points(points)) < 0.0


def _grid_angles() -> tuple[np.ndarray, np.ndarray]:
    """Polar and azimuth samples, denser around the face (equator, front)."""
    t = np.linspace(0.0, 1.0, _N_THETA + 1)
    theta = np.pi * t + 0.35 * np.pi / (2 * np.pi) * np.sin(2 * np.pi * t)
    s = np.linspace(0.0, 1.0, _N_PHI + 1)
    phi = 2 * np.pi * s + 0.4 * np.sin(2 * np.pi * s)
    theta[0], theta[-1], phi[0], phi[-1] = 0.0, np.pi, 0.0, 2 * np.pi
    return theta, phi


@lru_cache(maxsize=1)
def _head_arrays() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    theta, phi = _grid_angles()
    nt, nph = len(theta), len(phi)
    th, ph = np.meshgrid(theta, phi, indexing="ij")  # (nt, nph); seam column duplicated
    d = _direction(th.ravel(), ph.ravel())
    verts = d * _radius(d)[:, None]
    uvs = np.stack([ph.ravel() / (2 * np.pi), 1.0 - th.ravel() / np.pi], axis=1)
    # pole vertices: one copy per column, u at the middle of the column's fan
    pole_u = 0.5 * (phi[:-1] + phi[1:]) / (2 * np.pi)
    uvs[: nph - 1, 0] = pole_u
    uvs[(nt - 1) * nph : nt * nph - 1, 0] = pole_u
    idx = np.arange(nt * nph).reshape(nt, nph)
    a, b = idx[:-1, :-1], idx[:-1, 1:]  # row i (upper), columns j, j+1
    c, e = idx[1:, :-1], idx[1:, 1:]  # row i + 1 (lower)
    # outward winding: (lower j, lower j+1, upper j+1) and (lower j, upper j+1, upper j);
    # at the poles only the non-degenerate half of each quad is kept, using the pole
    # copy of column j (its u is the middle of the column)
    t1 = np.stack([c, e, b], axis=-1)
    t1[0, :, 2] = a[0]
    t2 = np.stack([c, b, a], axis=-1)
    faces = np.concatenate([t1[:-1].reshape(-1, 3), t2[1:].reshape(-1, 3)])
    used, faces = np.unique(faces, return_inverse=True)  # drop the unused seam pole copies
    faces = faces.reshape(-1, 3)
    verts, uvs = verts[used], uvs[used]
    return verts, faces.astype(np.int64), uvs, _scalp_density()


def _scalp_density_at(p: np.ndarray) -> np.ndarray:
    """Hair density in [0, 1] at head-surface points: a soft hairline ~1 cm wide."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ax = np.abs(x)
    hairline = 0.082 + 0.012 * np.clip(ax / 0.05, 0.0, 1.0) ** 2  # front, ~5 cm above brows
    sideburn = 0.016 + 0.045 * _smoothstep(0.0, 0.075, y)  # temples down to the sideburns
    above_face = np.maximum(y - hairline, sideburn - z)
    nape = -0.058 + 0.022 * np.clip(ax / 0.055, 0.0, 1.0) ** 2
    low = -0.004 + (nape + 0.004) * _smoothstep(-0.005, -0.075, z)  # sideburn end → nape
    above_neck = y - low
    ear = np.sqrt(((y - 0.004) / 0.036) ** 2 + ((z + 0.012) / 0.024) ** 2) - 1.0
    off_ear = np.where(ax > 0.045, 0.03 * ear, 1.0)
    h = np.minimum(np.minimum(above_face, above_neck), off_ear)
    return _smoothstep(-0.005, 0.005, h)


def _texel_points(n: int) -> np.ndarray:
    """Head-surface points under the centres of an n×n texture in the head's UV layout."""
    centres = (np.arange(n) + 0.5) / n
    v = 1.0 - centres[:, None]  # row i from the top ⇒ v = 1 − (i + 0.5) / H
    u = centres[None, :]
    th = np.pi * (1.0 - np.broadcast_to(v, (n, n)))
    ph = 2 * np.pi * np.broadcast_to(u, (n, n))
    d = _direction(th.ravel(), ph.ravel())
    return d * _radius(d)[:, None]


def _scalp_density() -> np.ndarray:
    n = _SCALP_SIZE
    return _scalp_density_at(_texel_points(n)).reshape(n, n).astype(np.float32)


def parting_texture() -> Texture:
    """``builtin:parting``: two interpolation groups split at the head's mid-plane x = 0.

    Red on the head's right (x < 0), blue on its left: the built-in guides part in
    the middle, and with these groups no hair blends guides from both sides.
    """
    n = _SCALP_SIZE
    right = (_texel_points(n)[:, 0] < 0.0).reshape(n, n)
    rgb = np.where(right[:, :, None], [255, 0, 0], [0, 0, 255]).astype(np.uint8)
    return Texture(rgb, wrap="clamp", name=PARTING_TEXTURE)


def scalp_texture() -> Texture:
    """The built-in head's hair density map (``builtin:scalp``), 256², 1 on the scalp."""
    return Texture(_head_arrays()[3], wrap="clamp", name=SCALP_TEXTURE)


def builtin_head() -> SkinMesh:
    """A new SkinMesh 'head' (about 7k triangles, UVs, ``textures['scalp']``, its hair
    density, and ``textures['parting']``, the groups the built-in guides part along)."""
    verts, faces, uvs, _ = _head_arrays()
    textures = {SCALP_TEXTURE: scalp_texture(), PARTING_TEXTURE: parting_texture()}
    return SkinMesh(verts, faces, uvs=uvs, name="head", textures=textures)
