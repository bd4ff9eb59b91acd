"""Starter guides: guides made on any mesh from a few numbers, for a groom to start from.

Groomers rarely draw guides from nothing: Houdini's Guide Initialize, Blender's "add
curves" and XGen's guides from normals all plant guides over the skin, straight out
along the normal or lying along a comb direction, and let gravity bend them. This is
that step for follicle:

1. roots: ``count`` points spread evenly over the rest mesh by area × density, the
   Halton (2, 3) sequence of the density sampler (Šik 2012 §2.1), as the built-in
   guides place theirs; ``seed`` picks which run of the sequence;
2. direction: the surface normal ("normal"), or ("comb") the comb direction projected
   onto the skin's tangent plane at the root and lifted off it by ``lift`` degrees;
3. gravity: segment i is turned towards −Y (the scene's down) by ``gravity`` × s_i of
   the angle between its direction and straight down, s_i the place of its far end
   along the guide (1 at the tip): ``gravity = 1`` leaves the tip hanging straight down;
4. the skin: every vertex but the root is kept out of the skin by follow-the-leader
   (as a brushed guide is, :func:`follicle.groom.brushes.follow`) on the skin's signed
   distance field, every segment keeping its length, so a guide never dives into the
   skin and its length is the one asked for.

``length`` is a value or a PropertyMap (value × texture at the root's UV, Šik 2012
§2.2.2); where it is 0 no guide grows (a mask), and it may not be negative. The guides
are bound to the mesh's rest pose (``root_triangle``/``root_bary``) as
:func:`follicle.load_guides` binds loaded ones, so the groom takes them alike.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..frames import normalize
from ..mesh.property import PropertyMap
from ..mesh.sampling import DensitySampler
from ..mesh.sdf import skin_sdf
from ..mesh.skin import SkinMesh
from ..mesh.texture import Texture
from ..validate import number, whole
from .brushes import follow, segment_lengths
from .groups import InterpolationGroups
from .guides import Guides

__all__ = ["generate_guides", "default_length", "shown_length", "GENERATE_MODES"]

GENERATE_MODES = ("normal", "comb")
DEFAULT_SHARE = 0.08  # a generated guide's default length: this share of the mesh's diagonal
_DOWN = np.array([0.0, -1.0, 0.0])  # +Y is up (docs: Data conventions)
_PUSH_TRIES = 16  # push-outs of a vertex before follow() gives up (a crease needs several)


def default_length(mesh: SkinMesh) -> float:
    """The length generated guides take unless told: 8 % of the diagonal of ``mesh``'s
    rest bounding box (fur in proportion to the creature, whatever its units)."""
    lo, hi = mesh.bounds("rest")
    return DEFAULT_SHARE * float(np.linalg.norm(hi - lo))


def shown_length(metres: float) -> str:
    """A length as a person reads it: ``1.2 cm``, ``4 mm``, ``0.3 m`` (3 digits)."""
    unit, scale = ("m", 1.0) if metres >= 1 else ("cm", 100.0) if metres >= 0.01 else ("mm", 1e3)
    return f"{metres * scale:.3g} {unit}"


def _lengths(length: float | PropertyMap | None, mesh: SkinMesh, uv: np.ndarray) -> np.ndarray:
    """Each root's length (C,): ``length``'s value, or value × texture(uv)."""
    if length is None:
        return np.full(len(uv), default_length(mesh))
    if not isinstance(length, PropertyMap):
        return np.full(len(uv), number(length, "length", lo=0.0, lo_open=True, unit="m"))
    if not length.constant and mesh.uvs is None:
        raise InputError(
            f"{length.name}: a texture is read at the roots' UVs, and mesh '{mesh.name}' has"
            " none; give a number, or a mesh with UVs"
        )
    values = length.evaluate(uv)
    if values.size and values.min() < 0:
        raise InputError(
            f"{length.name}: value × texture is {values.min():g} at some roots; a length may"
            " not be negative: mend the texture (its texels scale the value)"
        )
    return values


def _rotate_towards(d: np.ndarray, target: np.ndarray, share: np.ndarray, spare: np.ndarray):
    """Unit directions ``d`` (C, 3) turned towards ``target`` (3,) by ``share`` (C,) of
    the angle between them (Rodrigues); about ``spare`` (C, 3) where ``d`` is (anti)parallel
    to it and the turning axis is undefined."""
    axis = np.cross(d, target)
    sin = np.linalg.norm(axis, axis=1)
    cos = d @ target
    lost = sin < 1e-9
    axis[lost] = np.cross(d[lost], spare[lost])
    axis = normalize(axis)
    angle = share * np.arctan2(sin, cos)
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    # Rodrigues, axis ⟂ d: d cos θ + (axis × d) sin θ
    return d * c + np.cross(axis, d) * s


def _start(mode: str, normal: np.ndarray, tangent: np.ndarray, comb: np.ndarray, lift: float):
    """Each guide's first direction (C, 3): the normal, or the comb direction in the
    tangent plane lifted ``lift`` degrees off it (the root tangent where the comb
    points along the normal and has no part in the plane)."""
    if mode == "normal":
        return normal
    along = comb[None] - (normal @ comb)[:, None] * normal
    flat = np.linalg.norm(along, axis=1) < 1e-6
    along[flat] = tangent[flat]
    a = math.radians(lift)
    return normalize(math.cos(a) * normalize(along) + math.sin(a) * normal)


def generate_guides(
    mesh: SkinMesh,
    mode: Literal["normal", "comb"] = "normal",
    *,
    count: int = 300,
    length: float | PropertyMap | None = None,
    vertices: int = 12,
    comb: Sequence[float] = (0.0, 0.0, 1.0),
    lift: float = 30.0,
    gravity: float = 0.0,
    seed: int = 0,
    density: Texture | float | None = None,
    groups: InterpolationGroups | None = None,
) -> Guides:
    """Starter guides on ``mesh``, ready to grow hair from (``Groom(mesh, guides)``).

    ``mode`` "normal" grows them straight out of the skin, "comb" along the world
    direction ``comb`` projected onto the skin and lifted ``lift`` degrees (0: lying on
    it, 90: along the normal). ``count`` guides of ``vertices`` vertices are spread
    evenly by area × ``density`` (None: area alone); ``length`` in metres (or a
    PropertyMap: value × texture; None: 8 % of the mesh's bounding-box diagonal);
    ``gravity`` in [0, 1] bends them down towards the tip (1: the tip hangs straight
    down); ``seed`` picks another evenly spread set of roots. No vertex enters the
    skin, and the same arguments give the same bytes. ``groups`` are the interpolation
    groups (None: one).
    """
    if not isinstance(mesh, SkinMesh):
        raise InputError(f"mesh: expected a SkinMesh, got {type(mesh).__name__}")
    if mode not in GENERATE_MODES:
        raise InputError(f"generate: got {mode!r}; use one of {list(GENERATE_MODES)}")
    count = whole(count, "count", 1, 100_000, what="a whole number of guides")
    vertices = whole(vertices, "vertices", 2, 256, what="a whole number of vertices per guide")
    seed = whole(seed, "seed", 0, 2**31 - 1)
    gravity = number(gravity, "gravity", lo=0.0, hi=1.0)
    lift = number(lift, "lift", lo=0.0, hi=90.0, unit="degrees")
    c = np.asarray(comb, dtype=np.float64)
    if c.shape != (3,) or not np.isfinite(c).all() or not np.linalg.norm(c) > 0:
        raise InputError(f"comb: expected a direction of 3 finite numbers, not all 0 (got {comb})")
    tri, bary = DensitySampler(mesh, density).sample(
        count, sequence="halton", start=1 + seed * count
    )
    surf = mesh.evaluate(tri, bary.astype(np.float64))
    grow = _lengths(length, mesh, surf.uv)
    keep = np.flatnonzero(grow > 0)
    if len(keep) == 0:
        raise InputError(
            f"{getattr(length, 'name', 'length')}: 0 at every root, so no guide grows;"
            " give a length > 0 where hair should grow"
        )
    tri, bary, grow = tri[keep], bary[keep], grow[keep]
    normal, tangent = surf.normal[keep], surf.tangent[keep]
    d0 = _start(mode, normal, tangent, normalize(c), lift)
    s = (np.arange(vertices - 1) + 1.0) / (vertices - 1)  # segment i's end along the guide
    share = gravity * np.ones(len(d0))
    steps = np.stack([_rotate_towards(d0, _DOWN, share * si, tangent) for si in s], axis=1)
    seg = grow / (vertices - 1)
    points = np.empty((len(keep), vertices, 3))
    points[:, 0] = surf.position[keep]
    points[:, 1:] = points[:, :1] + np.cumsum(steps * seg[:, None, None], axis=1)
    sdf = skin_sdf(mesh)
    clearance = min(0.5 * sdf.voxel, 0.25 * float(seg.min()))
    follow(points, segment_lengths(points), sdf, clearance, tries=_PUSH_TRIES)
    curve_data = {
        "root_triangle": tri.astype(np.int64),
        "root_bary": bary.astype(np.float32),
        "root_uv": surf.uv[keep].astype(np.float32),
        "guide_id": np.arange(len(keep), dtype=np.int64),
    }
    curves = HairCurves.from_array(points.astype(np.float32), curve_data=curve_data)
    return Guides(curves, mesh, groups=groups)
