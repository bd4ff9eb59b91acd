"""Targets: the names, types and units each tool reads, applied to hair before writing.

follicle's own attribute names (``width`` diameters in metres, ``color``, ``root_uv``,
``hair_id`` int64, …) are what it reads back, but each tool that opens a groom looks for
its own: Blender's hair tools look for ``surface_uv_coordinate`` and drop every int64
attribute; Houdini calls colours ``Cd``, opacity ``Alpha``, ids ``id`` and binds guides to
the skin with ``skinprim`` / ``skinprimuv``; Unreal imports only ``groom_*`` attributes
of its groom schema, in centimetres, at most 255 points a curve; Unity's hair package
refuses a whole file for one curve with fewer than 2 points. A :class:`Target` says all
of that as data, and :func:`for_target` turns one chunk of HairCurves into what the
target reads — the same for every format, so a writer only adds what its container
needs (USD: ``GroomAPI``; Alembic: the groom schema's version properties).

What each importer keeps is a table too (:attr:`Target.alembic_reads`, read from the
importers' own sources, cited where each Target is made), so ``follicle check`` lists
what it would drop rather than assume it reads everything.

The table in the docs (How-to › Formats › Targets) is :data:`TARGETS`, written out.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field

import numpy as np

from ..curves import HairCurves
from ..errors import FormatError, InputError
from .attributes import DEFAULT_WIDTH

__all__ = [
    "NAMED_FORMATS",
    "Target",
    "TARGETS",
    "TARGET_NAMES",
    "get_target",
    "for_target",
    "problems",
    "export_fix",
    "MAX_UNREAL_POINTS",
    "GUIDE_ID_BASE",
    "check_named",
    "writer_extras",
]

# the formats written with attribute names, and with the guides and skin beside the hair
NAMED_FORMATS = (".usd", ".usda", ".usdc", ".usdz", ".abc")


def check_named(name: str, suffix: str, target: str, option: str = "target") -> None:
    """Refuse a ``target`` other than generic for a ``suffix`` outside
    :data:`NAMED_FORMATS`: only USD and Alembic carry the tools' attribute names, so
    elsewhere it would be silently ignored. FormatError naming ``name`` (the file),
    the ``option`` that set the target, and the fix."""
    if target != "generic" and suffix.lower() not in NAMED_FORMATS:
        raise FormatError(
            f"{name}: {option} {target} is for USD and Alembic files"
            f" ({', '.join(NAMED_FORMATS)}); write one of those or target generic"
        )


def writer_extras(path: str | os.PathLike[str], target: str, guides: object, mesh: object) -> dict:
    """The writer options for a grown groom's file ``path``: for USD and Alembic
    (:data:`NAMED_FORMATS`) the ``target`` tool, the ``guides`` and the skin ``mesh``
    (None for none); for other formats, which hold the hair alone, none."""
    if os.path.splitext(os.fspath(path))[1].lower() not in NAMED_FORMATS:
        return {}
    return {"target": target, "guides": guides, "mesh": mesh}


log = logging.getLogger("follicle")

MAX_UNREAL_POINTS = 255  # Unreal's groom builder stores a curve's point count in a byte
# Unreal's groom_id of guide k: GUIDE_ID_BASE + k, apart from every hair's (its hair_id,
# below it), as the schema's ids name one strand each (groom_closest_guides names guides
# by it); ids are int32 in [0, INT_MAX] (Alembic for Grooms specification, Geometry
# Parameters: groom_id, groom_closest_guides)
GUIDE_ID_BASE = 2**30
_INT32 = np.iinfo(np.int32)


@dataclass(frozen=True)
class Target:
    """What one tool reads: attribute renames (ours → theirs, per point and per curve),
    copies kept under a second name, whether ids must be int32, the file units (metres
    per unit) and the curve sizes it accepts."""

    name: str
    tool: str  # the tool's name, as messages say it
    reads: str  # what of it reads the file (the docs' table)
    point_names: dict[str, str] = field(default_factory=dict)
    curve_names: dict[str, str] = field(default_factory=dict)
    int32: bool = True  # 64-bit integer attributes written as int32 (dropped if too big)
    meters_per_unit: float = 1.0
    width_meters_per_unit: float | None = None  # the widths' unit when not the points'
    max_points: int | None = None
    guide_flag: str | None = None  # an int attribute, 1 on guides and 0 on hair
    houdini_skin: bool = False  # root_triangle / root_bary → skinprim / skinprimuv
    prefix: str | None = None  # the tool reads only attributes named so (and widths)
    groom_schema: bool = False  # Unreal's: USD GroomAPI on the hair, Alembic's version keys
    alembic_reads: frozenset[str] | None = None  # what its Alembic importer keeps (None: all)
    alembic_importer: str = ""  # that importer, as messages name it
    unused: frozenset[str] = frozenset()  # ours that it has no use for: not written
    formats: tuple[str, ...] | None = None  # the only suffixes its hair importer reads
    groups: bool = False  # each curve's interpolation group as curve_data['group']
    vertex_uv: bool = False  # root_uv written per vertex as 'uv' (the root's on every one)
    guides: bool = True  # the guides written beside the hair (False: left out)
    alembic_mesh: bool = True  # a skin mesh in its Alembic files (False: left out)
    only: frozenset[str] | None = None  # the attributes written (None: all it reads)

    @property
    def scale(self) -> float:
        """File units per metre: points and widths are multiplied by it."""
        return 1.0 / self.meters_per_unit

    @property
    def width_scale(self) -> float:
        """File width units per metre: widths are multiplied by it."""
        return 1.0 / (self.width_meters_per_unit or self.meters_per_unit)


TARGETS: dict[str, Target] = {
    t.name: t
    for t in (
        Target(
            "generic", "Blender", "any USD or Alembic reader; opens right in Blender and Houdini"
        ),
        Target(
            "blender",
            "Blender",
            "Blender 4–5 hair curves (its hair tools' attribute names)",
            curve_names={"root_uv": "surface_uv_coordinate"},
            # measured, bpy 5.0.1 (tests/test_blender.py): its Alembic curves importer
            # keeps the points and radius (width / 2) only
            alembic_reads=frozenset({"width"}),
            alembic_importer="Blender's Alembic importer",
            unused=frozenset({"normal"}),
        ),  # its hair is round tubes: USD import drops them
        Target(
            "houdini",
            "Houdini",
            "Houdini SOPs and Solaris (its groom attribute names)",
            # Houdini's own names: Cd and Alpha (colour, opacity) and uv
            # (sidefx.com/docs/houdini/model/attributes.html); id, a guide's or strand's
            # unique id (Epic's MetaHuman for Houdini, "HDA reference": @id → groom_id)
            point_names={"color": "Cd", "opacity": "Alpha"},
            curve_names={"root_uv": "uv", "hair_id": "id", "guide_id": "id"},
            int32=False,
            houdini_skin=True,
        ),
        Target(
            "unreal",
            "Unreal",
            "Unreal Engine's groom import (Alembic groom schema, USD GroomAPI)",
            point_names={"color": "groom_color"},
            curve_names={
                "root_uv": "groom_root_uv",
                "hair_id": "groom_id",
                "guide_id": "groom_id",
                "group": "groom_group_id",
                "closest_guides": "groom_closest_guides",
                "guide_weights": "groom_guide_weights",
            },
            meters_per_unit=0.01,
            max_points=MAX_UNREAL_POINTS,
            guide_flag="groom_guide",
            prefix="groom_",
            groom_schema=True,
            groups=True,
            # FAlembicHairTranslator::CanTranslate (Engine/Plugins/Runtime/HairStrands/
            # Source/AlembicHairImporter/Private/AlembicHairTranslator.cpp): "Any PolyMesh
            # will cause the Alembic to be rejected by this translator"
            alembic_mesh=False,
        ),
        Target(
            "unity",
            "Unity",
            "Unity's hair package (com.unity.demoteam.hair), through its Alembic importer",
            # com.unity.formats.alembic: Source/abci/Importer/aiCurves.cpp and
            # Documentation~/curves.md read positions, nVertices, width, UV and
            # velocities only; AlembicCurvesElement.cs sizes UVs per vertex
            # (uvs.ResizeDiscard(positionCount)); com.unity.demoteam.hair:
            # Editor/HairAssetBuilder.cs reads the root UV as UVs[i * vertexCount] and
            # builds a strand group of every AlembicCurves it finds (guides included),
            # from Alembic only (BuildHairAssetAlembic)
            int32=False,
            alembic_reads=frozenset({"width", "uv"}),
            alembic_importer="Unity's Alembic importer (com.unity.formats.alembic)",
            formats=(".abc",),
            groups=True,
            vertex_uv=True,
            guides=False,
            only=frozenset({"width", "uv"}),
            # the hair package reads Alembic positions in metres and diameters in
            # centimetres by default (HairAsset: alembicScalePositions = DataInMeters,
            # alembicScaleDiameters = DataInCentimeters)
            width_meters_per_unit=0.01,
        ),
    )
}
TARGET_NAMES = tuple(TARGETS)


def get_target(name: object, key: str = "target") -> Target:
    """The Target called ``name`` (a Target passes through); InputError naming ``key``."""
    if isinstance(name, Target):
        return name
    if not isinstance(name, str) or name not in TARGETS:
        raise InputError(f"{key}: unknown target {name!r}; use one of {', '.join(TARGET_NAMES)}")
    return TARGETS[name]


def _narrow_ints(data: dict[str, np.ndarray], what: str) -> dict[str, np.ndarray]:
    """64-bit (and unsigned 32-bit) integer arrays as int32; one that does not fit is
    dropped with a warning naming it."""
    out = {}
    for k, v in data.items():
        if v.dtype.kind in "iu" and v.dtype.itemsize >= 4 and v.dtype != np.int32:
            if v.size and (v.min() < _INT32.min or v.max() > _INT32.max):
                log.warning(
                    "%s '%s' not written: its values (%d … %d) do not fit the int32"
                    " the target reads",
                    what,
                    k,
                    int(v.min()),
                    int(v.max()),
                )
                continue
            v = v.astype(np.int32)
        out[k] = v
    return out


def _sized(curves: HairCurves, target: Target, role: str) -> HairCurves:
    """Curves longer than the target holds resampled to its most points. (No curve has
    fewer than 2 points, which Unity refuses: HairCurves cannot hold one, and readers
    leave such curves out with a warning.)"""
    counts = curves.counts
    if target.max_points is None or not (counts > target.max_points).any():
        return curves
    from .tfx import resample_fixed  # evenly by arc length, attributes interpolated

    long = counts > target.max_points
    log.warning(
        "%s: %d %s curve(s) of more than %d points resampled to %d by arc length",
        target.name,
        int(long.sum()),
        role,
        target.max_points,
        target.max_points,
    )
    keep, cut = curves[np.flatnonzero(~long)], curves[np.flatnonzero(long)]
    floats = {k: v for k, v in cut.point_data.items() if v.dtype.kind == "f"}
    pos, attrs = resample_fixed(cut, target.max_points, floats)
    n = target.max_points
    point_data = {
        k: attrs[k].reshape((len(cut) * n,) + cut.point_data[k].shape[1:]) for k in floats
    }
    dropped = sorted(set(cut.point_data) - set(floats))
    if dropped:
        log.warning(
            "%s: per-point %s of the resampled curves left out (not numbers to interpolate)",
            target.name,
            ", ".join(dropped),
        )
    resampled = HairCurves.from_array(pos, point_data, dict(cut.curve_data))
    keep = HairCurves(
        keep.points, keep.offsets, {k: keep.point_data[k] for k in floats}, dict(keep.curve_data)
    )
    order = np.argsort(np.concatenate([np.flatnonzero(~long), np.flatnonzero(long)]), kind="stable")
    return HairCurves.concatenate([keep, resampled])[order]


def _houdini_skin(curve_data: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """root_triangle / root_bary as Houdini's skinprim / skinprimuv: our root is
    u·v0 + v·v1 + (1 − u − v)·v2, Houdini's primuv (s, t) is (1 − s − t)·v0 + s·v1 + t·v2,
    so s = v and t = 1 − u − v."""
    out = dict(curve_data)
    if "root_triangle" in out and "root_bary" in out:
        bary = np.asarray(out.pop("root_bary"), dtype=np.float32)
        out["skinprim"] = out.pop("root_triangle")
        out["skinprimuv"] = np.stack([bary[:, 1], 1.0 - bary[:, 0] - bary[:, 1]], axis=1)
    return out


def _vertex_uv(curves: HairCurves) -> HairCurves:
    """``root_uv`` (per curve) as ``point_data['uv']``: the root's UV on each of its
    vertices, so that whichever vertex an importer takes for the root (Unity's hair
    package: the first of each resampled strand, ``UVs[i * vertexCount]``) has it."""
    curve_data = dict(curves.curve_data)
    uv = curve_data.pop("root_uv", None)
    if uv is None:
        return curves
    per_vertex = np.repeat(np.asarray(uv, np.float32), curves.counts, axis=0)
    return HairCurves(
        curves.points, curves.offsets, {**curves.point_data, "uv": per_vertex}, curve_data
    )


def for_target(
    curves: HairCurves, target: Target | str, role: str = "hair", in_units: bool = True
) -> HairCurves:
    """``curves`` (one chunk) as ``target`` reads them: sized, renamed, ids as int32,
    in its units (``in_units=False`` keeps metres, for a format that declares its unit,
    like USD's ``metersPerUnit``, which the tool converts from). ``role`` is "hair" or
    "guides": guides get widths (DEFAULT_WIDTH when they have none) and the target's
    guide flag (1; hair gets 0) with ``GUIDE_ID_BASE`` + their index as their id, apart
    from every hair's (Unreal binds each hair to the ids its ``groom_closest_guides``
    name, which :meth:`Groom.guide_binding` gives as guide indices: they are moved by the
    same base)."""
    t = get_target(target)
    if role not in ("hair", "guides"):
        raise InputError(f"role: expected 'hair' or 'guides', got {role!r}")
    curves = _sized(curves, t, role)
    if t.vertex_uv:
        curves = _vertex_uv(curves)
    point_data = {k: v for k, v in curves.point_data.items() if k not in t.unused}
    curve_data = {k: v for k, v in curves.curve_data.items() if k not in t.unused}
    if role == "guides" and "width" not in point_data:
        point_data["width"] = np.full(curves.point_count, DEFAULT_WIDTH, np.float32)
    points = curves.points
    if in_units and t.width_scale != 1.0 and "width" in point_data:
        point_data["width"] = np.asarray(point_data["width"], np.float32) * np.float32(
            t.width_scale
        )
    if in_units and t.scale != 1.0:
        points = np.asarray(curves.points, np.float64) * t.scale
    if t.houdini_skin:
        curve_data = _houdini_skin(curve_data)
    if t.guide_flag is not None:
        curve_data[t.guide_flag] = np.full(curves.curve_count, role == "guides", np.int32)
        if role == "guides":  # its id is what the hair's closest guides name
            curve_data["guide_id"] = GUIDE_ID_BASE + np.arange(curves.curve_count, dtype=np.int32)
        else:
            _apart_from_guides(curve_data)
    point_data = {t.point_names.get(k, k): v for k, v in point_data.items()}
    curve_data = {t.curve_names.get(k, k): v for k, v in curve_data.items()}
    if t.prefix is not None:  # what the tool would drop anyway is not written
        point_data = {k: v for k, v in point_data.items() if k.startswith(t.prefix) or k == "width"}
        curve_data = {k: v for k, v in curve_data.items() if k.startswith(t.prefix)}
    if t.only is not None:
        point_data = {k: v for k, v in point_data.items() if k in t.only}
        curve_data = {k: v for k, v in curve_data.items() if k in t.only}
    if t.int32:
        point_data = _narrow_ints(point_data, "point attribute")
        curve_data = _narrow_ints(curve_data, "curve attribute")
    return HairCurves(points.astype(np.float32, copy=False), curves.offsets, point_data, curve_data)


def _apart_from_guides(curve_data: dict[str, np.ndarray]) -> None:
    """A hair chunk's ``closest_guides`` (guide indices) as the guides' ids
    (``GUIDE_ID_BASE`` + index), in place; InputError when a ``hair_id`` reaches the
    guides' ids (more than 2**30 hairs), which would make them ambiguous."""
    ids = curve_data.get("hair_id")
    if ids is not None and len(ids) and int(np.max(ids)) >= GUIDE_ID_BASE:
        raise InputError(
            f"curve_data['hair_id']: ids up to {int(np.max(ids)):,} reach the guides' ids"
            f" ({GUIDE_ID_BASE:,} and up) in Unreal's groom_id; number the hairs below"
            f" {GUIDE_ID_BASE:,}"
        )
    closest = curve_data.get("closest_guides")
    if closest is not None:
        curve_data["closest_guides"] = GUIDE_ID_BASE + np.asarray(closest, np.int32)


def export_fix(target: Target | str, suffix: str = "") -> str:
    """The fix that ends a `follicle check` line: the export that writes a file
    ``target``'s tool reads as it is (``suffix``: the output's, where it matters; a tool
    whose importer reads one format only gets that one)."""
    t = get_target(target)
    if not suffix and t.formats is not None:
        suffix = t.formats[0]
    return f"fix: `follicle export FILE -o OUT{suffix} --target {t.name}`"


def problems(curves: HairCurves, target: Target | str, alembic: bool = False) -> list[str]:
    """What ``target``'s tool would drop or reject in ``curves`` as a reader returned
    them (``alembic``: from an Alembic file), one line each, each ending with its fix
    (empty: it opens them as they are). Widths that are not hair are the reader's
    warning (:func:`follicle.io.attributes.plausible_widths`)."""
    t = get_target(target)
    fix = export_fix(t)
    out = []
    if alembic and t.vertex_uv and "root_uv" in curves.curve_data:
        out.append(
            f"root UVs one per curve ('root_uv'): {t.alembic_importer} sizes UVs per vertex"
            f" and {t.tool}'s hair package takes vertex i·n's as hair i's root UV, so every"
            f" hair but the first gets another's; {fix} writes them per vertex"
        )
    if alembic and t.alembic_reads is not None:
        keep = t.alembic_reads | ({"root_uv"} if t.vertex_uv else set())
        lost = sorted((set(curves.point_data) | set(curves.curve_data)) - keep)
        if lost:
            how = (
                f"{export_fix(t, '.usdc')}: write USD for it"
                if t.formats is None
                else f"{fix} writes what it reads, under its names"
            )
            out.append(
                f"{t.alembic_importer} keeps only points and"
                f" {', '.join(sorted(t.alembic_reads))}: {', '.join(lost)} would be"
                f" dropped; {how}"
            )
    counts = curves.counts
    if t.max_points is not None and (counts > t.max_points).any():
        out.append(
            f"{int((counts > t.max_points).sum()):,} curve(s) have more than"
            f" {t.max_points} points (up to {int(counts.max()):,}): {t.tool} refuses"
            f" them; {fix} resamples them"
        )
    data = {**curves.point_data, **curves.curve_data}
    if t.int32:
        for k, v in data.items():
            read = t.prefix is None or k.startswith(t.prefix)
            if read and v.dtype.kind in "iu" and v.dtype.itemsize > 4:
                out.append(
                    f"'{k}' is {v.dtype}: {t.tool} drops 64-bit integer attributes;"
                    f" {fix} writes int32"
                )
    for ours, theirs in {**t.point_names, **t.curve_names}.items():
        if theirs not in data and ours in data and ours != "guide_id":
            out.append(f"'{ours}' is there but {t.tool} reads '{theirs}'; {fix} renames it")
    if t.prefix is not None:
        ignored = sorted(k for k in data if not k.startswith(t.prefix) and k != "width")
        if ignored:
            out.append(
                f"{t.tool} reads only {t.prefix}* attributes: {', '.join(ignored)} would be"
                f" dropped; {fix} writes what it reads, under its names"
            )
    if "width" not in curves.point_data:
        out.append(
            f"no widths: {t.tool} draws every hair at its default width; fix: give the"
            f" curves widths where they were made, or regrow them with widths"
            f" (`follicle grow SCENE -o OUT --target {t.name}`)"
        )
    return out
