"""Hair to cards: cluster, fit the strips, pack the atlas, bake it, for every level of
detail (:func:`make_cards`), and write them (:func:`write_cards`)."""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..frames import normalize
from ..groom.guides import resample_attribute
from ..render.image import encode_srgb8
from ..rng import uniforms
from .atlas import lod_bands, pack
from .bake import bake
from .clusters import cluster_hairs
from .gltf import LodMesh, png_bytes, write_glb
from .settings import CardParams
from .strips import Strips, card_coordinates, fit_strips, strip_mesh
from .usd import write_maps, write_usd

__all__ = ["HairCards", "card_path", "make_cards", "write_cards"]

STATIONS_PER_SEGMENT = 4  # hair samples baked per strip segment
DEFAULT_COLOR = (0.3, 0.3, 0.3)  # linear RGB of hair without a colour


class HairCards(NamedTuple):
    """Cards for each level of detail and their atlas.

    ``meshes``, ``labels`` (each hair's card), ``strips`` and ``rects`` (K, 4: x, y,
    w, h texels) per level; ``maps``: the atlas's float32 maps, (S, S) ``coverage``
    and (S, S, 3) ``color`` (linear RGB), ``tangent`` (card space, unit),
    ``attribute`` (depth −1..1 of ``depth_range`` metres, root-to-tip, seed) and, for
    the unreal target, ``root_uv`` (S, S, 2: the hairs' roots' UV on the skin, 0 where
    the curves carry none)."""

    meshes: list[LodMesh]
    labels: list[np.ndarray]
    strips: list[Strips]
    rects: list[np.ndarray]
    maps: dict[str, np.ndarray]
    depth_range: float
    params: CardParams


def _skin_normals(curves: HairCurves, mesh: object | None) -> np.ndarray:
    """The skin normal at each root: the mesh's, where the curves say where their roots
    are on it; else away from the roots' centre (a head's outward direction)."""
    roots = curves.points[curves.offsets[:-1]].astype(np.float64)
    data = curves.curve_data
    if mesh is not None and "root_triangle" in data and "root_bary" in data:
        return mesh.evaluate(data["root_triangle"], data["root_bary"]).normal  # type: ignore[attr-defined]
    return normalize(roots - roots.mean(axis=0))


def _check(curves: HairCurves) -> None:
    if not isinstance(curves, HairCurves):
        raise InputError(f"curves: expected follicle.HairCurves, got {type(curves).__name__}")
    if len(curves) == 0 or np.any(curves.counts < 2):
        raise InputError(
            "curves: cards need hairs of two or more points each; grow the groom first"
        )


def make_cards(
    curves: HairCurves, mesh: object | None = None, params: CardParams | None = None
) -> HairCards:
    """Cards of ``curves`` (grown on ``mesh``, whose normals orient them) by ``params``."""
    params = params if params is not None else CardParams()
    _check(curves)
    m = params.segments * STATIONS_PER_SEGMENT + 1
    pd = curves.point_data
    n_points = curves.point_count
    extra = np.column_stack(
        [
            pd.get("width", np.full(n_points, 1e-4)),
            pd.get("opacity", np.ones(n_points)),
            pd.get("color", np.broadcast_to(DEFAULT_COLOR, (n_points, 3))),
        ]
    )
    # the points and their attributes at the same arc-length stations, in one pass
    both = np.column_stack([curves.points, extra])
    resampled = resample_attribute(
        HairCurves(curves.points, curves.offsets, {"both": both}), "both", m, what="hair"
    )
    samples = resampled[..., :3]
    width, opacity, color = resampled[..., 3], resampled[..., 4], resampled[..., 5:8]
    normals = _skin_normals(curves, mesh)
    ids = curves.curve_data.get("hair_id", np.arange(len(curves)))
    seed = uniforms(params.seed, np.asarray(ids, np.int64), "card seed", 1)[:, 0]
    t = np.linspace(0.0, 1.0, m)

    bands = lod_bands(params.atlas, params.lods, params.reserve)
    fitted = []
    for lod, count in enumerate(params.card_counts(len(curves))):
        labels = cluster_hairs(curves, count, params.seed + lod)
        strips = fit_strips(samples, labels, count, normals, width.max(axis=1))
        rects = pack(strips.width, strips.length, params.atlas, bands[lod], params.padding, lod)
        fitted.append((labels, strips, rects))
    depth_range = max(float(s.depth.max()) for _, s, _ in fitted) or 1.0

    # every level's hairs in texel space, one set of strands for the rasterizer
    xs, ws, depths, tangents = [], [], [], []
    for labels, strips, rects in fitted:
        across, depth = card_coordinates(samples, labels, strips)
        r = rects[labels].astype(np.float64)
        scale = r[:, 2] / strips.width[labels]  # texels per metre across the card
        x = r[:, 0, None] + (across / strips.width[labels, None] + 0.5) * r[:, 2, None]
        y = r[:, 1, None] + r[:, 3, None] * t[None, :]
        xs.append(np.stack([x, y, np.zeros_like(x)], axis=2))
        # at least strand_texels wide at the root, tapering as the hair does
        taper = width / np.maximum(width[:, :1], 1e-12)
        ws.append(np.maximum(width * scale[:, None], params.strand_texels * taper))
        depths.append(depth / depth_range)
        along = (strips.length[labels, None] * t[None, :]) * np.ones_like(across)
        card = np.stack([across, along, depth], axis=2)
        tangents.append(normalize(np.gradient(card, axis=1)))
    levels = len(fitted)
    n = len(curves) * levels
    points = np.concatenate(xs).reshape(-1, 3).astype(np.float32)
    offsets = np.arange(0, n * m + 1, m, dtype=np.int64)

    def flat(parts: list[np.ndarray]) -> np.ndarray:
        """The levels' per-station arrays as one (n·m, E) per-point array."""
        return np.concatenate(parts).reshape(n * m, -1)

    attribute = np.stack(
        [
            np.concatenate(depths),
            np.broadcast_to(t, (n, m)),
            np.repeat(np.tile(seed, levels)[:, None], m, axis=1),
        ],
        axis=2,
    )
    passes = [
        np.tile(color, (levels, 1, 1)).reshape(-1, 3),
        attribute.reshape(-1, 3),
        flat(tangents),
    ]
    if params.target == "unreal":  # its Attribute texture carries the roots' UV: a 4th pass
        root_uv = np.zeros((len(curves), 3))
        root_uv[:, :2] = curves.curve_data.get("root_uv", root_uv[:, :2])
        passes.append(np.repeat(np.tile(root_uv, (levels, 1)), m, axis=0))
    coverage, baked = bake(
        points,
        offsets,
        flat(ws)[:, 0],
        np.tile(opacity, (levels, 1)).reshape(-1),
        passes,
        params.atlas,
    )
    # a hair drawn at the least width reaches up to half of it past its card's edge:
    # the atlas keeps only what lies on the cards (the padding stays empty)
    inside = np.zeros(coverage.shape, bool)
    for x0, y0, w, h in np.concatenate([f[2] for f in fitted]):
        inside[y0 : y0 + h, x0 : x0 + w] = True
    coverage[~inside] = 0.0
    for values in baked:
        values[~inside] = 0.0
    col, attr, tan = baked[:3]
    maps = {"coverage": coverage, "attribute": attr, "tangent": tan}
    maps["color"] = _edge_padded(col, coverage > 0.0, params.padding + 2)
    if len(baked) > 3:
        maps["root_uv"] = baked[3][..., :2]
    meshes = [
        LodMesh(*strip_mesh(strips, rects, params.atlas, params.segments))
        for _, strips, rects in fitted
    ]
    return HairCards(
        meshes,
        [f[0] for f in fitted],
        [f[1] for f in fitted],
        [f[2] for f in fitted],
        maps,
        depth_range,
        params,
    )


def _edge_padded(color: np.ndarray, known: np.ndarray, passes: int) -> np.ndarray:
    """``color`` (S, S, 3) with the texels no hair covers given their covered
    neighbours' mean colour, grown ``passes`` texels out (edge padding, as texture
    bakers do): a mip-mapped or filtered lookup at a card's edge then blends its hair
    with hair-coloured texels, not with black ones, while the coverage there stays 0."""
    color = color.copy()
    known = known.copy()
    for _ in range(passes):
        total = np.zeros_like(color)
        count = np.zeros(known.shape, np.float32)
        for axis in (0, 1):
            for step in (1, -1):
                total += np.roll(color * known[..., None], step, axis=axis)
                count += np.roll(known, step, axis=axis)
        fill = ~known & (count > 0)
        color[fill] = total[fill] / count[fill, None]
        known |= fill
    return color


def _unit8(x: np.ndarray) -> np.ndarray:
    """Values in 0..1 to 8 bits (rounded)."""
    return np.round(np.clip(x, 0.0, 1.0) * 255.0).astype(np.uint8)


def atlas_images(cards: HairCards) -> dict[str, bytes]:
    """The atlas's maps as PNGs in the layout of ``cards.params.target``, the first
    always ``color`` (sRGB, coverage as alpha: the glTF and USD material's texture).

    generic: ``depth`` (0.5 on the card, 0 and 1 at ∓ ``depth_range``), ``attribute``
    (root-to-tip, seed, coverage) and ``tangent`` (card space: across, along, out of the
    card; 0.5 + t/2).

    unreal: the textures of the groom cards' slots as Unreal's card shaders read them
    (Engine/Shaders/Private/HairStrands/HairCardsAttributeCommon.ush: its Depth, Coverage,
    Tangent and Attribute textures): ``depth`` R, the depth the engine adds to the
    pixel's, in its units, centimetres, behind the card (hairs in front of it 0, at most
    1 cm); ``coverage`` R; ``tangent`` RGB in the card's tangent space (U across, V
    along, the face normal) as 0.5 + t/2; ``attribute`` RGBA: the roots' UV on the skin
    (RG), the coordinate along the hair from root 0 to tip 1 (B) and a seed (A). The
    colour is the Material slot's texture."""
    maps = cards.maps
    cov = maps["coverage"]
    rgb = encode_srgb8(np.concatenate([maps["color"], np.ones_like(cov)[..., None]], axis=2))
    color = np.concatenate([rgb[..., :3], _unit8(cov)[..., None]], axis=2)
    attr = maps["attribute"]
    tangent = png_bytes(_unit8(0.5 + 0.5 * maps["tangent"]))
    if cards.params.target == "unreal":
        behind_cm = -attr[..., 0] * cards.depth_range * 100.0
        return {
            "color": png_bytes(color),
            "depth": png_bytes(_unit8(behind_cm)),
            "coverage": png_bytes(_unit8(cov)),
            "tangent": tangent,
            "attribute": png_bytes(
                _unit8(np.concatenate([maps["root_uv"], attr[..., 1:3]], axis=2))
            ),
        }
    return {
        "color": png_bytes(color),
        "depth": png_bytes(_unit8(0.5 + 0.5 * attr[..., 0])),
        "attribute": png_bytes(_unit8(np.stack([attr[..., 1], attr[..., 2], cov], axis=2))),
        "tangent": tangent,
    }


def card_path(path: str | Path) -> Path:
    """``path`` as a cards output: InputError unless it names glTF binary or USD (checked
    by the command and :func:`follicle.cards` before any hair is grown or baked)."""
    path = Path(path)
    if path.suffix.lower() not in (".glb", ".usd", ".usda", ".usdc"):
        raise InputError(
            f"{path}: cards are written as glTF binary (.glb) or USD (.usd, .usda, .usdc);"
            " name the output so"
        )
    return path


def write_cards(cards: HairCards, path: str | Path) -> Path:
    """Write ``cards`` to ``path``, atomically: glTF binary (.glb), or USD (.usd, .usda,
    .usdc) with the atlas's maps as PNGs beside it (``NAME_color.png`` …); for the
    unreal target, a .glb's maps are also written beside it, the textures Unreal's
    groom editor takes for its card slots."""
    path = card_path(path)
    images = atlas_images(cards)
    if path.suffix.lower() == ".glb":
        if cards.params.target == "unreal":
            write_maps(path, images)
        extras = {
            "depth_range_m": cards.depth_range,
            "cards_per_lod": [len(r) for r in cards.rects],
        }
        write_glb(path, cards.meshes, images, cards.params.alpha_cutoff, extras)
    else:
        write_usd(path, cards.meshes, images, cards.params.alpha_cutoff)
    return path
