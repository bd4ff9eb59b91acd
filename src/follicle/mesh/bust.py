"""The built-in bust: a head with ears, closed eyes and lips on a neck and shoulders.

The shape is a signed distance field of smooth-blended primitives (ellipsoids, capsules,
tapered capsules), united and carved one after another with the polynomial smooth
minimum (I. Quilez, "Smooth minimum", 2013; ellipsoid distance bound: Quilez,
"Ellipsoid SDF", 2008), and cut flat at y = -0.40 below the shoulders. ``tools/make_bust.py``
meshes this field (Lorensen and Cline 1987 marching cubes, then Garland and Heckbert 1997
quadric decimation), lays out UVs and bakes the scalp map into ``data/bust.npz``, which
:func:`builtin_bust` loads; :func:`bust_signed_distance_and_normal` evaluates the same
field for combing guides.

The face is a calm, neutral mannequin's: soft brows over shallow sockets, closed eyes (an
upper lid over the eyeball and a lower lid, meeting in the lash line), cheekbones and
full cheeks, a soft jaw and chin, a nose with its tip, wings and nostrils, slightly full
lips with the corners of the mouth. Each ear is a tilted flap with a fleshy lobe and a
tragus; the scapha and fossa are carved behind its helix rim, with the antihelix ridge
and its upper branch standing in them and the concha bowl in front. Hair grows only on
the scalp, which none of these parts reach.

UVs: a spherical map about :data:`UV_CENTRE`, the head's centre on the line through the
ears, with its poles in the ears (``u`` is the angle from +X over π) and its seam
straight below the head (``v = 1/2 + atan2(z, y) / 2π`` about the centre: the crown at
v = 1/2, the face at 3/4, the back of the head at 1/4); the scalp is one chart with no
seam across it. Metres, +Y up, the face
looks towards +Z; the head matches :mod:`follicle.mesh.head` (crown y ≈ 0.12, chin
y ≈ -0.11), the shoulders reach x ≈ ±0.21.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

import numpy as np

from .head import PARTING_TEXTURE, SCALP_TEXTURE, _as_points
from .skin import SkinMesh
from .texture import Texture

__all__ = [
    "builtin_bust",
    "bust_field",
    "bust_inside",
    "bust_signed_distance",
    "bust_signed_distance_and_normal",
    "BUST_DATA",
    "BUST_BOTTOM",
    "UV_CENTRE",
    "EAR",
    "ear_distance",
]

BUST_DATA = "data/bust.npz"  # beside this module, written by tools/make_bust.py
BUST_BOTTOM = -0.40  # y of the flat cut under the shoulders (m)
UV_CENTRE = (0.0, -0.004, -0.012)  # centre of the UV map: its poles are in the ears' hollows
_CUT_SOFT = 0.006  # rounding of the cut's edge (m)
# the right ear's flap: an ellipsoid (centre, semi-axes, (pitch, yaw)), mirrored for the left
EAR = ((0.078, 0.0, -0.016), (0.0065, 0.031, 0.018), (-14.0, -22.0))
_TILT = EAR[2]


def _rotation(pitch: float, yaw: float) -> np.ndarray:
    """The turn of a primitive by pitch about +X, then yaw about +Y: its columns are the
    primitive's local axes in world coordinates."""
    a, b = np.radians(pitch), np.radians(yaw)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])
    ry = np.array([[np.cos(b), 0.0, np.sin(b)], [0.0, 1.0, 0.0], [-np.sin(b), 0.0, np.cos(b)]])
    return ry @ rx


def _on_ear(offset: tuple[float, float, float]) -> tuple[float, ...]:
    """A point given in the right ear's flap frame (out, up, forwards from the centre of
    :data:`EAR`) in world coordinates, so the ear's parts turn with the flap."""
    centre, _, angles = EAR
    return tuple(np.round(np.asarray(centre) + _rotation(*angles) @ np.asarray(offset), 6))


# One primitive per row, applied in order: ("add" | "sub", shape, parameters, blend k in
# metres, mirrored). A mirrored primitive is written for x > 0 and evaluated at |x|, so a
# pair (eyes, ears, shoulders) is one row. Shapes: "ell" (centre, semi-axes, optional
# (pitch, yaw) in degrees: about +X, then about +Y), "cap" (a, b, radius), "cone"
# (a, b, radius at a, radius at b).
_PRIMITIVES: tuple[tuple[str, str, tuple, float, bool], ...] = (
    # skull and face masses
    ("add", "ell", ((0.0, 0.018, -0.014), (0.074, 0.102, 0.097)), 0.0, False),
    ("add", "ell", ((0.0, 0.045, 0.020), (0.062, 0.075, 0.072)), 0.02, False),
    ("add", "ell", ((0.0, -0.018, 0.020), (0.063, 0.064, 0.067)), 0.02, False),
    # cheekbones and the fuller cheeks below them
    ("add", "ell", ((0.040, -0.006, 0.058), (0.024, 0.016, 0.022), (0.0, 20.0)), 0.024, True),
    ("add", "ell", ((0.037, -0.042, 0.049), (0.026, 0.028, 0.028)), 0.026, True),
    # lower face, jaw, chin
    ("add", "ell", ((0.0, -0.060, 0.018), (0.055, 0.048, 0.062)), 0.02, False),
    ("add", "cap", ((0.048, -0.052, -0.012), (0.020, -0.094, 0.056), 0.015), 0.03, True),
    ("add", "ell", ((0.0, -0.093, 0.070), (0.023, 0.019, 0.021)), 0.02, False),
    ("add", "ell", ((0.0, -0.054, 0.068), (0.030, 0.028, 0.026)), 0.018, False),
    # eyes: shallow sockets, the eyeball under closed lids (upper and lower), soft brows
    ("sub", "ell", ((0.032, 0.012, 0.096), (0.015, 0.0080, 0.011)), 0.014, True),
    ("add", "ell", ((0.032, 0.0100, 0.0725), (0.0145, 0.0125, 0.0135)), 0.003, True),
    ("add", "ell", ((0.032, 0.0045, 0.0710), (0.0132, 0.0080, 0.0124)), 0.0025, True),
    ("add", "ell", ((0.031, 0.030, 0.077), (0.020, 0.0050, 0.0055), (0.0, 25.0)), 0.016, True),
    # nose: bridge to tip, the tip, the wings, the nostrils
    ("add", "cone", ((0.0, 0.022, 0.088), (0.0, -0.024, 0.104), 0.0060, 0.0080), 0.01, False),
    ("add", "ell", ((0.0, -0.027, 0.101), (0.0092, 0.0085, 0.0090)), 0.006, False),
    ("add", "ell", ((0.0110, -0.031, 0.095), (0.0075, 0.0065, 0.0070)), 0.006, True),
    ("sub", "ell", ((0.0065, -0.0375, 0.0970), (0.0028, 0.0018, 0.0035)), 0.002, True),
    # lips: upper, lower, the line between them, the corners of the mouth
    ("add", "ell", ((0.0, -0.0535, 0.0915), (0.0200, 0.0068, 0.0090)), 0.006, False),
    ("add", "ell", ((0.0, -0.0640, 0.0895), (0.0175, 0.0075, 0.0095)), 0.006, False),
    ("sub", "ell", ((0.006, -0.0598, 0.0990), (0.0150, 0.0014, 0.0035), (0.0, 14.0)), 0.002, True),
    ("sub", "ell", ((0.0215, -0.0595, 0.0920), (0.0025, 0.0018, 0.0040)), 0.003, True),
    # ears: the flap, a fleshy lobe, the tragus; the scapha and fossa carved behind the
    # helix rim, the antihelix ridge and its upper branch, the concha bowl in front
    ("add", "ell", EAR, 0.006, True),
    ("add", "ell", (_on_ear((0.0008, -0.024, 0.003)), (0.0055, 0.009, 0.008), _TILT), 0.004, True),
    ("add", "ell", (_on_ear((0.003, -0.008, 0.0145)), (0.003, 0.0045, 0.003), _TILT), 0.003, True),
    ("sub", "ell", (_on_ear((0.008, 0.003, -0.001)), (0.0042, 0.0255, 0.0145), _TILT), 0.003, True),
    (
        "add",
        "cap",
        (_on_ear((0.0036, -0.012, -0.004)), _on_ear((0.0036, 0.010, -0.002)), 0.0022),
        0.003,
        True,
    ),
    (
        "add",
        "cap",
        (_on_ear((0.0036, 0.010, -0.002)), _on_ear((0.0034, 0.016, 0.008)), 0.0018),
        0.003,
        True,
    ),
    (
        "sub",
        "ell",
        (_on_ear((0.0062, -0.007, 0.004)), (0.0048, 0.0085, 0.0068), _TILT),
        0.003,
        True,
    ),
    # neck and its muscles
    ("add", "cap", ((0.0, -0.050, -0.022), (0.0, -0.260, -0.006), 0.057), 0.025, False),
    ("add", "cap", ((0.045, -0.035, -0.020), (0.017, -0.205, 0.036), 0.012), 0.02, True),
    # shoulders, chest, back, upper arms
    ("add", "cap", ((0.030, -0.150, -0.036), (0.150, -0.235, -0.020), 0.040), 0.04, True),
    ("add", "ell", ((0.0, -0.350, -0.005), (0.155, 0.150, 0.095)), 0.04, False),
    ("add", "ell", ((0.160, -0.270, -0.008), (0.046, 0.052, 0.048)), 0.035, True),
    ("add", "cap", ((0.168, -0.280, -0.010), (0.185, -0.460, -0.015), 0.040), 0.02, True),
    ("add", "ell", ((0.060, -0.310, 0.048), (0.065, 0.045, 0.045)), 0.03, True),
    ("add", "cap", ((0.020, -0.218, 0.045), (0.140, -0.225, 0.005), 0.008), 0.02, True),
)


def _smin(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum (Quilez 2013): min(a, b) rounded over a width k."""
    if k <= 0.0:
        return np.minimum(a, b)
    h = np.maximum(k - np.abs(a - b), 0.0) / k
    return np.minimum(a, b) - 0.25 * k * h * h


def _ellipsoid(p: np.ndarray, params: tuple) -> np.ndarray:
    """Distance bound to an ellipsoid, k0 (k0 − 1) / k1 (Quilez 2008)."""
    q = p - np.asarray(params[0])
    if len(params) > 2:
        q = q @ _rotation(*params[2])  # world → local: q · R (R's columns are local axes)
    r = np.asarray(params[1])
    k0 = np.linalg.norm(q / r, axis=1)
    k1 = np.linalg.norm(q / (r * r), axis=1)
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)


def _cone(p: np.ndarray, params: tuple) -> np.ndarray:
    """Distance to a capsule from a to b whose radius goes from ra to rb."""
    a, b = np.asarray(params[0]), np.asarray(params[1])
    ra, rb = params[2], params[3] if len(params) > 3 else params[2]
    pa, ba = p - a, b - a
    h = np.clip(pa @ ba / (ba @ ba), 0.0, 1.0)
    return np.linalg.norm(pa - h[:, None] * ba, axis=1) - (ra + (rb - ra) * h)


_SHAPES = {"ell": _ellipsoid, "cap": _cone, "cone": _cone}


def bust_field(points: np.ndarray) -> np.ndarray:
    """The bust's field at (n, 3) float64 points: negative inside, about the distance (m)
    near the surface; the union and carving of :data:`_PRIMITIVES`, cut at y = -0.40."""
    p = np.asarray(points, dtype=np.float64)
    mirrored = np.column_stack([np.abs(p[:, 0]), p[:, 1], p[:, 2]])
    d = np.full(len(p), np.inf)
    for op, shape, params, k, mirror in _PRIMITIVES:
        e = _SHAPES[shape](mirrored if mirror else p, params)
        d = _smin(d, e, k) if op == "add" else -_smin(-d, e, k)
    return -_smin(-d, p[:, 1] - BUST_BOTTOM, _CUT_SOFT)


def bust_signed_distance_and_normal(points: object) -> tuple[np.ndarray, np.ndarray]:
    """Approximate signed distance (m, negative inside) to the bust and the outward unit
    gradient at points: the field over its gradient length (central differences)."""
    p = _as_points(points)
    h = 1e-5
    steps = np.concatenate([np.zeros((1, 3)), h * np.eye(3), -h * np.eye(3)])
    f = bust_field((p[None] + steps[:, None]).reshape(-1, 3)).reshape(7, len(p))
    grad = (f[1:4] - f[4:7]).T / (2 * h)
    g = np.linalg.norm(grad, axis=1)
    g = np.where(g > 1e-9, g, 1.0)
    return f[0] / g, grad / g[:, None]


def ear_distance(points: object) -> np.ndarray:
    """Approximate distance (m) from points (n, 3) to the nearer ear's flap (:data:`EAR`),
    negative inside: what keeps the scalp map's hairline off the ears."""
    p = _as_points(points).copy()
    p[:, 0] = np.abs(p[:, 0])
    return _ellipsoid(p, EAR)


def bust_signed_distance(points: object) -> np.ndarray:
    """Approximate signed distance (m) to the built-in bust, negative inside, (n,) float64."""
    return bust_signed_distance_and_normal(points)[0]


def bust_inside(points: object) -> np.ndarray:
    """True for points strictly inside the built-in bust's field (n,) bool."""
    return bust_field(_as_points(points)) < 0.0


@lru_cache(maxsize=1)
def _bust_arrays() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    with resources.files(__package__).joinpath(BUST_DATA).open("rb") as f:
        data = np.load(f)
        arrays = (data["vertices"], data["faces"], data["uvs"], data["scalp"])
    for a in arrays:
        a.setflags(write=False)
    return arrays


def _parting(n: int) -> Texture:
    """Two interpolation groups split at x = 0: red on the right (x < 0, u > 1/2)."""
    right = (np.arange(n) + 0.5) / n > 0.5
    rgb = np.where(right[None, :, None], [255, 0, 0], [0, 0, 255]).astype(np.uint8)
    return Texture(np.broadcast_to(rgb, (n, n, 3)), wrap="clamp", name=PARTING_TEXTURE)


def builtin_bust() -> SkinMesh:
    """A new SkinMesh 'bust' (about 39k triangles, UVs, ``textures['scalp']``, its hair
    density, and ``textures['parting']``, the groups the built-in guides part along)."""
    verts, faces, uvs, scalp = _bust_arrays()
    textures = {
        SCALP_TEXTURE: Texture(scalp, wrap="clamp", name=SCALP_TEXTURE),
        PARTING_TEXTURE: _parting(scalp.shape[1]),
    }
    return SkinMesh(verts, faces, uvs=uvs, name="bust", textures=textures)
