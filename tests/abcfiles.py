"""Alembic archives written with alembic3d's own API, the way other tools write them,
for the Alembic tests: curves of any type, basis, wrap and scope under Xforms, meshes.

alembic3d's samples point into the imath arrays they are given without holding them,
so each function keeps the arrays it makes (``held``) until its sample is written."""

from __future__ import annotations

import imath
import numpy as np
from alembic3d import Abc, AbcCoreAbstract, AbcGeom

KIND = {
    "linear": AbcGeom.CurveType.kLinear,
    "cubic": AbcGeom.CurveType.kCubic,
    "variable": AbcGeom.CurveType.kVariableOrder,
}
BASIS = {
    "none": AbcGeom.BasisType.kNoBasis,
    "bezier": AbcGeom.BasisType.kBezierBasis,
    "bspline": AbcGeom.BasisType.kBsplineBasis,
    "catmullRom": AbcGeom.BasisType.kCatmullromBasis,
    "hermite": AbcGeom.BasisType.kHermiteBasis,
}
WRAP = {
    "nonperiodic": AbcGeom.CurvePeriodicity.kNonPeriodic,
    "periodic": AbcGeom.CurvePeriodicity.kPeriodic,
}
SCOPE = {
    "constant": AbcGeom.GeometryScope.kConstantScope,
    "uniform": AbcGeom.GeometryScope.kUniformScope,
    "varying": AbcGeom.GeometryScope.kVaryingScope,
    "vertex": AbcGeom.GeometryScope.kVertexScope,
    "faceVarying": AbcGeom.GeometryScope.kFacevaryingScope,
}


def values(kind: str, arr, held: list) -> object:
    """``arr`` as the imath array of a parameter ``kind``, kept in ``held``."""
    arr = np.ascontiguousarray(arr)
    if kind in ("c3f", "c4f"):
        out = (imath.C3fArray if kind == "c3f" else imath.C4fArray)(len(arr))
        for i, channel in enumerate("rgba"[: arr.shape[1]]):
            np.asarray(getattr(out, channel))[:] = arr[:, i]
    elif kind == "uint":
        out = imath.UnsignedIntArray(imath.DoubleArrayFromBuffer(arr.astype(np.float64)))
    elif kind == "uchar":
        out = imath.UnsignedCharArray(len(arr))
        np.asarray(out)[:] = arr
    elif kind == "short":  # no buffer constructor: element by element
        out = imath.ShortArray(len(arr))
        for i, v in enumerate(arr.tolist()):
            out[i] = v
    else:
        out = {
            "float": imath.FloatArrayFromBuffer,
            "int": imath.IntArrayFromBuffer,
            "v2f": imath.V2fArrayFromBuffer,
            "v3f": imath.V3fArrayFromBuffer,
            "n3f": imath.V3fArrayFromBuffer,
            "double": imath.DoubleArrayFromBuffer,
        }[kind](arr.astype({"int": np.int32, "double": np.float64}.get(kind, np.float32)))
    held.append(out)
    return out


GEOM = {
    "float": "Float",
    "int": "Int32",
    "v2f": "V2f",
    "v3f": "V3f",
    "n3f": "N3f",
    "c3f": "C3f",
    "c4f": "C4f",
    "double": "Double",
    "short": "Int16",
}


def param_sample(held: list, kind: str, vals, scope: str, index=None) -> object:
    sample = getattr(AbcGeom, f"O{GEOM[kind]}GeomParamSample")
    if index is None:
        return sample(values(kind, vals, held), SCOPE[scope])
    return sample(values(kind, vals, held), values("uint", index, held), SCOPE[scope])


def write(path, build):
    """An archive at ``path`` holding what ``build(top)`` makes under its top object;
    ``build`` returns the objects to keep until the archive closes, which it does when
    this returns (Ogawa finishes a file when its last object goes)."""
    arch = Abc.OArchive(str(path))
    kept = build(arch.getTop())
    del kept, arch
    return path


def add_params(arb, params, held: list) -> None:
    """arbGeomParams (name, kind, values, scope[, indices]) in the compound ``arb``."""
    for pname, kind_, vals, scope, *index in params:
        param = getattr(AbcGeom, f"O{GEOM[kind_]}GeomParam")(
            arb, pname, bool(index), SCOPE[scope], 1
        )
        param.set(param_sample(held, kind_, vals, scope, *index))


def xforms(top, chain) -> object:
    """Nested Xforms under ``top``: (name, 4×4 row-vector matrix, inherits) each."""
    parent = top
    for name, matrix, inherits in chain:
        xform = AbcGeom.OXform(parent, name)
        sample = AbcGeom.XformSample()
        sample.setMatrix(imath.M44d(*[tuple(r) for r in np.asarray(matrix, float).tolist()]))
        sample.setInheritsXforms(inherits)
        xform.getSchema().set(sample)
        parent = xform
    return parent


def add_curves(
    parent,
    name,
    counts,
    points,
    kind="linear",
    basis="none",
    wrap="nonperiodic",
    widths=None,
    uv=None,
    normals=None,
    params=(),
    orders=None,
    knots=None,
    weights=None,
) -> object:
    """One OCurves: ``widths``/``uv``/``normals`` are (values, scope) or (values, scope,
    indices); ``params`` (name, kind, values, scope[, indices]) arbGeomParams."""
    obj, held = AbcGeom.OCurves(parent, name), []
    sample = AbcGeom.OCurvesSchemaSample()
    sample.setPositions(values("v3f", points, held))
    sample.setCurvesNumVertices(values("int", counts, held))
    sample.setType(KIND[kind])
    sample.setBasis(BASIS[basis])
    sample.setWrap(WRAP[wrap])
    for setter, kind_, given in (
        ("setWidths", "float", widths),
        ("setUVs", "v2f", uv),
        ("setNormals", "n3f", normals),
    ):
        if given is not None:
            getattr(sample, setter)(param_sample(held, kind_, *given))
    if orders is not None:
        sample.setOrders(values("uchar", orders, held))
    if knots is not None:
        sample.setKnots(values("float", knots, held))
    if weights is not None:
        sample.setPositionWeights(values("float", weights, held))
    schema = obj.getSchema()
    schema.set(sample)
    add_params(schema.getArbGeomParams(), params, held)
    return obj


def add_mesh(parent, name, points, indices_, counts, uv=None, subd=False) -> object:
    """One OPolyMesh (or OSubD); faces as given (Alembic's are clockwise); ``uv`` is
    (values, scope) or (values, scope, indices)."""
    obj, held = (AbcGeom.OSubD if subd else AbcGeom.OPolyMesh)(parent, name), []
    cls = AbcGeom.OSubDSchemaSample if subd else AbcGeom.OPolyMeshSchemaSample
    sample = cls(
        values("v3f", points, held), values("int", indices_, held), values("int", counts, held)
    )
    if uv is not None:
        sample.setUVs(param_sample(held, "v2f", *uv))
    obj.getSchema().set(sample)
    return obj


def add_animated_mesh(parent, name, frames, indices_, counts, fps) -> object:
    """One OPolyMesh whose P is sampled at ``fps`` (one sample per entry of ``frames``,
    (K, P, 3), from time 0), its topology written once, as a baked deformation is."""
    archive = parent.getArchive()
    sampling = archive.addTimeSampling(AbcCoreAbstract.TimeSampling(1.0 / fps, 0.0))
    obj, held = AbcGeom.OPolyMesh(parent, name, sampling), []
    schema = obj.getSchema()
    schema.set(
        AbcGeom.OPolyMeshSchemaSample(
            values("v3f", frames[0], held),
            values("int", indices_, held),
            values("int", counts, held),
        )
    )
    for points in frames[1:]:
        schema.set(AbcGeom.OPolyMeshSchemaSample(values("v3f", points, held)))
    return obj
