"""Built-in guide sets ("long", "short", "curly") grown on the built-in head or bust by code.

Roots come from a small deterministic sampler (Halton (2, 3) points mapped to
triangles by an area × scalp-density CDF). Each strand is marched from its root
along the surface normal, bent by a comb field (a centre parting, hair going back
and down) and by gravity, and after every step pushed out of the head to a small
clearance, keeping every segment the same length. Curly guides wind a helix around
such a path (Almeida 2014 §3.1.2). curve_data: ``root_triangle`` int64, ``root_bary``
float32 (seed convention, Šik 2012 §2.2.3), ``root_uv`` float32, ``guide_id`` int64.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..frames import normalize
from ..mesh.bust import builtin_bust, bust_signed_distance_and_normal
from ..mesh.head import SCALP_TEXTURE, builtin_head, head_signed_distance_and_normal
from ..mesh.sampling import DensitySampler
from ..mesh.skin import SkinMesh
from ..mesh.texture import Texture
from ..validate import whole

__all__ = ["builtin_guides", "BUILTIN_GUIDES"]


class _Style(NamedTuple):
    vertices: int
    length: float  # length of the path (for curly: of the helix axis)
    gravity: float  # weight of -Y in the wanted direction
    comb: float  # weight of the comb field in the wanted direction
    bend: float  # how far each step turns towards the wanted direction (0..1)
    lift: float  # weight of the surface normal in the first direction
    hug_all: bool  # lie on the whole head (short), else only where the head faces up
    curl_radius: float = 0.0
    curl_turns: float = 0.0


BUILTIN_GUIDES = {
    "long": _Style(24, 0.30, 1.0, 0.7, 0.45, 0.5, False),
    "short": _Style(16, 0.05, 0.5, 1.0, 0.5, 0.25, True),
    "curly": _Style(32, 0.22, 1.0, 0.7, 0.45, 0.6, False, curl_radius=0.02, curl_turns=3.5),
}
_COUNT = 300
_CLEARANCE = 0.003  # m kept between hair and head
_MIN_DENSITY = 0.5
_FACE_DEPTH = 0.1  # m in front of the head's centre where the side comb is strongest
# hanging hair: the face's half width (m, about the eyes' outer corners) where the side
# comb grows, and how far beside it that extra comb fades out (gone beyond the temples)
_FACE_HALF_WIDTH = 0.05
_FACE_FADE = 0.04
# hanging hair beside the face: the parting's side comb fades out from _SIDES_TOP +
# _TOP_FADE above the head's centre (above the temples) down to _SIDES_TOP (just above
# the ears, m)
_SIDES_TOP = 0.02
_TOP_FADE = 0.05

SDF = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
# the built-in meshes with an analytic signed distance; their head centre is the origin
_ANALYTIC: tuple[tuple[Callable[[], SkinMesh], SDF], ...] = (
    (builtin_head, head_signed_distance_and_normal),
    (builtin_bust, bust_signed_distance_and_normal),
)


def sample_roots(mesh: SkinMesh, count: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` deterministic roots where the scalp density exceeds 0.5: (triangles, bary).

    Halton (2, 3) samples of the density sampler on the scalp map cut below 0.5; the
    bilinear map still ramps up across the cut, so the few roots that land where it
    is ≤ 0.5 are skipped.
    """
    tex = mesh.textures.get(SCALP_TEXTURE)
    if tex is None or mesh.uvs is None:
        tri, bary = DensitySampler(mesh).sample(count, sequence="halton", start=1)
        return tri, bary
    values = tex.data[:, :, 0]
    if not values.max() > _MIN_DENSITY:
        raise InputError(f"mesh '{mesh.name}': no area with scalp density > {_MIN_DENSITY}")
    cut = Texture(np.where(values > _MIN_DENSITY, values, 0.0), wrap=tex.wrap, name=tex.name)
    sampler = DensitySampler(mesh, cut)
    tris: list[np.ndarray] = []
    barys: list[np.ndarray] = []
    start = 1
    while sum(len(t) for t in tris) < count:
        tri, bary = sampler.sample(2 * count, sequence="halton", start=start)
        start += 2 * count
        keep = tex.sample(mesh.evaluate(tri, bary).uv) > _MIN_DENSITY
        tris.append(tri[keep])
        barys.append(bary[keep])
    return np.concatenate(tris)[:count], np.concatenate(barys)[:count]


def _mesh_sdf(mesh: SkinMesh) -> SDF:
    """Signed distance and outward direction from exact closest points on the rest mesh."""

    def sdf(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        tri, bary, dist = mesh.closest_points(p)
        surf = mesh.evaluate(tri, np.clip(bary, 0.0, 1.0))
        away = p - surf.position
        sign = np.where(np.sum(away * surf.normal, axis=1) < 0, -1.0, 1.0)
        direction = np.where(dist[:, None] > 1e-9, normalize(away) * sign[:, None], surf.normal)
        return sign * dist, direction

    return sdf


def _analytic_sdf(mesh: SkinMesh) -> SDF | None:
    """The analytic signed distance of the built-in mesh ``mesh`` is (its rest vertices
    equal), else None."""
    for make, sdf in _ANALYTIC:
        rest = make().rest_vertices
        if mesh.rest_vertices.shape == rest.shape and np.array_equal(mesh.rest_vertices, rest):
            return sdf
    return None


def _push_out(
    p: np.ndarray, prev: np.ndarray, seg: np.ndarray, sdf: SDF, clear: float | np.ndarray
):
    """Move points closer than ``clear`` (a number or (C,)) to the head out, keeping
    |p - prev| = seg (C, 1)."""
    for _ in range(4):
        dist, normal = sdf(p)
        inside = dist < clear
        if not inside.any():
            break
        p = p + np.where(inside, clear - dist, 0.0)[:, None] * normal
        p = prev + seg * normalize(p - prev)  # re-normalise the segment
    return p


def _comb_field(
    p: np.ndarray, centre: np.ndarray, parting_side: np.ndarray, hangs: bool
) -> np.ndarray:
    """Style direction: away from a centre parting and towards the back.

    ``parting_side`` (C,) ±1 is the side of the parting each strand's root is on; the
    strand is combed at least half strength towards it, so one rooted on the parting line
    itself does not slide straight down a steep forehead over the face. In front of the
    head's centre (the face looks towards +Z) the side comb grows, up to three times at
    :data:`_FACE_DEPTH`: hair from the front hairline is combed aside, clear of the
    eyes, rather than falling down the face with gravity.

    Hair that ``hangs`` (not lying on the whole head, as short hair does, which never
    points out of it) is combed aside only where it would fall over the face: the
    extra comb is strongest within :data:`_FACE_HALF_WIDTH` of the mid-plane and fades
    out over :data:`_FACE_FADE` beside it, and the parting's own side comb fades out
    below the top of the head (from :data:`_SIDES_TOP` + :data:`_TOP_FADE` above the
    centre down to :data:`_SIDES_TOP`). Hair at the temples, sides and back then falls
    down by the head instead of flaring out from it.
    """
    side = parting_side * np.maximum(np.tanh((p[:, 0] - centre[0]) / 0.015) * parting_side, 0.5)
    front = np.clip((p[:, 2] - centre[2]) / _FACE_DEPTH, 0.0, 1.0)
    if hangs:
        over = np.abs(p[:, 0] - centre[0]) - _FACE_HALF_WIDTH
        over = np.clip(1.0 - over / _FACE_FADE, 0.0, 1.0)
        top = np.clip((p[:, 1] - centre[1] - _SIDES_TOP) / _TOP_FADE, 0.0, 1.0)
        side = side * np.maximum(top, over * (1.0 + 2.0 * front))
    else:
        side = side * (1.0 + 2.0 * front)
    return np.stack([0.6 * side, np.zeros(len(p)), -0.5 * np.ones(len(p))], axis=1)


def _march(
    roots: np.ndarray,
    normals: np.ndarray,
    style: _Style,
    sdf: SDF,
    centre: np.ndarray,
    clear: float,
    length: np.ndarray,
) -> np.ndarray:
    """Grow (C, n, 3) paths of the given lengths (C,) with equal segments.

    Every step turns the direction towards gravity plus the comb field; near the
    head that wanted direction loses its outward part (hair lies on the skull where
    the skull faces up, everywhere for short hair); then the new vertex is pushed
    out of the head and the segment re-normalised.
    """
    count = style.vertices
    seg = (length / (count - 1))[:, None]
    down = np.array([0.0, -1.0, 0.0])
    out = np.empty((len(roots), count, 3))
    out[:, 0] = roots
    parting_side = np.where(roots[:, 0] >= centre[0], 1.0, -1.0)
    d = normalize(
        style.lift * normals
        + _comb_field(roots, centre, parting_side, not style.hug_all)
        + 0.5 * down
    )
    for i in range(1, count):
        prev = out[:, i - 1]
        clear_i = clear + _helix_radius(style, i * seg[:, 0])
        dist, n_s = sdf(prev)
        want = style.gravity * down + style.comb * _comb_field(
            prev, centre, parting_side, not style.hug_all
        )
        hug = np.ones(len(prev)) if style.hug_all else np.clip(3.0 * n_s[:, 1], 0.0, 1.0)
        hug = hug * (dist < clear_i + 0.02)
        outward = np.maximum(np.sum(want * n_s, axis=1), 0.0)
        want = normalize(want - (hug * outward)[:, None] * n_s)
        d = normalize((1.0 - style.bend) * d + style.bend * want)
        nxt = _push_out(prev + seg * d, prev, seg, sdf, clear_i)
        d = normalize(nxt - prev)
        out[:, i] = nxt
    return out


def _transport_frames(path: np.ndarray, normal0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frames (N, B) along (C, n, 3) paths by projecting the previous N (parallel transport)."""
    tangent = np.gradient(path, axis=1)
    tangent = normalize(tangent)
    nvec = np.empty_like(path)
    cur = normal0
    for i in range(path.shape[1]):
        t = tangent[:, i]
        cur = cur - np.sum(cur * t, axis=1, keepdims=True) * t
        bad = np.linalg.norm(cur, axis=1) < 1e-6
        cur[bad] = np.cross(t[bad], [0.0, 0.0, 1.0]) + 1e-3 * np.cross(t[bad], [1.0, 0, 0])
        cur = normalize(cur)
        nvec[:, i] = cur
    return nvec, np.cross(tangent, nvec)


def _helix_radius(style: _Style, arc: np.ndarray) -> np.ndarray:
    """The curl's radius at arc length ``arc`` (m) along its axis: none at the root,
    growing in over the first 3 cm."""
    return style.curl_radius * np.clip(arc / 0.03, 0.0, 1.0) ** 2


def _curl(path: np.ndarray, normal0: np.ndarray, style: _Style, phase: np.ndarray) -> np.ndarray:
    """Helix of ``curl_radius`` around the path (Almeida 2014 §3.1.2), growing in over the
    first 3 cm."""
    arc = np.concatenate(
        [np.zeros((len(path), 1)), np.cumsum(np.linalg.norm(np.diff(path, axis=1), axis=2), 1)],
        axis=1,
    )
    radius = _helix_radius(style, arc)
    angle = 2 * np.pi * style.curl_turns * arc / arc[:, -1:] + phase[:, None]
    nv, bv = _transport_frames(path, normal0)
    offset = np.cos(angle)[:, :, None] * nv + np.sin(angle)[:, :, None] * bv
    return path + radius[:, :, None] * offset


def _follow(targets: np.ndarray, sdf: SDF, clear: float) -> np.ndarray:
    """Equal-segment strands following target polylines, kept out of the head."""
    seg = np.linalg.norm(np.diff(targets, axis=1), axis=2).sum(axis=1) / (targets.shape[1] - 1)
    seg = seg[:, None]
    out = np.empty_like(targets)
    out[:, 0] = targets[:, 0]
    for i in range(1, targets.shape[1]):
        prev = out[:, i - 1]
        nxt = prev + seg * normalize(targets[:, i] - prev)
        out[:, i] = _push_out(nxt, prev, seg, sdf, clear)
    return out


def builtin_guides(name: str, mesh: SkinMesh | None = None, count: int = _COUNT) -> HairCurves:
    """Built-in guides 'long', 'short' or 'curly' (``count``, default 300) on ``mesh``.

    ``mesh`` defaults to the built-in head. On the built-in head or bust collisions use
    its analytic signed distance; on another mesh they use exact closest points (its
    ``textures['scalp']`` is the density if present, else the whole surface grows hair).
    """
    if name not in BUILTIN_GUIDES:
        raise InputError(f"unknown built-in guides {name!r}; choose one of {list(BUILTIN_GUIDES)}")
    count = whole(count, "count", 1, what="a whole number of guides")
    style = BUILTIN_GUIDES[name]
    if mesh is None:
        mesh = builtin_head()
    analytic = _analytic_sdf(mesh)
    lo, hi = mesh.bounds("rest")
    centre = np.zeros(3) if analytic is not None else 0.5 * (lo + hi)
    sdf: SDF = analytic if analytic is not None else _mesh_sdf(mesh)

    tri, bary = sample_roots(mesh, int(count))
    surf = mesh.evaluate(tri, bary.astype(np.float64))
    rng = np.random.default_rng(20240601)  # fixed: the built-in sets never change
    length = style.length * (1.0 + 0.1 * rng.uniform(-1.0, 1.0, size=len(tri)))
    if style.curl_radius > 0:
        path = _march(surf.position, surf.normal, style, sdf, centre, _CLEARANCE, length)
        phase = rng.uniform(0.0, 2 * np.pi, size=len(tri))
        strands = _follow(_curl(path, surf.tangent, style, phase), sdf, _CLEARANCE)
    else:
        path = _march(surf.position, surf.normal, style, sdf, centre, _CLEARANCE, length)
        strands = _follow(path, sdf, _CLEARANCE)
    curve_data = {
        "root_triangle": tri.astype(np.int64),
        "root_bary": bary.astype(np.float32),
        "root_uv": surf.uv.astype(np.float32),
        "guide_id": np.arange(len(tri), dtype=np.int64),
    }
    return HairCurves.from_array(strands, curve_data=curve_data)
