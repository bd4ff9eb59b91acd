"""Reading a USD stage's BasisCurves and NurbsCurves as plain arrays, in a guarded child
process.

usd-core is C++: a hostile file can make it crash, allocate without end or compose for
ever, so :mod:`follicle.io.usd_guard` has this module run in the guarded reading server
(:mod:`follicle.io.guard_server`, entry :func:`read_request`): it imports only numpy,
pxr and follicle's numpy-only modules, and reads each file in a forked child under
memory and time limits. Each prim becomes ``{"where", "points", "offsets",
"point_data", "curve_data"}``, its curves already the points they pass through, in
follicle's space (metres, +Y up).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator

import numpy as np
from pxr import Sdf, Tf, Usd, UsdGeom

from . import curve_basis
from .curve_space import SpaceError, to_world
from .guard_rules import Refused

GUIDES_PATH = "/Groom/Guides"  # as follicle.io.usd has it (the reading child skips the writer)
GROOM_GUIDES_PATH = "/Groom/Hair/Guides"  # … and where it puts them for Unreal
# what usd-core raises on a file it cannot make sense of (Tf errors, bad values, bad types)
USD_ERRORS = (
    Tf.ErrorException,
    RuntimeError,
    ValueError,
    TypeError,
    IndexError,
    OverflowError,
    np.linalg.LinAlgError,
)
MAX_PRIMS = 100_000  # prims a stage may compose, by _Composition's count


# ------------------------------------------------------------------ composition
class _Composition:
    """Counts the prims composing a layer would make, before USD composes it: each prim
    spec once, plus, for every reference or payload, the prims of its target as often
    as it is reached (A references B twice, B references C twice, … is 2^depth), through
    sublayers and variants too. An upper bound (opinions that merge are counted apart), cheap (each
    spec is visited once), and it refuses cycles."""

    def __init__(self, where: str) -> None:
        self.where = where
        self.memo: dict[tuple[str, str], int] = {}
        self.active: set[tuple[str, str]] = set()
        self.missing: list[str] = []  # layers an arc names that cannot be opened

    def _enter(self, key: tuple[str, str]) -> None:
        if key in self.active:
            raise Refused(
                f"{self.where}: {key[0]} composes itself (a reference, payload or"
                " sublayer cycle); fix the file's composition arcs"
            )
        self.active.add(key)

    def _done(self, key: tuple[str, str], n: int) -> int:
        if n > MAX_PRIMS:
            raise Refused(
                f"{self.where}: composes more than {MAX_PRIMS} prims (references"
                " or payloads nested many times over); not read"
            )
        self.active.discard(key)
        self.memo[key] = n
        return n

    def layer(self, layer: Sdf.Layer) -> int:
        """Prims of ``layer``'s root prims and sublayers."""
        key = (layer.identifier, "")
        if key in self.memo:
            return self.memo[key]
        self._enter(key)
        n = sum(self.prim(layer, spec.path) for spec in layer.rootPrims if spec)
        for asset in layer.subLayerPaths:
            sub = self._open(layer, asset)
            if sub is None:
                self.missing.append(asset)
            n += self.layer(sub) if sub is not None else 0
        return self._done(key, n)

    def prim(self, layer: Sdf.Layer, path: Sdf.Path) -> int:
        """Prims under ``path`` in ``layer``: its spec, its children and what it references."""
        key = (layer.identifier, str(path))
        if key in self.memo:
            return self.memo[key]
        self._enter(key)
        spec = layer.GetPrimAtPath(path)
        n = 1
        if spec is not None:
            n += sum(self.prim(layer, child.path) for child in spec.nameChildren if child)
            arcs = [
                *spec.referenceList.GetAddedOrExplicitItems(),
                *spec.payloadList.GetAddedOrExplicitItems(),
            ]
            for arc in arcs:
                n += self._arc(layer, arc.assetPath, arc.primPath)
            for variant_set in spec.variantSets.values():  # every variant, chosen or not
                n += sum(
                    self.prim(layer, variant.primSpec.path)
                    for variant in variant_set.variants.values()
                )
        return self._done(key, n)

    def _open(self, layer: Sdf.Layer, asset: str) -> Sdf.Layer | None:
        """The layer ``asset`` names, relative to ``layer``; None when no file is there
        (the caller adds it to :attr:`missing`); Refused naming it when it cannot be
        read (a cut or corrupt piece of the stage)."""
        try:
            return Sdf.Layer.FindOrOpenRelativeToLayer(layer, asset)
        except USD_ERRORS as exc:
            raise Refused(
                f"{self.where}: @{asset}@, a sublayer, reference or payload of it, cannot"
                f" be read ({usd_error(exc)}); write it again"
            ) from None

    def _arc(self, layer: Sdf.Layer, asset: str, target: Sdf.Path) -> int:
        other = self._open(layer, asset) if asset else layer
        if other is None:
            self.missing.append(asset)
            return 0
        if target.isEmpty:
            if not other.defaultPrim:
                return 0
            target = Sdf.Path.absoluteRootPath.AppendChild(other.defaultPrim)
        return self.prim(other, target)


# ------------------------------------------------------------------ curves
def _array(value: object, name: str, where: str) -> np.ndarray | None:
    """``value`` as a numeric array of rows (1-D, or 2-D of 1-4 columns; half widened to
    float32), None for a non-numeric one, Refused for a single value where USD wants
    an array (``float widths = 1``)."""
    if value is None:
        return None
    arr = np.asarray(value)
    if arr.dtype.kind not in "fiub":
        return None
    if arr.ndim not in (1, 2) or arr.ndim == 2 and not 1 <= arr.shape[1] <= 4:
        shape = "a single value" if arr.ndim == 0 else f"of shape {arr.shape}"
        raise Refused(
            f"{where}: {name} is {shape}; it must be an array ({name} = [...]) of"
            " 1-4 components each"
        )
    return arr.astype(np.float32) if arr.dtype == np.float16 else arr


COLOR_NAMES = ("displaycolor", "color", "cd", "col")  # colour primvars, lower case, by priority
OPACITY_NAMES = ("displayopacity", "opacity", "alpha")  # and opacity ones
# names in point_data that only the schema's attributes and the chosen colour fill
CONVENTIONAL = ("width", "normal", "color", "opacity")


class _Prim:
    """A BasisCurves or NurbsCurves prim read as arrays: its topology, then its primvars
    mapped to the points its curves pass through (:mod:`follicle.io.curve_basis`)."""

    def __init__(
        self, prim: Usd.Prim, time: Usd.TimeCode, source: str, stored: bool = False
    ) -> None:
        self.schema = UsdGeom.Curves(prim)
        self.time = time
        self.stored = stored  # names as stored: no colour / uv aliases taken for ours
        self.where = f"{source}: {prim.GetPath()}"
        counts = _array(
            self.schema.GetCurveVertexCountsAttr().Get(time), "curveVertexCounts", self.where
        )
        points = _array(self.schema.GetPointsAttr().Get(time), "points", self.where)
        if counts is None or points is None:
            raise Refused(f"{self.where}: no points or curveVertexCounts")
        self.counts = curve_basis.topology(
            counts, points, self.where, "curveVertexCounts", "points"
        )
        if prim.IsA(UsdGeom.NurbsCurves):
            self.stencil: curve_basis.NurbsStencil | None = self._nurbs(UsdGeom.NurbsCurves(prim))
            self.out, varying = self.stencil.counts, self.stencil.varying_counts
            self.points = self.stencil.vertex(points.astype(np.float32))
        else:
            basis = UsdGeom.BasisCurves(prim)
            self.stencil = None
            self.rule = curve_basis.rule(
                basis.GetTypeAttr().Get(),
                basis.GetBasisAttr().Get(),
                basis.GetWrapAttr().Get(),
                self.counts,
                self.where,
            )
            self.out = varying = curve_basis.out_counts(self.rule, self.counts)
            self.points = curve_basis.through_points(
                points.astype(np.float32), self.counts, self.rule
            )
        self.sizes = curve_basis.scope_sizes(self.counts, len(points), varying)

    def _nurbs(self, schema: UsdGeom.NurbsCurves) -> curve_basis.NurbsStencil:
        """The stencil of a NurbsCurves prim from its order, knots, pointWeights and ranges
        (the last two optional: an empty array counts as unauthored, as Blender writes)."""
        values = {}
        for name, attr in (
            ("order", schema.GetOrderAttr()),
            ("knots", schema.GetKnotsAttr()),
            ("pointWeights", schema.GetPointWeightsAttr()),
            ("ranges", schema.GetRangesAttr()),
        ):
            arr = _array(attr.Get(self.time), name, self.where)
            values[name] = None if arr is None or arr.size == 0 else arr
        if values["order"] is None or values["knots"] is None:
            raise Refused(
                f"{self.where}: a NurbsCurves prim needs order and knots; author"
                " them (one order per curve, vertices + order knots per curve)"
            )
        if values["order"].dtype.kind not in "iu":
            raise Refused(f"{self.where}: order must be int[], got {values['order'].dtype}")
        return curve_basis.nurbs_stencil(
            self.counts,
            values["order"],
            values["knots"],
            values["pointWeights"],
            values["ranges"],
            self.where,
        )

    def _check(self, name: str, values: np.ndarray, interpolation: str) -> None:
        if interpolation not in self.sizes or len(values) != self.sizes[interpolation]:
            raise Refused(
                f"{self.where}: {name} has {len(values)} values; {interpolation} interpolation"
                f" needs {self.sizes.get(interpolation, 'a known interpolation')}"
            )

    def per_point(self, name: str, values: np.ndarray, interpolation: str) -> np.ndarray:
        """``values`` of any interpolation as one row per output point."""
        self._check(name, values, interpolation)
        if interpolation == "vertex":
            if self.stencil is not None:
                return self.stencil.vertex(values)
            return curve_basis.through_points(values, self.counts, self.rule)
        if interpolation in ("constant", "uniform"):
            return np.repeat(
                values, self.out if interpolation == "uniform" else len(self.points), axis=0
            )
        return values if self.stencil is None else self.stencil.varying(values)

    def _widths_normals(self, point_data: dict[str, np.ndarray]) -> None:
        api = UsdGeom.PrimvarsAPI(self.schema)
        for key, name, attr, interpolation in (
            ("width", "widths", self.schema.GetWidthsAttr(), self.schema.GetWidthsInterpolation()),
            (
                "normal",
                "normals",
                self.schema.GetNormalsAttr(),
                self.schema.GetNormalsInterpolation(),
            ),
        ):
            if api.HasPrimvar(name):  # primvars:widths / primvars:normals win over the attribute
                primvar = api.GetPrimvar(name)
                value = primvar.ComputeFlattened(self.time)
                interpolation = primvar.GetInterpolation()
            else:
                value = attr.Get(self.time) if attr.HasAuthoredValue() else None
            arr = _array(value, name, self.where)
            if arr is not None and key == "width":
                if arr.ndim == 2 and arr.shape[1] != 1:
                    raise Refused(
                        f"{self.where}: widths has {arr.shape[1]} values a row; it must"
                        " be float[], one diameter each"
                    )
                arr = arr.reshape(len(arr))
            if arr is not None:
                point_data[key] = self.per_point(name, arr.astype(np.float32), interpolation)

    def _rows(self, primvar: UsdGeom.Primvar, arr: np.ndarray) -> np.ndarray:
        """``arr`` grouped in rows of the primvar's elementSize."""
        size = primvar.GetElementSize()
        if size == 1:
            return arr
        if arr.ndim != 1 or size < 1 or len(arr) % size:
            raise Refused(
                f"{self.where}: primvar {primvar.GetPrimvarName()} has elementSize"
                f" {size} but {arr.size} values of shape {arr.shape}; fix"
                " elementSize"
            )
        return arr.reshape(len(arr) // size, size)

    def _appearance(
        self, found: list[tuple[str, str, np.ndarray]], point_data: dict[str, np.ndarray]
    ) -> set[str]:
        """``color`` (RGB) and ``opacity`` from the first colour primvar by COLOR_NAMES
        (displayColor, color, Cd, col: any case; 3 or 4 floats a row, the 4th its
        opacity) and the first opacity one by OPACITY_NAMES, which wins over a 4th
        channel; the names of the primvars used."""

        def first(names: tuple[str, ...], widths: tuple[int, ...]) -> tuple | None:
            fits = [
                f
                for f in found
                if f[0].lower() in names
                and f[2].dtype.kind == "f"
                and (f[2].shape[1] if f[2].ndim == 2 else 1) in widths
            ]
            return min(fits, key=lambda f: names.index(f[0].lower()), default=None)

        used = set()
        if self.stored:  # only the schema's own colour and opacity are ours
            alpha = first(OPACITY_NAMES[:1], (1,))
        else:
            alpha = first(OPACITY_NAMES, (1,))
        if alpha is not None:
            rows = self.per_point(alpha[0], alpha[2].astype(np.float32), alpha[1])
            point_data["opacity"] = rows.reshape(len(rows))
            used.add(alpha[0])
        color = first(COLOR_NAMES[:1] if self.stored else COLOR_NAMES, (3, 4))
        if color is not None:
            rows = self.per_point(color[0], color[2].astype(np.float32), color[1])
            point_data["color"] = np.ascontiguousarray(rows[:, :3])
            if rows.shape[1] == 4 and alpha is None:
                point_data["opacity"] = np.ascontiguousarray(rows[:, 3])
            used.add(color[0])
        return used

    def read(self) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """(point_data, curve_data) of the prim, per output point and per curve. A primvar
        whose name is one of CONVENTIONAL but that does not fill it comes back as
        ``<name>_primvar``; Blender's ``surface_uv_coordinate`` as ``root_uv``."""
        point_data: dict[str, np.ndarray] = {}
        curve_data: dict[str, np.ndarray] = {}
        self._widths_normals(point_data)
        found = []
        for primvar in UsdGeom.PrimvarsAPI(self.schema).GetPrimvarsWithAuthoredValues():
            name = primvar.GetPrimvarName()
            arr = _array(primvar.ComputeFlattened(self.time), name, self.where)
            if name not in ("widths", "normals") and arr is not None:
                found.append((name, primvar.GetInterpolation(), self._rows(primvar, arr)))
        used = self._appearance(found, point_data)
        for name, interpolation, arr in found:
            if name in used or interpolation == "constant":
                continue
            if interpolation == "uniform":
                self._check(name, arr, interpolation)
                curve_data[name] = arr
            else:
                key = f"{name}_primvar" if name in CONVENTIONAL else name
                point_data[key] = self.per_point(name, arr, interpolation)
        if (
            not self.stored
            and "root_uv" not in curve_data
            and "surface_uv_coordinate" in curve_data
        ):
            curve_data["root_uv"] = curve_data.pop("surface_uv_coordinate")
        return point_data, curve_data


def _check_ops(prim: Usd.Prim, where: str) -> None:
    """Refused when an xformOpOrder of ``prim`` or a prim above names an op the prim
    does not have (or has with a type that is not a transform): usd-core would skip it
    with a warning, and the curves would silently land elsewhere."""
    while prim and not prim.IsPseudoRoot():
        xformable = UsdGeom.Xformable(prim)
        if xformable:
            order = xformable.GetXformOpOrderAttr().Get() or []
            named = [op for op in order if op != "!resetXformStack!"]
            found = {op.GetOpName() for op in xformable.GetOrderedXformOps()}
            missing = [op for op in named if op not in found]
            if missing:
                raise Refused(
                    f"{where}: xformOpOrder of {prim.GetPath()} names {missing[0]},"
                    " which it does not have as a transform attribute; fix the"
                    " xformOps"
                )
        prim = prim.GetParent()


def _world(prim: Usd.Prim, time: Usd.TimeCode, where: str) -> np.ndarray:
    """The prim's local-to-world matrix times the stage's metersPerUnit and a Z-up to Y-up
    turn: row vectors in follicle's metres, +Y up."""
    stage = prim.GetStage()
    _check_ops(prim, where)
    m = np.array(UsdGeom.XformCache(time).GetLocalToWorldTransform(prim), dtype=np.float64)
    mpu = UsdGeom.GetStageMetersPerUnit(stage)
    if not (math.isfinite(mpu) and mpu > 0):
        raise Refused(
            f"{where}: metersPerUnit is {mpu}; it must be a number > 0 (1 for"
            " metres, 0.01 for centimetres)"
        )
    if not np.isfinite(m).all():
        raise Refused(f"{where}: its transform is not finite (NaN or inf); fix its xformOps")
    m[:, :3] *= mpu
    if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z:  # (x, y, z) -> (x, z, -y)
        m = m @ np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], np.float64)
    return m


def _transform(
    points: np.ndarray, pd: dict[str, np.ndarray], m: np.ndarray, where: str
) -> np.ndarray:
    """``points`` (returned) and ``pd``'s width and normal (in place) moved by ``m``
    (:func:`follicle.io.curve_space.to_world`; USD's matrices act on row vectors too)."""
    try:
        return to_world(points, pd, m, where, "fix its xformOps")
    except SpaceError as exc:
        raise Refused(str(exc)) from None


# ------------------------------------------------------------------ stage
def _chosen(stage: Usd.Stage, guides: bool, source: str) -> list[Usd.Prim]:
    prims = [
        p for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves) or p.IsA(UsdGeom.NurbsCurves)
    ]
    guide_prims = [
        p
        for p in prims
        if p.GetPath().HasPrefix(Sdf.Path(GUIDES_PATH))
        or p.GetPath().HasPrefix(Sdf.Path(GROOM_GUIDES_PATH))
    ]
    hair = [p for p in prims if p not in guide_prims]
    chosen = guide_prims if guides else hair or guide_prims
    if not chosen:
        what = f"no {GUIDES_PATH} prim" if guides else "no BasisCurves or NurbsCurves prims"
        raise Refused(f"{source}: {what}; is this a hair file?")
    return chosen


def read(
    path: str, source: str, time: float | None, guides: bool, stored: bool = False
) -> list[dict]:
    """Every chosen BasisCurves or NurbsCurves prim of the file at ``path`` as a dict of
    arrays (see the module); messages name it ``source``. ``stored``: primvars under
    the names the file gives them (for `follicle check`), no aliases taken as ours."""
    root = Sdf.Layer.FindOrOpen(path)
    if root is None:
        raise Refused(f"{source}: usd-core could not open it; is it a valid USD file?")
    composition = _Composition(source)
    composition.layer(root)
    if composition.missing:  # its hair would be read in part, or not at all
        more = len(composition.missing) - 1
        raise Refused(
            f"{source}: @{composition.missing[0]}@, a sublayer, reference or payload of"
            f" it{f' (and {more} more)' if more else ''}, cannot be opened; put the file"
            " back where the path points, or remove the arc"
        )
    stage = Usd.Stage.Open(root, Usd.Stage.LoadAll)
    when = Usd.TimeCode.EarliestTime() if time is None else Usd.TimeCode(time)
    prims = []
    for prim in _chosen(stage, guides, source):
        try:
            part = _Prim(prim, when, source, stored)
            point_data, curve_data = part.read()
        except curve_basis.CurveBasisError as exc:
            raise Refused(str(exc)) from None
        points = _transform(part.points, point_data, _world(prim, when, part.where), part.where)
        offsets = np.concatenate([[0], np.cumsum(part.out)])
        found: dict[str, object] = {
            "where": part.where,
            "points": points,
            "offsets": offsets,
            "point_data": point_data,
            "curve_data": curve_data,
        }
        if stored:  # what `follicle check` also asks: does Unreal see its groom schema?
            found["groom_schema"] = _has_groom_api(prim)
        prims.append(found)
    return prims


def _has_groom_api(prim: Usd.Prim) -> bool:
    """Whether ``GroomAPI`` (Unreal's USD groom schema, which USD does not know, so it
    is read from the prim's list of applied schemas) is on ``prim`` or a prim above."""
    while prim.IsValid() and not prim.IsPseudoRoot():
        if "GroomAPI" in prim.GetPrimTypeInfo().GetAppliedAPISchemas():
            return True
        prim = prim.GetParent()
    return False


def usd_error(exc: BaseException, first: bool = False) -> str:
    """The message of usd-core's last (or ``first``) error in ``exc``, on one line,
    without the C++ function and source file it names."""
    errors = str(exc).strip().split("Error in ")
    message = errors[1 if first and len(errors) > 1 else -1]
    if " : '" in message:  # Error in 'Function' at line N in file F : 'message'
        message = message.split(" : '", 1)[1]
    message = " ".join(message.split()).rstrip("'").strip()
    return message[:300] or type(exc).__name__


HINT = "is it a valid USD file?"


def prepare() -> None:
    """Load usd-core's plugins once in the reading server, before any fork."""
    Usd.SchemaRegistry()


@contextlib.contextmanager
def refusals(source: str) -> Iterator[None]:
    """Turn usd-core's errors into :class:`~follicle.io.guard_rules.Refused`, one line
    naming ``source``."""
    try:
        yield
    except USD_ERRORS as exc:
        raise Refused(f"{source}: usd-core could not read it ({usd_error(exc)}); {HINT}") from None


def read_request(request: dict) -> list[dict]:
    """The reading server's entry (:mod:`follicle.io.guard_server`): :func:`read` of
    ``request["source"]`` with its ``time`` and ``guides``."""
    with refusals(request["shown"]):
        return read(
            request["source"],
            request["shown"],
            request["time"],
            request["guides"],
            request.get("stored", False),
        )
