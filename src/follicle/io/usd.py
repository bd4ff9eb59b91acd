"""USD hair: ``UsdGeomBasisCurves`` written and read with Pixar's ``pxr`` (usd-core).

Writing (``.usda``, ``.usdc``, ``.usdz``; ``.usd`` is crate, like ``.usdc``): the stage has
``upAxis = "Y"``, ``metersPerUnit = 1`` and ``defaultPrim = "Groom"``. ``/Groom`` is an Xform,
``/Groom/Hair`` a Scope holding one BasisCurves prim per chunk of the stream,
``/Groom/Hair/chunk_0000``, ``chunk_0001``, … (always, even for a single chunk), the
optional guides are the BasisCurves ``/Groom/Guides`` and the optional skin mesh the
UsdGeomMesh ``/Groom/Skin`` (in an animation with head motion ``/Groom/Head/Skin``, under
the sampled Xform ``/Groom/Head``; see :mod:`follicle.io.usd_skin`).

Every prim is ``type = "cubic"``, ``basis = "catmullRom"``, ``wrap = "pinned"``: the curve
passes through every stored vertex, root to tip, with no phantom points in the file (USD
adds P[-1] = 2·P[0] − P[1] and P[n] = 2·P[n−1] − P[n−2] when it evaluates; follicle's own
spline repeats the end vertex instead, so the first and last segments differ slightly in
parametrisation, never in the vertices they pass through). Attributes:

- ``points``, ``curveVertexCounts``, ``extent`` (the curves' Bézier hulls padded by half
  the widest width, so it bounds the smooth curves, not only their vertices);
- ``widths`` (diameters, metres) and ``normals``, vertex interpolation (normals make
  renderers draw flat ribbons facing them: pass ``normals=False`` for round tubes);
- ``primvars:displayColor`` (``color``) and ``primvars:displayOpacity`` (``opacity``), vertex;
- every other ``point_data`` array as a vertex primvar and every ``curve_data`` array as a
  uniform one under its own name (``root_uv`` float2, ``hair_id`` int64, ``strand_id``,
  ``strand_uv``, ``root_triangle``, ``root_bary``, ``group``, …) when its dtype and shape
  map to a USD type (float/double/half with 1–4 components, int with 1–4, int64, uint,
  uint64, uchar, bool); others are skipped with a warning.

The stream is written with bounded memory: each chunk goes to a crate layer that is saved
after it, and crate saves append, releasing the chunk's arrays (a text layer would hold
everything until its one save). ``.usda`` is exported from that temporary crate (USD
maps the crate while it writes, so file-backed memory grows to about its size) and
``.usdz`` copies it block by block into a Zip32 package. The same curves give the same
bytes.

Reading takes every BasisCurves and NurbsCurves prim of the stage, any type, basis and
wrap, and keeps the points each curve passes through; see :func:`load_usd`. usd-core
reads in a child process under memory and time limits after cheap checks of the file's container
(:mod:`follicle.io.usd_guard`, :mod:`follicle.io.usd_stage`), so a hostile file is one
FormatError, never a crash. A failed write (a full disk, a file-size limit) is one
FormatError naming the output, with no temporary file left.
"""

from __future__ import annotations

import contextlib
import logging
import os
import struct
import tempfile
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, Vt

from ..atomic import atomic_path
from ..curves import HairCurves
from ..errors import FileAccessError, FormatError
from ..inputs import input_file
from .animation import Animation, target_guides, with_groups
from .attributes import column
from .cache_writer import cache_writer
from .curve_bounds import catmull_rom_bounds
from .guard import curves_from_parts
from .stream import Curves, as_chunks
from .suffixes import USD_SUFFIXES as SUFFIXES
from .targets import Target, for_target, get_target
from .usd_guard import check_container, read_stage
from .usd_skin import define_head, define_skin, set_head, set_points
from .usd_stage import usd_error

if TYPE_CHECKING:
    from ..mesh.skin import SkinMesh

__all__ = [
    "save_usd",
    "save_usd_cache",
    "load_usd",
    "usd_parts",
    "HAIR_PATH",
    "GUIDES_PATH",
    "SKIN_PATH",
    "HEAD_PATH",
    "SUFFIXES",
]

log = logging.getLogger("follicle")

GROOM_PATH = "/Groom"
HAIR_PATH = "/Groom/Hair"
GUIDES_PATH = "/Groom/Guides"
GROOM_GUIDES_PATH = "/Groom/Hair/Guides"  # Unreal's groom schema: the guides in the groom
SKIN_PATH = "/Groom/Skin"  # the skin mesh, at rest
HEAD_PATH = "/Groom/Head"  # an animation's head motion, the skin under it (Head/Skin)

# point_data / curve_data name -> USD attribute written by the schema, not as a primvar
_SPECIAL = {
    "width": "widths",
    "normal": "normals",
    "color": "displayColor",
    "opacity": "displayOpacity",
}
_RESERVED = set(_SPECIAL.values())


def _type_table() -> dict[tuple[str, int], Sdf.ValueTypeName]:
    """(numpy dtype str, components) -> USD array value type."""
    names = Sdf.ValueTypeNames
    table = {}
    for code, base in (("<f4", "Float"), ("<f8", "Double"), ("<f2", "Half"), ("<i4", "Int")):
        for k in (1, 2, 3, 4):
            table[(code, k)] = getattr(names, f"{base}{k if k > 1 else ''}Array")
    table.update(
        {
            ("<i8", 1): names.Int64Array,
            ("<u4", 1): names.UIntArray,
            ("<u8", 1): names.UInt64Array,
            ("|u1", 1): names.UCharArray,
            ("|b1", 1): names.BoolArray,
        }
    )
    return table


_TYPES = _type_table()


def _primvar_value(arr: np.ndarray) -> tuple[Sdf.ValueTypeName, object] | None:
    """(USD type, Vt array) of ``arr`` (P or C rows of 1-4 components), or None when USD
    has no such type. Small integers widen to int32 / uint32."""
    if arr.ndim not in (1, 2):
        return None
    if arr.dtype.kind in "iu" and arr.dtype.itemsize < 4 and arr.dtype != np.uint8:
        arr = arr.astype(np.int32 if arr.dtype.kind == "i" else np.uint32)
    arr = np.ascontiguousarray(arr, dtype=arr.dtype.newbyteorder("<"))
    type_name = _TYPES.get((arr.dtype.str, 1 if arr.ndim == 1 else arr.shape[1]))
    if type_name is None:
        return None
    return type_name, type_name.type.pythonClass.FromNumpy(arr)


# ------------------------------------------------------------------ writing
def _extent(points: np.ndarray, offsets: np.ndarray, widths: np.ndarray | None) -> Vt.Vec3fArray:
    """Bounds of pinned Catmull-Rom curves (:func:`catmull_rom_bounds`) padded by half
    the widest width."""
    pad = 0.5 * float(widths.max()) if widths is not None and widths.size else 0.0
    lo, hi = catmull_rom_bounds(points, offsets)
    return Vt.Vec3fArray([Gf.Vec3f(*(lo - pad).tolist()), Gf.Vec3f(*(hi + pad).tolist())])


def _define_curves(stage: Usd.Stage, path: str, curves: HairCurves, normals: bool) -> None:
    """One pinned Catmull-Rom BasisCurves prim at ``path`` holding ``curves``."""
    prim = UsdGeom.BasisCurves.Define(stage, path)
    prim.CreateTypeAttr(UsdGeom.Tokens.cubic)
    prim.CreateBasisAttr(UsdGeom.Tokens.catmullRom)
    prim.CreateWrapAttr(UsdGeom.Tokens.pinned)
    prim.CreateCurveVertexCountsAttr(Vt.IntArray.FromNumpy(curves.counts.astype(np.int32)))
    prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(curves.points))
    vertex, uniform = UsdGeom.Tokens.vertex, UsdGeom.Tokens.uniform
    width = column(curves, "width", 1)
    if width is not None:
        prim.CreateWidthsAttr(Vt.FloatArray.FromNumpy(width))
        prim.SetWidthsInterpolation(vertex)
    normal = column(curves, "normal", 3) if normals else None
    if normal is not None:
        prim.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(normal))
        prim.SetNormalsInterpolation(vertex)
    color, opacity = column(curves, "color", 3), column(curves, "opacity", 1)
    if color is not None:
        prim.CreateDisplayColorPrimvar(vertex).Set(Vt.Vec3fArray.FromNumpy(color))
    if opacity is not None:
        prim.CreateDisplayOpacityPrimvar(vertex).Set(Vt.FloatArray.FromNumpy(opacity))
    if curves.point_count:
        prim.CreateExtentAttr(_extent(curves.points, curves.offsets, width))
    api = UsdGeom.PrimvarsAPI(prim)
    written: set[str] = set()
    pd = curves.point_data
    for data, interpolation in ((pd, vertex), (curves.curve_data, uniform)):
        for name, arr in sorted(data.items()):
            if data is pd and name in _SPECIAL:
                continue
            value = _primvar_value(arr)
            if (
                name in _RESERVED
                or name in written
                or value is None
                or not Sdf.Path.IsValidNamespacedIdentifier(name)
            ):
                log.warning(
                    "USD: %s '%s' (%s %s) not written: reserved or repeated name,"
                    " or no USD type for it",
                    "point_data" if data is pd else "curve_data",
                    name,
                    arr.dtype,
                    arr.shape,
                )
                continue
            api.CreatePrimvar(name, value[0], interpolation).Set(value[1])
            written.add(name)


def _new_stage(path: Path, groom_schema: bool = False) -> Usd.Stage:
    """A crate stage at ``path`` with follicle's metadata and /Groom, /Groom/Hair (a
    Scope; for Unreal's groom schema an Xform with GroomAPI: its importer builds one
    groom from that prim and the curves below it, through Xforms only)."""
    args = {"format": "usdc"} if path.suffix.lower() == ".usd" else {}
    stage = Usd.Stage.Open(Sdf.Layer.CreateNew(str(path), args))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, GROOM_PATH).GetPrim())
    if groom_schema:
        UsdGeom.Xform.Define(stage, HAIR_PATH).GetPrim().AddAppliedSchema("GroomAPI")
    else:
        UsdGeom.Scope.Define(stage, HAIR_PATH)
    return stage


def _groom_stage(
    crate: Path,
    guides: HairCurves | None,
    normals: bool,
    mesh: SkinMesh | None,
    groom_schema: bool,
) -> Usd.Stage:
    """A new crate stage at ``crate`` (:func:`_new_stage`) with the skin ``mesh`` and the
    ``guides`` defined, ready for the hair under /Groom/Hair."""
    stage = _new_stage(crate, groom_schema)
    if mesh is not None:
        define_skin(stage, SKIN_PATH, mesh)
    if guides is not None:
        _define_curves(stage, GROOM_GUIDES_PATH if groom_schema else GUIDES_PATH, guides, normals)
    return stage


def _write_crate(
    chunks: Iterator[HairCurves],
    crate: Path,
    guides: HairCurves | None,
    normals: bool,
    mesh: SkinMesh | None,
    groom_schema: bool,
) -> None:
    stage = _groom_stage(crate, guides, normals, mesh, groom_schema)
    layer = stage.GetRootLayer()
    for i, chunk in enumerate(chunks):
        _define_curves(stage, f"{HAIR_PATH}/chunk_{i:04d}", chunk, normals)
        layer.Save()  # crate appends the chunk and lets go of its arrays
    layer.Save()


def _finish(target: Path, tmp: Path, write_crate: Callable[[Path], None]) -> None:
    """Write through ``write_crate(crate_path)`` into ``tmp`` in ``target``'s format."""
    suffix = target.suffix.lower()
    if suffix in (".usdc", ".usd"):
        write_crate(tmp)
        return
    with tempfile.TemporaryDirectory(prefix="follicle-usd-") as folder:
        crate = Path(folder) / f"{target.stem}.usdc"
        write_crate(crate)
        if suffix == ".usda":
            if not Sdf.Layer.FindOrOpen(str(crate)).Export(str(tmp)):
                raise FormatError(f"{target}: USD could not write the .usda text")
            return
        _package(crate, tmp, target)


def _package(crate: Path, usdz: Path, target: Path) -> None:
    """Write ``usdz`` holding ``crate`` as USDZ asks: a Zip32 archive, the member stored
    uncompressed with its data 64-byte aligned. Copied in blocks, with a fixed timestamp
    (USD's own ZipFileWriter stamps the time and maps the whole file into memory)."""
    size = crate.stat().st_size
    if size >= 2**32 - 2**16:
        raise FormatError(
            f"{target}: {size / 2**30:.1f} GiB of curves is over the 4 GiB a .usdz can hold"
            " (USDZ is Zip32); write .usdc instead"
        )
    name = crate.name.encode()
    pad = -(30 + len(name) + 4) % 64
    extra = struct.pack("<HH", 0x1986, pad) + bytes(pad)  # USD's alignment padding field
    crc = 0
    with open(usdz, "wb") as out:
        out.write(bytes(30 + len(name) + len(extra)))  # local header, written last
        with open(crate, "rb") as src:
            while block := src.read(1 << 20):
                crc = zlib.crc32(block, crc)
                out.write(block)
        # version 2.0, no flags, stored, 1980-01-01 00:00 (DOS date 0x21), crc, sizes
        common = struct.pack(
            "<HHHHHIIIHH", 20, 0, 0, 0, 0x21, crc, size, size, len(name), len(extra)
        )
        central = out.tell()
        out.write(
            b"PK\x01\x02"
            + struct.pack("<H", 20)
            + common
            + struct.pack("<HHHII", 0, 0, 0, 0, 0)
            + name
            + extra
        )
        directory = out.tell() - central
        out.write(b"PK\x05\x06" + struct.pack("<HHHHIIH", 0, 0, 1, 1, directory, central, 0))
        out.seek(0)
        out.write(b"PK\x03\x04" + common + name + extra)


@contextlib.contextmanager
def _writing(target: Path) -> Iterator[None]:
    """Turn usd-core's and the system's write failures (a full disk, a file-size limit,
    no permission) into one FormatError naming ``target``."""
    try:
        yield
    except Tf.ErrorException as exc:
        why = usd_error(exc, first=True)  # the first error is the cause, the rest follow it
        raise FileAccessError(
            f"{target}: usd-core could not write it ({why}); free disk space or write elsewhere"
        ) from None
    except OSError as exc:
        raise FileAccessError(
            f"{target}: could not write it ({exc.strerror or exc}); free disk"
            " space or write elsewhere"
        ) from None


def _check_suffix(path: str | os.PathLike[str]) -> Path:
    target = Path(path)
    if target.suffix.lower() not in SUFFIXES:
        raise FormatError(f"{target}: a USD file must end in .usd, .usda, .usdc or .usdz")
    return target


def save_usd(
    curves: Curves,
    path: str | os.PathLike[str],
    guides: HairCurves | None = None,
    normals: bool = True,
    mesh: SkinMesh | None = None,
    target: Target | str = "generic",
) -> Path:
    """Write ``curves`` (HairCurves or a stream of chunks) as pinned Catmull-Rom
    BasisCurves, one prim per chunk under ``/Groom/Hair``, ``guides`` (HairCurves or
    Guides) as ``/Groom/Guides`` and the skin ``mesh`` (a SkinMesh, at rest) as the
    UsdGeomMesh ``/Groom/Skin`` (see :mod:`follicle.io.usd_skin`); atomically, in the
    format the extension names. ``target`` (see :mod:`follicle.io.targets`) names and
    types the attributes for the tool that opens the file; for Unreal's groom import
    ``/Groom/Hair`` is an Xform with ``GroomAPI`` applied and the guides, flagged
    ``groom_guide = 1``, are ``/Groom/Hair/Guides``, inside the groom. Points stay in
    metres (``metersPerUnit = 1``), which every target converts from."""
    out = _check_suffix(path)
    tool = get_target(target)
    guide_curves = target_guides(guides, tool, in_units=False)
    chunks = (
        for_target(with_groups(chunk, guides, tool), tool, in_units=False)
        for chunk in as_chunks(curves)
    )
    with _writing(out), atomic_path(out) as tmp:
        _finish(
            out,
            tmp,
            lambda crate: _write_crate(
                chunks, crate, guide_curves, normals, mesh, tool.groom_schema
            ),
        )
    return out


# ------------------------------------------------------------------ animation cache


def _write_cache(anim: Animation, crate: Path, mesh: SkinMesh | None, groom_schema: bool) -> None:
    stage = _new_stage(crate, groom_schema)
    stage.SetTimeCodesPerSecond(anim.fps)
    stage.SetFramesPerSecond(anim.fps)
    layer = stage.GetRootLayer()
    head = None if anim.head is None else define_head(stage, HEAD_PATH)
    if mesh is not None:
        define_skin(stage, SKIN_PATH if head is None else f"{HEAD_PATH}/Skin", mesh)
    skin = None if anim.skin is None else UsdGeom.Mesh.Get(stage, SKIN_PATH)
    path = f"{HAIR_PATH}/chunk_0000"
    first = None
    for f, frame in enumerate(anim.frames):
        if first is None:
            first = frame
            _define_curves(stage, path, frame, True)
            prim = UsdGeom.BasisCurves.Get(stage, path)
            # topology and primvars stay as frame 0 has them; these are sampled per frame
            sampled = [prim.GetPointsAttr(), prim.GetExtentAttr(), prim.GetNormalsAttr()]
            for attr in sampled:
                attr.Clear()
        time = Usd.TimeCode(anim.start + f)
        if head is not None and anim.head is not None:
            set_head(head, anim.head[f], time)
        if skin is not None and anim.skin is not None:
            set_points(skin, anim.skin[f], time)
        sampled[0].Set(Vt.Vec3fArray.FromNumpy(frame.points), time)
        if frame.point_count:
            width = first.point_data.get("width")
            sampled[1].Set(_extent(frame.points, frame.offsets, width), time)
        if "normal" in first.point_data and "normal" in frame.point_data:
            normal = np.asarray(frame.point_data["normal"], dtype=np.float32)
            sampled[2].Set(Vt.Vec3fArray.FromNumpy(normal), time)
        layer.Save()  # crate appends this frame's samples
    stage.SetStartTimeCode(anim.start)
    stage.SetEndTimeCode(anim.start + f)
    layer.Save()


def _save_cache(out: Path, anim: Animation, mesh: SkinMesh | None, tool: Target) -> None:
    """The animation as one stage in ``out``'s format (see :func:`save_usd_cache`)."""
    with _writing(out), atomic_path(out) as tmp:
        _finish(out, tmp, lambda crate: _write_cache(anim, crate, mesh, tool.groom_schema))


save_usd_cache = cache_writer(
    "save_usd_cache",
    _check_suffix,
    _save_cache,
    in_units=False,
    doc="""Write an animation: frame ``f`` of ``frames`` is time code ``start + f`` of one
    BasisCurves prim ``/Groom/Hair/chunk_0000``, whose topology and primvars come from
    frame 0 and whose ``points`` and ``extent`` are sampled per frame; named and typed
    as ``target`` reads them (see :func:`save_usd`). ``fps`` sets
    ``timeCodesPerSecond``; the head's ``xformOp:transform`` is sampled per frame, and
    so are an animated skin's ``points`` and ``extent``.
    """,
)


# ------------------------------------------------------------------ reading
def load_usd(
    path: str | os.PathLike[str],
    time: float | None = None,
    guides: bool = False,
    stored: bool = False,
) -> HairCurves:
    """Hair curves from every BasisCurves and NurbsCurves prim of a USD stage, joined in
    stage order.

    Any type, basis and wrap: each curve becomes the points it passes through (linear
    and pinned Catmull-Rom: every vertex; nonperiodic Catmull-Rom: all but the two end
    vertices; Bézier: every third; B-spline: the curve at its knots; NURBS, rational
    or not: the curve at its knots and evenly between them, at least as many points as
    it has control vertices, see :func:`follicle.io.curve_basis.nurbs_stencil`).
    Widths, normals and other numeric primvars of any interpolation (constant, uniform,
    vertex, varying) come back per point (``width``, ``normal``) or, uniform ones, per
    curve. ``color`` (RGB) is the first of displayColor, then a primvar named color,
    Cd or col (any case; Blender writes its colour attributes as 4-channel color4f),
    ``opacity`` the first of displayOpacity, opacity or alpha, else a 4-channel colour's
    4th channel; other primvars with these names come back as ``<name>_primvar``, and
    Blender's ``surface_uv_coordinate`` as ``root_uv``. Transforms, metersPerUnit and a
    Z up axis are applied. Widths whose median is over 5 mm (a tool's default radius,
    not hair) are kept but logged as a warning. ``/Groom/Guides`` is skipped unless it
    is the only curves prim, or ``guides=True`` reads only it; ``/Groom/Skin`` is never
    read as hair. ``time`` picks a time code (default: the default values, or else the
    first sample).

    usd-core reads the file in a child process under memory and time limits, after
    cheap checks of its container (see :mod:`follicle.io.usd_guard`): anything wrong
    with the file, or usd-core crashing on it, is a FormatError naming it. Half-float
    primvars come back as float32; int32 ones as int64, follicle's integers. ``stored``
    keeps primvars as the file names and types them (only ``displayColor`` /
    ``displayOpacity`` taken as ``color`` / ``opacity``): what `follicle check` reads.
    """
    source, parts = usd_parts(path, time, guides, stored)
    return curves_from_parts(parts, source, bool(stored))


def usd_parts(
    path: str | os.PathLike[str],
    time: float | None = None,
    guides: bool = False,
    stored: bool = False,
) -> tuple[Path, list[dict]]:
    """(the file, its chosen curves prims as dicts of arrays) as :func:`load_usd` reads
    and then joins them; ``stored`` parts also say whether Unreal's ``GroomAPI`` is on
    the prim or one above it (``groom_schema``), for `follicle check`."""
    source = input_file(path, "USD file (.usd, .usda, .usdc or .usdz)")
    check_container(source)
    return source, read_stage(source, time, guides, bool(stored))
