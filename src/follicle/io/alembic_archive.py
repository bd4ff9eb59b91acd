"""Reading an Alembic archive's curves and meshes as plain arrays, in a guarded child.

alembic3d (PyAlembic's API over the C++ library) trusts its input: a corrupt archive
can make it crash or allocate without end, and some of its objects crash when merely
printed. So :mod:`follicle.io.alembic_guard` has this module run in the guarded reading
server (:mod:`follicle.io.guard_server`, entry :func:`read_request`): it imports only
numpy, alembic3d and follicle's numpy-only modules, and reads each file in a forked
child under memory and time limits.

Objects are visited depth first in archive order, each one's world matrix the product
of the Xforms above it (an Xform that does not inherit starts afresh). A curves object
becomes ``{"where", "points", "offsets", "point_data", "curve_data"}``, its curves
already the points they pass through (:mod:`follicle.io.curve_basis`); a mesh (PolyMesh,
or a SubD's control cage) ``{"where", "name", "points", "face_counts", "face_indices",
"uv", "uv_scope", "flip", "others"}``. Alembic declares no unit and no up axis: values
are taken as they are (Y up, by the convention of every Alembic writer).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import TYPE_CHECKING, Protocol, cast

import numpy as np
from alembic3d import Abc, AbcGeom, Util

from . import curve_basis
from .curve_space import SpaceError, to_world
from .guard_rules import MAX_ANIMATION_POINTS, Refused

if TYPE_CHECKING:
    from typing_extensions import Buffer

GUIDES_PATH = "/Groom/Guides"  # as follicle.io.alembic writes them
GROOM_VERSION_KEYS = ("groom_version_major", "groom_version_minor")  # Unreal's groom schema
HINT = "is it a valid Alembic file?"
# what alembic3d raises on an archive it cannot make sense of (the C++ library's
# exceptions arrive as RuntimeError, a missing child as KeyError, bad values otherwise)
ERRORS = (
    RuntimeError,
    ValueError,
    TypeError,
    IndexError,
    KeyError,
    OverflowError,
    np.linalg.LinAlgError,
)
_EXISTING = Abc.WrapExistingFlag.kWrapExisting
_POD = {
    Util.POD.kBooleanPOD: np.bool_,
    Util.POD.kUint8POD: np.uint8,
    Util.POD.kInt8POD: np.int8,
    Util.POD.kUint16POD: np.uint16,
    Util.POD.kInt16POD: np.int16,
    Util.POD.kUint32POD: np.uint32,
    Util.POD.kInt32POD: np.int32,
    Util.POD.kUint64POD: np.uint64,
    Util.POD.kInt64POD: np.int64,
    Util.POD.kFloat16POD: np.float32,
    Util.POD.kFloat32POD: np.float32,
    Util.POD.kFloat64POD: np.float64,
}
_KIND = {
    AbcGeom.CurveType.kLinear: "linear",
    AbcGeom.CurveType.kCubic: "cubic",
    AbcGeom.CurveType.kVariableOrder: "variable",
}
_BASIS = {
    AbcGeom.BasisType.kNoBasis: "none",
    AbcGeom.BasisType.kBezierBasis: "bezier",
    AbcGeom.BasisType.kBsplineBasis: "bspline",
    AbcGeom.BasisType.kCatmullromBasis: "catmullRom",
    AbcGeom.BasisType.kHermiteBasis: "hermite",
    AbcGeom.BasisType.kPowerBasis: "power",
}
_WRAP = {
    AbcGeom.CurvePeriodicity.kNonPeriodic: "nonperiodic",
    AbcGeom.CurvePeriodicity.kPeriodic: "periodic",
}
# Alembic's geoScope metadata -> follicle's scope names
_SCOPE = {
    "con": "constant",
    "uni": "uniform",
    "var": "varying",
    "vtx": "vertex",
    "fvr": "faceVarying",
}
COLOR_NAMES = ("color", "cd", "displaycolor", "groom_color", "col")  # by priority, lower case


# ------------------------------------------------------------------ alembic3d's handles
class _DataType(Protocol):
    """``AbcCoreAbstract.DataType``: a property's plain old data type and its extent."""

    def getPod(self) -> object: ...
    def getExtent(self) -> int: ...


class _PropertyHeader(Protocol):
    """``AbcCoreAbstract.PropertyHeader`` of an array property: what :func:`_array` reads."""

    def getName(self) -> str: ...
    def getDataType(self) -> _DataType: ...


class _TimeSampling(Protocol):
    """``AbcCoreAbstract.TimeSampling``: the time (s) of each sample index."""

    def getSampleTime(self, index: int, /) -> float: ...


class _Sampled(Protocol):
    """A schema's samples (``IXformSchema``, ``IPolyMeshSchema``, ``ISubDSchema``)."""

    def getTimeSampling(self) -> _TimeSampling: ...
    def getNumSamples(self) -> int: ...


class _MeshSample(Protocol):
    """``IPolyMeshSchema.Sample`` or ``ISubDSchema.Sample``: the positions read here."""

    def getPositions(self) -> object: ...


class _MeshSchema(_Sampled, Protocol):
    """``IPolyMeshSchema`` or ``ISubDSchema``: its samples, one per selector."""

    def getValue(self, sel: Abc.ISampleSelector, /) -> _MeshSample: ...


# ------------------------------------------------------------------ values
def _numpy(values: object) -> np.ndarray:
    """An alembic3d (imath) array as a numpy copy: through its buffer when it has one,
    colours channel by channel (their arrays have none, and element by element they
    take seconds a million), other scalars element by element."""
    with contextlib.suppress(TypeError):  # memoryview checks it is a buffer
        return np.array(memoryview(cast("Buffer", values)))
    channels = [getattr(values, c) for c in "rgba" if hasattr(values, c)]
    if channels:
        return np.stack([np.array(memoryview(c)) for c in channels], axis=1)
    return np.asarray(values)


def _optional(values: object) -> np.ndarray:
    """An optional array of a sample (orders, knots, weights): empty when absent."""
    return np.zeros(0) if values is None else _numpy(values).reshape(-1)


def _array(
    compound: Abc.ICompoundProperty,
    header: _PropertyHeader,
    sel: Abc.ISampleSelector,
    where: str,
) -> np.ndarray | None:
    """The numeric array property ``header`` of ``compound`` as rows of 1-4 components
    (float16 widened to float32), or None when it holds strings or wider rows."""
    kind = header.getDataType()
    dtype, extent = _POD.get(kind.getPod()), kind.getExtent()
    if dtype is None or not 1 <= extent <= 4:
        return None
    arr: np.ndarray = _numpy(compound.getProperty(header.getName()).getValue(sel)).astype(
        dtype, copy=False
    )
    if extent > 1 and arr.ndim == 1 and arr.size % extent == 0:
        arr = arr.reshape(-1, extent)
    if arr.shape[1:] != ((extent,) if extent > 1 else ()):
        raise Refused(
            f"{where}: {header.getName()} has values of shape {arr.shape[1:]};"
            f" its type says {extent} components"
        )
    return arr


def _param(
    compound: Abc.ICompoundProperty, name: str, sel: Abc.ISampleSelector, where: str
) -> tuple[np.ndarray, str, str] | None:
    """Geometry parameter ``name`` of ``compound`` as (values, scope, interpretation),
    indexed ones expanded; None when absent or not numeric."""
    header = compound.getPropertyHeader(name)
    if header is None or header.isScalar():
        return None
    meta = header.getMetaData()
    if header.isArray():
        values = _array(compound, header, sel, where)
    else:  # indexed: a compound of .vals and .indices
        sub = Abc.ICompoundProperty(compound, name)
        vals, indices = sub.getPropertyHeader(".vals"), sub.getPropertyHeader(".indices")
        values = None if vals is None or not vals.isArray() else _array(sub, vals, sel, where)
        if values is not None and indices is not None and indices.isArray():
            values = values[_indices(sub, indices, sel, len(values), f"{where}: {name}")]
    if values is None:
        return None
    return values, _SCOPE.get(meta.get("geoScope"), ""), meta.get("interpretation")


def _indices(
    compound: Abc.ICompoundProperty,
    header: _PropertyHeader,
    sel: Abc.ISampleSelector,
    count: int,
    where: str,
) -> np.ndarray:
    """An indexed parameter's indices, each checked to pick one of its ``count`` values."""
    index = _array(compound, header, sel, where)
    if index is None or index.ndim != 1 or index.dtype.kind not in "iu":
        raise Refused(f"{where}.indices is not an array of whole numbers")
    bad = (index < 0) | (index >= count)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise Refused(f"{where}.indices[{i}] = {int(index[i])} is outside its {count} values")
    return index


# ------------------------------------------------------------------ curves
class _Curves:
    """A curves object's control vertices reduced to the points its curves pass
    through, and any scope of values mapped to those points."""

    def __init__(
        self, sample: AbcGeom.ICurvesSchemaSample, where: str, stored: bool = False
    ) -> None:
        self.where = where
        self.stored = stored  # names as stored: no colour aliases taken for ours
        counts = _numpy(sample.getCurvesNumVertices())
        points = _numpy(sample.getPositions())
        self.counts = curve_basis.topology(counts, points, where, "nVertices", "P")
        self.stencil: curve_basis.NurbsStencil | None = None
        self.mapping = "all"
        self._reduction(sample)
        self.out: np.ndarray  # output points per curve
        self.points: np.ndarray  # the points the curves pass through
        if self.stencil is not None:
            self.out, varying = self.stencil.counts, self.stencil.varying_counts
            self.points = self.stencil.vertex(points.astype(np.float32))
        else:
            self.out = varying = curve_basis.out_counts(self.mapping, self.counts)
            self.points = curve_basis.through_points(
                points.astype(np.float32), self.counts, self.mapping
            )
        self.sizes = curve_basis.scope_sizes(self.counts, len(points), varying)

    def _reduction(self, sample: AbcGeom.ICurvesSchemaSample) -> None:
        """Set the :func:`curve_basis.rule` mapping or the NURBS stencil of the curves.

        Linear curves, and curves of no basis (Blender's poly curves), keep every
        vertex; cubic ones follow their basis as RenderMan (and USD) define it, but
        B-splines with knots are NURBS of order 4 (Maya writes them so). Variable-order
        curves are NURBS, except Blender's Catmull-Rom ones, which pass through every
        vertex (as USD's pinned ones). Periodic curves are refused, as in USD."""
        kind = _KIND.get(sample.getType(), str(sample.getType()))
        basis = _BASIS.get(sample.getBasis(), str(sample.getBasis()))
        wrap = _WRAP.get(sample.getWrap(), str(sample.getWrap()))
        if kind not in _KIND.values():
            raise Refused(
                f"{self.where}: unknown curve type {kind} (linear, cubic or variable order)"
            )
        if wrap != "nonperiodic":  # curve_basis refuses it with the reason
            curve_basis.rule(kind, basis, wrap, self.counts, self.where)
        if kind == "linear" or basis == "none":
            self.mapping = curve_basis.rule("linear", basis, wrap, self.counts, self.where)
        elif kind == "variable" and basis == "catmullRom":
            self.mapping = curve_basis.rule("cubic", basis, "pinned", self.counts, self.where)
        elif kind == "variable" or basis == "bspline" and _optional(sample.getKnots()).size:
            self.stencil = self._nurbs(sample, None if kind == "variable" else 4)
        else:
            self.mapping = curve_basis.rule(kind, basis, wrap, self.counts, self.where)

    def _nurbs(
        self, sample: AbcGeom.ICurvesSchemaSample, order: int | None
    ) -> curve_basis.NurbsStencil:
        """NURBS curves: orders per curve (or ``order``), knots as Alembic batches them
        (vertices + order per curve; Maya's vertices + order − 2, ends repeated; none:
        clamped uniform knots, as Blender makes them), optional position weights."""
        c = len(self.counts)
        orders = np.full(c, order) if order else _optional(sample.getOrders())
        orders = orders.astype(np.int64)
        if orders.shape != (c,):
            raise Refused(
                f"{self.where}: .orders has {orders.size} values; {c} curves need one each"
            )
        knots = _optional(sample.getKnots()).astype(np.float64)
        if knots.size == 0:
            knots = _clamped_knots(self.counts, orders)
        elif knots.size == int((self.counts + orders - 2).sum()):
            knots = _pad_knots(knots, self.counts + orders - 2)
        weights = _optional(sample.getPositionWeights()).astype(np.float64)
        return curve_basis.nurbs_stencil(
            self.counts, orders, knots, weights if weights.size else None, where=self.where
        )

    def per_point(self, name: str, values: np.ndarray, scope: str) -> np.ndarray:
        """``values`` of any scope as one row per output point."""
        scope = self._scope(name, values, scope)
        if scope == "vertex":
            if self.stencil is not None:
                return self.stencil.vertex(values)
            return curve_basis.through_points(values, self.counts, self.mapping)
        if scope in ("constant", "uniform"):
            return np.repeat(values, self.out if scope == "uniform" else len(self.points), axis=0)
        return values if self.stencil is None else self.stencil.varying(values)

    def _scope(self, name: str, values: np.ndarray, scope: str) -> str:
        """``scope`` checked against the number of values (or, when the file names no
        scope, found from it)."""
        if not scope:
            scope = next((s for s, n in self.sizes.items() if n == len(values)), "")
        if scope not in self.sizes or len(values) != self.sizes[scope]:
            raise Refused(
                f"{self.where}: {name} has {len(values)} values; {scope or 'no'}"
                f" scope needs {self.sizes.get(scope, 'a known scope')}"
            )
        return scope

    def read(
        self, geom: Abc.ICompoundProperty, sel: Abc.ISampleSelector
    ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """(point_data, curve_data): widths, normals, uv and every numeric arbGeomParam."""
        point_data: dict[str, np.ndarray] = {}
        curve_data: dict[str, np.ndarray] = {}
        for key, name, comps in (("width", "width", ()), ("normal", "N", (3,))):
            param = _param(geom, name, sel, self.where)
            if param is not None:
                values = param[0].astype(np.float32)
                if values.shape[1:] != comps:
                    raise Refused(
                        f"{self.where}: {name} has values of shape"
                        f" {values.shape[1:]}; it needs {comps or 'one number'}"
                    )
                point_data[key] = self.per_point(name, values, param[1])
        uv = _param(geom, "uv", sel, self.where)
        if uv is not None:
            self._put("uv", uv, point_data, curve_data, rename="root_uv")
        if geom.getPropertyHeader(".arbGeomParams") is not None:
            arb = Abc.ICompoundProperty(geom, ".arbGeomParams")
            params = {
                h.getName(): _param(arb, h.getName(), sel, self.where) for h in arb.propertyheaders
            }
            self._colour(params, point_data)
            for name, param in params.items():
                if param is not None and name not in point_data and name not in curve_data:
                    self._put(name, param, point_data, curve_data)
        return point_data, curve_data

    def _colour(self, params: dict, point_data: dict[str, np.ndarray]) -> None:
        """The colour parameter (C3f or C4f; by name priority, else the first; only one
        named ``color`` when the names are read as ``stored``) as ``color`` per point,
        its alpha as ``opacity`` unless an ``opacity`` parameter gives that."""
        colours = [
            n
            for n, p in params.items()
            if p is not None
            and p[2] in ("rgb", "rgba")
            and p[0].dtype.kind == "f"
            and (not self.stored or n == "color")
        ]
        if not colours:
            return
        name = min(
            colours,
            key=lambda n: (
                COLOR_NAMES.index(n.lower()) if n.lower() in COLOR_NAMES else len(COLOR_NAMES)
            ),
        )
        values, scope, _ = params.pop(name)
        rgba = self.per_point(name, values.astype(np.float32), scope)
        point_data["color"] = np.ascontiguousarray(rgba[:, :3])
        if rgba.shape[1] == 4 and params.get("opacity") is None:
            point_data["opacity"] = np.ascontiguousarray(rgba[:, 3])

    def _put(
        self,
        name: str,
        param: tuple[np.ndarray, str, str],
        point_data: dict[str, np.ndarray],
        curve_data: dict[str, np.ndarray],
        rename: str | None = None,
    ) -> None:
        """A parameter per curve (uniform, under ``rename`` if given: a constant one is
        repeated) or per point (opacity always, as follicle keeps it); other constant
        ones are skipped, as USD's."""
        values, scope, _ = param
        scope = self._scope(name, values, scope)
        if name == "opacity":
            point_data[name] = self.per_point(name, values.astype(np.float32), scope)
        elif scope == "uniform" or rename and scope == "constant":
            curve_data[rename or name] = (
                np.repeat(values, len(self.counts), axis=0) if scope == "constant" else values
            )
        elif scope != "constant":
            point_data[name] = self.per_point(name, values, scope)


def _clamped_knots(counts: np.ndarray, orders: np.ndarray) -> np.ndarray:
    """Open uniform knots (each end repeated ``order`` times, uniform between), so the
    curve starts and ends at its end vertices: Blender's default for NURBS it exports
    without knots."""
    per = []
    for n, k in zip(counts.tolist(), orders.tolist(), strict=True):
        inner = np.arange(1, n - k + 1, dtype=np.float64)
        per.append(np.concatenate([np.zeros(k), inner, np.full(k, max(n - k + 1, 1.0))]))
    return np.concatenate(per) if per else np.zeros(0)


def _pad_knots(knots: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Knot vectors written without their two outermost knots (Maya's convention) with
    those ends repeated back."""
    ends = np.cumsum(lengths)
    parts = np.split(knots, ends[:-1])
    return np.concatenate(
        [np.concatenate([p[:1], p, p[-1:]]) for p in parts if p.size] or [np.zeros(0)]
    )


# ------------------------------------------------------------------ archive
def _objects(
    archive: Abc.IArchive, sel: Abc.ISampleSelector, source: str
) -> Iterator[tuple[Abc.IObject, np.ndarray]]:
    """Every object of the archive, depth first in archive order, with its world matrix
    (row vectors); a stack, not recursion, so a deep hierarchy cannot overflow."""
    stack = [(child, np.eye(4)) for child in reversed(list(archive.getTop().children))]
    while stack:
        obj, world = stack.pop()
        if AbcGeom.IXform.matches(obj.getHeader()):
            local, inherits = _xform(obj, sel, source)
            world = local @ world if inherits else local
        yield obj, world
        stack.extend((child, world) for child in reversed(list(obj.children)))


def _selector(time: float | None) -> Abc.ISampleSelector:
    """Each object's first sample, or the sample nearest ``time`` seconds (alembic3d
    takes a whole number for a time too: only the bare selector picks index 0)."""
    return Abc.ISampleSelector() if time is None else Abc.ISampleSelector(float(time))


def _scalar_int(compound: Abc.ICompoundProperty, name: str) -> int | None:
    """The whole number that scalar property ``name`` of ``compound`` holds, or None."""
    header = compound.getPropertyHeader(name)
    if (
        header is None
        or not header.isScalar()
        or _POD.get(header.getDataType().getPod())
        not in (np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32)
    ):
        return None
    value = compound.getProperty(name).getValue()
    return int(value) if isinstance(value, (int, np.integer)) else None


def _groom_version(obj: Abc.IObject, sel: Abc.ISampleSelector, where: str) -> list[int] | None:
    """Unreal's groom schema version (``groom_version_major``, ``_minor``) where its
    importer reads groom-wide values: scalar user properties of the curves object or an
    Xform above it, or (version 1.0's place) an Xform's arbGeomParams; None when it is
    not there. (A curves object's arbGeomParams are its strands' attributes to Unreal.)"""
    while obj.valid() and obj.getParent().valid():  # up to the archive's top, not it
        props = obj.getProperties()
        xform = AbcGeom.IXform.matches(obj.getHeader())
        for schema in (".xform",) if xform else (".geom",):
            if props.getPropertyHeader(schema) is None:
                continue
            geom = Abc.ICompoundProperty(props, schema)
            if geom.getPropertyHeader(".userProperties") is not None:
                user = Abc.ICompoundProperty(geom, ".userProperties")
                major, minor = (_scalar_int(user, k) for k in GROOM_VERSION_KEYS)
                if major is not None and minor is not None:
                    return [major, minor]
            if xform and geom.getPropertyHeader(".arbGeomParams") is not None:
                arb = Abc.ICompoundProperty(geom, ".arbGeomParams")
                params = [_param(arb, k, sel, where) for k in GROOM_VERSION_KEYS]
                ints = [
                    p[0] for p in params if p is not None and p[0].size and p[0].dtype.kind in "iu"
                ]
                if len(ints) == len(params):
                    return [int(v.reshape(-1)[0]) for v in ints]
        obj = obj.getParent()
    return None


def _curves_part(
    obj: Abc.IObject, world: np.ndarray, sel: Abc.ISampleSelector, source: str, stored: bool
) -> dict:
    where = f"{source}: {obj.getFullName()}"
    sample = AbcGeom.ICurves(obj, _EXISTING).getSchema().getValue(sel)
    try:
        part = _Curves(sample, where, stored)
        point_data, curve_data = part.read(Abc.ICompoundProperty(obj.getProperties(), ".geom"), sel)
        points = to_world(part.points, point_data, world, where, "fix its Xforms")
    except (curve_basis.CurveBasisError, SpaceError) as exc:
        raise Refused(str(exc)) from None
    found: dict[str, object] = {
        "where": where,
        "points": points,
        "offsets": np.concatenate([[0], np.cumsum(part.out)]),
        "point_data": point_data,
        "curve_data": curve_data,
    }
    if stored:  # what `follicle check` also asks: does Unreal see its groom schema?
        found["groom_schema"] = _groom_version(obj, sel, where) is not None
    return found


def read_curves(
    path: str, source: str, time: float | None, guides: bool, stored: bool = False
) -> Iterator[dict]:
    """Every chosen curves object of the archive at ``path`` as a dict of arrays (see
    the module), one at a time (the reading server counts their arrays as they come):
    those outside /Groom/Guides, or those inside when ``guides`` or when there are no
    others. Messages name it ``source``. ``stored``: parameters under the
    names the file gives them (for `follicle check`), no colour aliases taken as ours."""
    sel = _selector(time)
    archive = Abc.IArchive(path)
    found = [
        (o, m) for o, m in _objects(archive, sel, source) if AbcGeom.ICurves.matches(o.getHeader())
    ]
    is_guide = [
        o.getFullName() == GUIDES_PATH or o.getFullName().startswith(GUIDES_PATH + "/")
        for o, _ in found
    ]
    hair = [f for f, g in zip(found, is_guide, strict=True) if not g]
    guide = [f for f, g in zip(found, is_guide, strict=True) if g]
    chosen = guide if guides else hair or guide
    if not chosen:
        what = f"no {GUIDES_PATH} curves" if guides else "no curves objects"
        raise Refused(f"{source}: {what}; is this a hair file?")
    for obj, world in chosen:
        yield _curves_part(obj, world, sel, source, stored)


# ------------------------------------------------------------------ meshes
def _shape_name(obj: Abc.IObject) -> str:
    """A shape's name as the tools that wrote it mean it: its Xform's when that holds
    nothing else (Maya's ``head/headShape``, follicle's ``Skin/SkinShape``), as Blender
    names the object it imports; else its own."""
    parent = obj.getParent()
    if (
        parent.valid()
        and AbcGeom.IXform.matches(parent.getHeader())
        and parent.getNumChildren() == 1
    ):
        return parent.getName()
    return obj.getName()


def _world_at(obj: Abc.IObject, sel: Abc.ISampleSelector, source: str) -> np.ndarray:
    """The object's world matrix (row vectors) at ``sel``, as :func:`_objects` makes it:
    the Xforms above it, nearest first, until one that does not inherit."""
    world = np.eye(4)
    for parent in _parents(obj):
        local, inherits = _xform(parent, sel, source)
        world = world @ local
        if not inherits:
            break
    return world


def _xform(obj: Abc.IObject, sel: Abc.ISampleSelector, source: str) -> tuple[np.ndarray, bool]:
    """An Xform's local matrix (row vectors) at ``sel`` and whether it inherits its
    parent's; Refused when the matrix is not finite."""
    schema = AbcGeom.IXform(obj, _EXISTING).getSchema()
    local = np.array(schema.getValue(sel).getMatrix(), dtype=np.float64)
    if local.shape != (4, 4) or not np.isfinite(local).all():
        raise Refused(
            f"{source}: {obj.getFullName()}: its transform is not finite (NaN or inf); fix"
            " the Xform"
        )
    return local, bool(schema.getInheritsXforms(sel))


def _sampled_times(obj: Abc.IObject, schema: _Sampled) -> list[float]:
    """The times (s) of the object's samples and of the samples of the Xforms above it."""
    times: set[float] = set()
    schemas: list[_Sampled] = [schema] + [
        AbcGeom.IXform(p, _EXISTING).getSchema() for p in _parents(obj)
    ]
    for kind in schemas:
        sampling = kind.getTimeSampling()
        times.update(sampling.getSampleTime(i) for i in range(kind.getNumSamples()))
    return sorted(times)


def _parents(obj: Abc.IObject) -> list[Abc.IObject]:
    """The Xforms above ``obj``."""
    out, parent = [], obj.getParent()
    while parent.valid() and parent.getParent().valid():
        if AbcGeom.IXform.matches(parent.getHeader()):
            out.append(parent)
        parent = parent.getParent()
    return out


def _animation(obj: Abc.IObject, schema: _MeshSchema, count: int, where: str, source: str) -> dict:
    """The mesh's world points at each of its samples and its Xforms': ``times`` (K,)
    in seconds and ``frames`` (K, P, 3)."""
    times = _sampled_times(obj, schema)
    if len(times) < 2:
        raise Refused(
            f"{where}: it and its Xforms have {len(times)} sample(s); a skin animation"
            " needs the mesh sampled at two times or more"
        )
    if len(times) * count > MAX_ANIMATION_POINTS:
        raise Refused(
            f"{where}: {len(times):,} samples of {count:,} points is more than"
            f" {MAX_ANIMATION_POINTS:,} points in all; export fewer frames"
        )
    frames = np.empty((len(times), count, 3))
    for k, t in enumerate(times):
        sel = Abc.ISampleSelector(float(t))
        points = _numpy(schema.getValue(sel).getPositions()).astype(np.float64)
        if points.shape != (count, 3):
            raise Refused(
                f"{where}: at {t:g} s its P has shape {points.shape}, at the first"
                f" ({count}, 3); a skin animation keeps its points"
            )
        try:
            frames[k] = to_world(points, {}, _world_at(obj, sel, source), where, "fix its Xforms")
        except SpaceError as exc:
            raise Refused(str(exc)) from None
    return {"times": np.asarray(times, dtype=np.float64), "frames": frames}


def read_mesh(path: str, source: str, animated: bool = False) -> list[dict]:
    """The first PolyMesh (or SubD cage) of the archive at ``path`` at its first sample,
    as polygons with their UVs, and the names of the meshes after it. With ``animated``,
    also its points at every sample (:func:`_animation`)."""
    sel = _selector(None)
    archive = Abc.IArchive(path)
    meshes = [
        (o, m)
        for o, m in _objects(archive, sel, source)
        if AbcGeom.IPolyMesh.matches(o.getHeader()) or AbcGeom.ISubD.matches(o.getHeader())
    ]
    if not meshes:
        raise Refused(f"{source}: no PolyMesh or SubD objects; is this a mesh file?")
    obj, world = meshes[0]
    where = f"{source}: {obj.getFullName()}"
    kind = AbcGeom.IPolyMesh if AbcGeom.IPolyMesh.matches(obj.getHeader()) else AbcGeom.ISubD
    schema = kind(obj, _EXISTING).getSchema()
    sample = schema.getValue(sel)
    points = _numpy(sample.getPositions()).astype(np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise Refused(f"{where}: P must be point3f[] (x, y, z each), got shape {points.shape}")
    try:
        points = to_world(points, {}, world, where, "fix its Xforms")
    except SpaceError as exc:
        raise Refused(str(exc)) from None
    part = {
        "where": where,
        "name": _shape_name(obj),
        "points": points,
        "face_counts": _numpy(sample.getFaceCounts()).reshape(-1),
        "face_indices": _numpy(sample.getFaceIndices()).reshape(-1),
        # Alembic winds faces clockwise; a mirroring transform turns them back
        "flip": bool(np.linalg.det(world[:3, :3]) > 0),
        "others": [o.getFullName() for o, _ in meshes[1:]],
    }
    uv = _param(Abc.ICompoundProperty(obj.getProperties(), ".geom"), "uv", sel, where)
    if uv is not None:
        part["uv"], part["uv_scope"] = uv[0], {"varying": "vertex"}.get(uv[1], uv[1])
    if animated:
        part.update(_animation(obj, schema, len(points), where, source))
    return [part]


def read_request(request: dict) -> Iterator[dict]:
    """The reading server's entry (:mod:`follicle.io.guard_server`): curves
    (``abc-curves``, with ``time`` and ``guides``, one object at a time) or the mesh
    (``abc-mesh``)."""
    source = request["shown"]
    try:
        if request["kind"] == "abc-mesh":
            yield from read_mesh(request["source"], source, request.get("animated", False))
        else:
            yield from read_curves(
                request["source"],
                source,
                request["time"],
                request["guides"],
                request.get("stored", False),
            )
    except ERRORS as exc:
        why = " ".join(str(exc).split())[:300] or type(exc).__name__
        raise Refused(f"{source}: Alembic could not read it ({why}); {HINT}") from None
