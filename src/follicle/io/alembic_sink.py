"""Writing an Alembic archive in a child process: alembic3d aborts on a failed write.

Ogawa writes through a C++ stream that throws on a full disk or a file-size limit, and
the archive's destructors write again (its root group, its "finished" flag) and so
throw once more, which ends the process (``std::terminate``). So
:mod:`follicle.io.alembic` decides everything in Python and sends each object to
write through a pipe to this module, started by
:func:`follicle.io.guard_server.command` (``"abc-sink"``)
(numpy and alembic3d only): a failed write then ends this child, which reports it, and
never the caller. After a failure the child leaves with ``os._exit``, so no destructor
runs; after a finished archive it waits for the next one.

The protocol, on stdin: one JSON line per operation naming its arrays
(``"arrays": [[name, dtype, shape], …]``), then their raw bytes in that order
(:func:`send`, :func:`receive`). Operations: ``open`` (``path``), ``xform`` (``path``,
``fps``/``start`` for a sampled one, ``user``: ``{name: int16}`` user properties),
``matrix`` (``path``; ``matrix``: a row-vector 4×4 sample), ``curves`` (``path``,
``fps``/``start``, ``keep``: hold it for more samples; ``points``, ``counts``,
``bounds``, optional ``width``, ``normal``, ``uv`` (uniform scope, or vertex scope when
it has one row a point), ``velocities`` and ``params``:
``[[name, kind, scope], …]`` with arrays ``param0``, …, kind one of
:data:`_PARAM_TYPES`, scope ``Vertex``, ``Uniform`` or ``Constant``), ``sample``
(``path``; ``points``, ``velocities``, ``bounds``, optional ``normal``), ``mesh``
(``path``, ``fps``/``start`` for a sampled one; ``points``, ``indices``, ``counts``,
optional ``uv`` and ``uv_index``), ``mesh_points`` (``path`` of a sampled mesh;
``points``: its next sample) and ``close``. The child answers ``close`` (or a failure)
with one JSON line on stdout: ``{"ok": true}`` or ``{"error": message}``.
"""

from __future__ import annotations

import json
import os
import sys
from typing import BinaryIO, Protocol

import imath
import numpy as np
from alembic3d import Abc, AbcCoreAbstract, AbcGeom

__all__ = ["send", "receive", "serve"]


# alembic3d ships no type information: what this module calls on its handles
class _OSchema(Protocol):
    """The schema of an alembic3d output object (``getSchema()``): takes samples."""

    def set(self, sample: object, /) -> None: ...


class _OObject(Protocol):
    """An alembic3d output object kept for later samples: OXform, OCurves, OPolyMesh."""

    def getSchema(self) -> _OSchema: ...


class _OCurvesSample(Protocol):
    """``AbcGeom.OCurvesSchemaSample``: the setters :meth:`_Writer.curves` adds."""

    def setCurvesNumVertices(self, counts: object, /) -> None: ...
    def setWidths(self, widths: object, /) -> None: ...
    def setUVs(self, uvs: object, /) -> None: ...


def send(stream: BinaryIO, op: dict, arrays: dict[str, np.ndarray] | None = None) -> None:
    """Write operation ``op`` with ``arrays`` (numeric, any shape) to ``stream``."""
    arrays = {k: np.ascontiguousarray(v) for k, v in (arrays or {}).items()}
    listed = [[k, v.dtype.str, list(v.shape)] for k, v in arrays.items()]
    stream.write(json.dumps({**op, "arrays": listed}).encode() + b"\n")
    for arr in arrays.values():
        if arr.size:  # (a view of no bytes cannot be cast)
            stream.write(arr.data.cast("B"))


def receive(stream: BinaryIO) -> tuple[dict | None, dict[str, np.ndarray]]:
    """The next operation and its arrays from ``stream``; (None, {}) at its end."""
    line = stream.readline()
    if not line:
        return None, {}
    op = json.loads(line)
    arrays = {}
    for name, dtype, shape in op.pop("arrays"):
        kind = np.dtype(dtype)
        data = stream.read(kind.itemsize * int(np.prod(shape, dtype=np.int64)))
        arrays[name] = np.frombuffer(data, kind).reshape(shape)
    return op, arrays


class _Writer:
    """The archive being written and its objects by path.

    alembic3d's samples point into the imath arrays they are given without holding
    them, so every array made for an operation is kept in ``held`` until the operation
    has been written (:func:`serve` clears it after each)."""

    def __init__(self) -> None:
        self.archive: Abc.OArchive | None = None
        self.objects: dict[str, _OObject] = {}
        self.samplings: dict[tuple[float, float], int] = {}
        self.held: list[object] = []

    # -------------------------------------------------------------- helpers
    def _parent(self, path: str) -> tuple[object, str]:
        parent, _, name = path.rpartition("/")
        if parent:
            return self.objects[parent], name
        assert self.archive is not None  # follicle.io.alembic sends "open" first
        return self.archive.getTop(), name

    def _args(self, op: dict) -> list:
        """The time sampling argument of a sampled object (``fps``, ``start`` seconds)."""
        if op.get("fps") is None:
            return []
        key = (op["fps"], op["start"])
        if key not in self.samplings:
            sampling = AbcCoreAbstract.TimeSampling(1.0 / key[0], key[1])
            assert self.archive is not None  # follicle.io.alembic sends "open" first
            self.samplings[key] = self.archive.addTimeSampling(sampling)
        return [Abc.Argument(self.samplings[key])]

    def _values(self, kind: str, arr: np.ndarray) -> object:
        """``arr`` as the imath array of ``kind``, held until the operation ends."""
        if kind == "c3f":
            out = imath.C3fArray(imath.V3fArrayFromBuffer(arr))
        elif kind == "uchar":
            out = imath.UnsignedCharArray(len(arr))
            np.asarray(out)[:] = arr
        elif kind == "uint":
            out = imath.UnsignedIntArray(imath.DoubleArrayFromBuffer(arr.astype(np.float64)))
        else:
            out = getattr(imath, _BUFFERS[kind] + "ArrayFromBuffer")(arr)
        self.held.append(out)
        return out

    def _param(
        self, kind: str, arr: np.ndarray, scope: str, index: np.ndarray | None = None
    ) -> object:
        """A geometry parameter sample of ``kind`` holding ``arr`` (and ``index``)."""
        sample = getattr(AbcGeom, f"O{_PARAM_TYPES[kind]}GeomParamSample")
        scope = getattr(AbcGeom.GeometryScope, f"k{scope}Scope")
        values = self._values(kind, arr)
        if index is None:
            return sample(values, scope)
        return sample(values, self._values("uint", index), scope)

    def _linear(self, arrays: dict[str, np.ndarray]) -> _OCurvesSample:
        """A sample of linear, nonperiodic curves (said in every sample: a sample that
        does not say it is cubic Bézier) with its points, bounds and optional normals
        and velocities."""
        sample = AbcGeom.OCurvesSchemaSample()
        sample.setPositions(self._values("v3f", arrays["points"]))
        sample.setType(AbcGeom.CurveType.kLinear)
        sample.setWrap(AbcGeom.CurvePeriodicity.kNonPeriodic)
        sample.setBasis(AbcGeom.BasisType.kNoBasis)
        low, high = (imath.V3d(*row) for row in arrays["bounds"].tolist())
        sample.setSelfBounds(imath.Box3d(low, high))
        if "normal" in arrays:
            sample.setNormals(self._param("n3f", arrays["normal"], "Vertex"))
        if "velocities" in arrays:
            sample.setVelocities(self._values("v3f", arrays["velocities"]))
        return sample

    # -------------------------------------------------------------- operations
    def open(self, op: dict, arrays: dict[str, np.ndarray]) -> None:
        self.archive = Abc.OArchive(op["path"])

    def xform(self, op: dict, arrays: dict[str, np.ndarray]) -> None:
        parent, name = self._parent(op["path"])
        xform = AbcGeom.OXform(parent, name, *self._args(op))
        self.objects[op["path"]] = xform
        if op.get("user"):  # int16 scalars (Unreal's groom schema version)
            user = xform.getSchema().getUserProperties()
            for key, value in op["user"].items():
                Abc.OInt16Property(user, key).setValue(int(value))

    def matrix(self, op: dict, arrays: dict[str, np.ndarray]) -> None:
        sample = AbcGeom.XformSample()
        sample.setMatrix(imath.M44d(*[tuple(row) for row in arrays["matrix"].tolist()]))
        self.objects[op["path"]].getSchema().set(sample)

    def curves(self, op: dict, arrays: dict[str, np.ndarray]) -> None:
        parent, name = self._parent(op["path"])
        obj = AbcGeom.OCurves(parent, name, *self._args(op))
        schema = obj.getSchema()
        sample = self._linear(arrays)
        sample.setCurvesNumVertices(self._values("int", arrays["counts"]))
        if "width" in arrays:
            sample.setWidths(self._param("float", arrays["width"], "Vertex"))
        if "uv" in arrays:  # per curve, or per vertex when there is one a vertex
            per_vertex = len(arrays["uv"]) == len(arrays["points"]) != len(arrays["counts"])
            scope = "Vertex" if per_vertex else "Uniform"
            sample.setUVs(self._param("v2f", arrays["uv"], scope))
        schema.set(sample)
        arb = schema.getArbGeomParams()
        for i, (pname, kind, scope) in enumerate(op["params"]):
            param = getattr(AbcGeom, f"O{_PARAM_TYPES[kind]}GeomParam")
            param(arb, pname, False, getattr(AbcGeom.GeometryScope, f"k{scope}Scope"), 1).set(
                self._param(kind, arrays[f"param{i}"], scope)
            )
        if op["keep"]:
            self.objects[op["path"]] = obj

    def sample(self, op: dict, arrays: dict[str, np.ndarray]) -> None:
        self.objects[op["path"]].getSchema().set(self._linear(arrays))

    def mesh(self, op: dict, arrays: dict[str, np.ndarray]) -> None:
        parent, name = self._parent(op["path"])
        args = [
            self._values("v3f", arrays["points"]),
            self._values("int", arrays["indices"]),
            self._values("int", arrays["counts"]),
        ]
        if "uv" in arrays:
            args.append(self._param("v2f", arrays["uv"], "Facevarying", arrays["uv_index"]))
        obj = AbcGeom.OPolyMesh(parent, name, *self._args(op))
        obj.getSchema().set(AbcGeom.OPolyMeshSchemaSample(*args))
        if op.get("fps") is not None:  # sampled: mesh_points adds its later samples
            self.objects[op["path"]] = obj

    def mesh_points(self, op: dict, arrays: dict[str, np.ndarray]) -> None:
        """The next sample of a sampled mesh: new points, the topology kept."""
        sample = AbcGeom.OPolyMeshSchemaSample()
        sample.setPositions(self._values("v3f", arrays["points"]))
        self.objects[op["path"]].getSchema().set(sample)

    def close(self, op: dict, arrays: dict[str, np.ndarray]) -> None:
        """Release every object, children first, then the archive: Ogawa writes the
        hierarchy and its root and marks the file finished."""
        for path in sorted(self.objects, key=lambda p: -p.count("/")):
            del self.objects[path]
        self.samplings.clear()  # a time sampling's index belongs to its archive
        self.archive = None


# geometry parameter kind -> the name in alembic3d's O<name>GeomParam, and its imath array
_PARAM_TYPES = {
    "float": "Float",
    "v2f": "V2f",
    "v3f": "V3f",
    "n3f": "N3f",
    "double": "Double",
    "v2d": "V2d",
    "v3d": "V3d",
    "int": "Int32",
    "v2i": "V2i",
    "v3i": "V3i",
    "uchar": "Uchar",
    "c3f": "C3f",
}
_BUFFERS = {
    "float": "Float",
    "v2f": "V2f",
    "v3f": "V3f",
    "n3f": "V3f",
    "double": "Double",
    "v2d": "V2d",
    "v3d": "V3d",
    "int": "Int",
    "v2i": "V2i",
    "v3i": "V3i",
}


def serve() -> None:
    """Run the operations on stdin (see the module), archive after archive, answering
    each ``close``; end when stdin does (the caller is gone) or after a failure, which
    is answered in its place."""
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    writer = _Writer()
    try:
        while True:
            op, arrays = receive(stdin)
            if op is None:
                break
            getattr(writer, op["op"])(op, arrays)
            writer.held.clear()
            if op["op"] == "close":
                stdout.write(b'{"ok": true}\n')
                stdout.flush()
    except Exception as exc:  # noqa: BLE001 - every failure is reported, then the child ends
        why = getattr(exc, "strerror", None) or " ".join(str(exc).split())[:300]
        stdout.write(json.dumps({"error": why or type(exc).__name__}).encode() + b"\n")
        stdout.flush()
        # leave now, no destructor run: the objects the failed write left behind would
        # write again as they go, and abort
        os._exit(1)
    os._exit(1 if writer.archive is not None else 0)  # an unfinished archive stays so
