"""Reading a USD stage's BasisCurves as plain arrays, run as a script in a child process.

usd-core is C++: a hostile file can make it crash, allocate without end or compose for
ever, so :mod:`follicle.io.usd_guard` runs this file as a script (``python -I
usd_stage.py``, see :func:`serve`): it imports only numpy and pxr (no follicle), and
forks a child for each file, which caps its own address space before it opens the file,
is killed at its time limit, and writes ``OUT/arrays.npz`` plus ``OUT/result.json``: either
``{"prims": [{"where", "points", "offsets", "point_data", "curve_data"}]}`` (names of
arrays in the npz) or ``{"refused": message}``. Each prim's curves are already the
points they pass through, in follicle's space (metres, +Y up).
"""

from __future__ import annotations

import json
import math
import os
import resource
import select
import signal
import sys
import traceback
from pathlib import Path

import numpy as np
from pxr import Sdf, Tf, Usd, UsdGeom

GUIDES_PATH = "/Groom/Guides"  # as follicle.io.usd has it (this script imports no follicle)
# what usd-core raises on a file it cannot make sense of (Tf errors, bad values, bad types)
USD_ERRORS = (Tf.ErrorException, RuntimeError, ValueError, TypeError, IndexError,
              OverflowError, np.linalg.LinAlgError)  # fmt: skip
MAX_PRIMS = 100_000  # prims a stage may compose, by _Composition's count
_VSTEP = {"bezier": 3, "bspline": 1, "catmullRom": 1}


class Refused(Exception):
    """The file is readable USD but not hair follicle can read; the message says why."""


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

    def _enter(self, key: tuple[str, str]) -> None:
        if key in self.active:
            raise Refused(f"{self.where}: {key[0]} composes itself (a reference, payload or"
                          " sublayer cycle); fix the file's composition arcs")  # fmt: skip
        self.active.add(key)

    def _done(self, key: tuple[str, str], n: int) -> int:
        if n > MAX_PRIMS:
            raise Refused(f"{self.where}: composes more than {MAX_PRIMS} prims (references"
                          " or payloads nested many times over); not read")  # fmt: skip
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
            sub = Sdf.Layer.FindOrOpenRelativeToLayer(layer, asset)
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
            arcs = [*spec.referenceList.GetAddedOrExplicitItems(),
                    *spec.payloadList.GetAddedOrExplicitItems()]  # fmt: skip
            for arc in arcs:
                n += self._arc(layer, arc.assetPath, arc.primPath)
            for variant_set in spec.variantSets.values():  # every variant, chosen or not
                n += sum(self.prim(layer, variant.primSpec.path)
                         for variant in variant_set.variants.values())  # fmt: skip
        return self._done(key, n)

    def _arc(self, layer: Sdf.Layer, asset: str, target: Sdf.Path) -> int:
        other = Sdf.Layer.FindOrOpenRelativeToLayer(layer, asset) if asset else layer
        if other is None:
            return 0
        if target.isEmpty:
            if not other.defaultPrim:
                return 0
            target = Sdf.Path.absoluteRootPath.AppendChild(other.defaultPrim)
        return self.prim(other, target)


# ------------------------------------------------------------------ curves
def _rule(kind: str, basis: str, wrap: str, counts: np.ndarray, where: str) -> str:
    """How a prim's control vertices map to the points its curves pass through."""
    if wrap == "periodic":
        raise Refused(f"{where}: periodic (closed) curves are not hair; not read")
    if kind == "linear":
        low, rule = 2, "all"
    elif basis not in _VSTEP:
        raise Refused(f"{where}: unknown basis '{basis}' (bezier, bspline or catmullRom)")
    elif wrap == "pinned" and basis != "bezier":
        low, rule = 2, "all" if basis == "catmullRom" else "pinned-knots"
    else:
        low, rule = 4, {"bezier": "bezier", "bspline": "knots", "catmullRom": "inner"}[basis]
    bad = (counts < low) | (((counts - 4) % 3 != 0) if rule == "bezier" else False)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise Refused(
            f"{where}: curve {i} has {int(counts[i])} vertices, invalid for {kind} {basis}"
            f" {wrap} curves"
        )
    return rule


def _out_counts(rule: str, counts: np.ndarray) -> np.ndarray:
    if rule in ("inner", "knots"):
        return counts - 2
    if rule == "bezier":
        return (counts - 1) // 3 + 1
    return counts


def _through(values: np.ndarray, counts: np.ndarray, rule: str) -> np.ndarray:
    """Per-control-vertex ``values`` at the points the curves pass through."""
    offsets = np.concatenate([[0], np.cumsum(counts)])
    if rule == "all":
        return values
    if rule == "pinned-knots":  # add USD's phantom ends, then as nonperiodic
        starts, ends = offsets[:-1], offsets[1:] - 1
        first, last = values[starts], values[ends]
        if np.issubdtype(values.dtype, np.floating):
            first, last = 2 * first - values[starts + 1], 2 * last - values[ends - 1]
        at = np.arange(len(values)) + np.repeat(2 * np.arange(len(counts)) + 1, counts)
        padded = np.empty((len(values) + 2 * len(counts),) + values.shape[1:], values.dtype)
        padded[at], padded[starts + 2 * np.arange(len(counts))] = values, first
        padded[ends + 2 * np.arange(len(counts)) + 2] = last
        return _through(padded, counts + 2, "knots")
    local = np.arange(len(values)) - np.repeat(offsets[:-1], counts)
    if rule == "bezier":
        return values[local % 3 == 0]
    inner = np.flatnonzero((local > 0) & (local < np.repeat(counts, counts) - 1))
    if rule == "inner" or not np.issubdtype(values.dtype, np.floating):
        return values[inner]
    # uniform cubic B-spline at its knots: (P[j-1] + 4 P[j] + P[j+1]) / 6
    return ((values[inner - 1] + 4 * values[inner] + values[inner + 1]) / 6).astype(values.dtype)


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
        raise Refused(f"{where}: {name} is {shape}; it must be an array ({name} = [...]) of"
                      " 1-4 components each")
    return arr.astype(np.float32) if arr.dtype == np.float16 else arr


class _Prim:
    """A BasisCurves prim read as arrays: its topology, then its primvars mapped to the
    points its curves pass through."""

    def __init__(self, prim: Usd.Prim, time: Usd.TimeCode, source: str) -> None:
        self.schema = UsdGeom.BasisCurves(prim)
        self.time = time
        self.where = f"{source}: {prim.GetPath()}"
        counts = _array(self.schema.GetCurveVertexCountsAttr().Get(time), "curveVertexCounts",
                        self.where)  # fmt: skip
        points = _array(self.schema.GetPointsAttr().Get(time), "points", self.where)
        if counts is None or points is None:
            raise Refused(f"{self.where}: no points or curveVertexCounts")
        if counts.ndim != 1 or counts.dtype.kind not in "iu":
            raise Refused(f"{self.where}: curveVertexCounts must be int[], got {counts.dtype}"
                          f" of shape {counts.shape}")  # fmt: skip
        if points.ndim != 2 or points.shape[1] != 3:
            raise Refused(f"{self.where}: points must be point3f[] (x, y, z each), got shape"
                          f" {points.shape}")  # fmt: skip
        self.counts = counts.astype(np.int64)
        if np.any(self.counts < 0):
            i = int(np.argmax(self.counts < 0))
            raise Refused(f"{self.where}: curve {i} has a negative vertex count"
                          f" ({int(self.counts[i])})")  # fmt: skip
        if int(self.counts.sum()) != len(points):
            raise Refused(
                f"{self.where}: curveVertexCounts sum to {int(self.counts.sum())} but there are"
                f" {len(points)} points"
            )
        self.rule = _rule(self.schema.GetTypeAttr().Get(), self.schema.GetBasisAttr().Get(),
                          self.schema.GetWrapAttr().Get(), self.counts, self.where)  # fmt: skip
        self.out = _out_counts(self.rule, self.counts)
        self.points = _through(points.astype(np.float32), self.counts, self.rule)

    def _check(self, name: str, values: np.ndarray, interpolation: str) -> None:
        sizes = {"constant": 1, "uniform": len(self.counts), "vertex": int(self.counts.sum()),
                 "varying": int(self.out.sum()), "faceVarying": int(self.out.sum())}  # fmt: skip
        if interpolation not in sizes or len(values) != sizes[interpolation]:
            raise Refused(
                f"{self.where}: {name} has {len(values)} values; {interpolation} interpolation"
                f" needs {sizes.get(interpolation, 'a known interpolation')}"
            )

    def per_point(self, name: str, values: np.ndarray, interpolation: str) -> np.ndarray:
        """``values`` of any interpolation as one row per output point."""
        self._check(name, values, interpolation)
        if interpolation == "vertex":
            return _through(values, self.counts, self.rule)
        if interpolation in ("constant", "uniform"):
            return np.repeat(values, self.out if interpolation == "uniform" else len(self.points),
                             axis=0)  # fmt: skip
        return values

    def _widths_normals(self, point_data: dict[str, np.ndarray]) -> None:
        api = UsdGeom.PrimvarsAPI(self.schema)
        for key, name, attr, interpolation in (
            ("width", "widths", self.schema.GetWidthsAttr(), self.schema.GetWidthsInterpolation()),
            ("normal", "normals", self.schema.GetNormalsAttr(),
             self.schema.GetNormalsInterpolation()),
        ):  # fmt: skip
            if api.HasPrimvar(name):  # primvars:widths / primvars:normals win over the attribute
                primvar = api.GetPrimvar(name)
                value = primvar.ComputeFlattened(self.time)
                interpolation = primvar.GetInterpolation()
            else:
                value = attr.Get(self.time) if attr.HasAuthoredValue() else None
            arr = _array(value, name, self.where)
            if arr is not None:
                point_data[key] = self.per_point(name, arr.astype(np.float32), interpolation)

    def _rows(self, primvar: UsdGeom.Primvar, arr: np.ndarray) -> np.ndarray:
        """``arr`` grouped in rows of the primvar's elementSize."""
        size = primvar.GetElementSize()
        if size == 1:
            return arr
        if arr.ndim != 1 or size < 1 or len(arr) % size:
            raise Refused(f"{self.where}: primvar {primvar.GetPrimvarName()} has elementSize"
                          f" {size} but {arr.size} values of shape {arr.shape}; fix"
                          " elementSize")  # fmt: skip
        return arr.reshape(len(arr) // size, size)

    def read(self) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """(point_data, curve_data) of the prim, per output point and per curve."""
        point_data: dict[str, np.ndarray] = {}
        curve_data: dict[str, np.ndarray] = {}
        self._widths_normals(point_data)
        for primvar in UsdGeom.PrimvarsAPI(self.schema).GetPrimvarsWithAuthoredValues():
            name, interpolation = primvar.GetPrimvarName(), primvar.GetInterpolation()
            arr = _array(primvar.ComputeFlattened(self.time), name, self.where)
            if name in ("widths", "normals") or arr is None or interpolation == "constant" \
                    and name not in ("displayColor", "displayOpacity"):  # fmt: skip
                continue
            arr = self._rows(primvar, arr)
            key = {"displayColor": "color", "displayOpacity": "opacity"}.get(name)
            if key is not None:
                point_data[key] = self.per_point(name, arr.astype(np.float32), interpolation)
            elif interpolation == "uniform":
                self._check(name, arr, interpolation)
                curve_data[name] = arr
            else:
                point_data[name] = self.per_point(name, arr, interpolation)
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
                raise Refused(f"{where}: xformOpOrder of {prim.GetPath()} names {missing[0]},"
                              " which it does not have as a transform attribute; fix the"
                              " xformOps")  # fmt: skip
        prim = prim.GetParent()


def _world(prim: Usd.Prim, time: Usd.TimeCode, where: str) -> np.ndarray:
    """The prim's local-to-world matrix times the stage's metersPerUnit and a Z-up to Y-up
    turn: row vectors in follicle's metres, +Y up."""
    stage = prim.GetStage()
    _check_ops(prim, where)
    m = np.array(UsdGeom.XformCache(time).GetLocalToWorldTransform(prim), dtype=np.float64)
    mpu = UsdGeom.GetStageMetersPerUnit(stage)
    if not (math.isfinite(mpu) and mpu > 0):
        raise Refused(f"{where}: metersPerUnit is {mpu}; it must be a number > 0 (1 for"
                      " metres, 0.01 for centimetres)")  # fmt: skip
    if not np.isfinite(m).all():
        raise Refused(f"{where}: its transform is not finite (NaN or inf); fix its xformOps")
    m[:, :3] *= mpu
    if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z:  # (x, y, z) -> (x, z, -y)
        m = m @ np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], np.float64)
    return m


def _transform(points: np.ndarray, pd: dict[str, np.ndarray], m: np.ndarray,
               where: str) -> np.ndarray:  # fmt: skip
    """``points`` (returned) and ``pd``'s width and normal (in place) moved by ``m``."""
    if np.allclose(m, np.eye(4), rtol=0, atol=1e-12):
        return points
    linear = m[:3, :3]  # USD matrices act on row vectors: p' = p @ linear + m[3, :3]
    det = float(np.linalg.det(linear))
    if "width" in pd:
        pd["width"] = (pd["width"] * abs(det) ** (1 / 3)).astype(np.float32)
    if "normal" in pd:
        if not (np.isfinite(det) and abs(det) > 1e-30):
            raise Refused(f"{where}: its transform is singular (a scale of 0), so its normals"
                          " cannot be transformed; fix its xformOps")  # fmt: skip
        n = pd["normal"].astype(np.float64) @ np.linalg.inv(linear).T
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        pd["normal"] = n.astype(np.float32)
    return (points.astype(np.float64) @ linear + m[3, :3]).astype(np.float32)


# ------------------------------------------------------------------ stage
def _chosen(stage: Usd.Stage, guides: bool, source: str) -> list[Usd.Prim]:
    prims = [p for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves)]
    guide_prims = [p for p in prims if p.GetPath().HasPrefix(Sdf.Path(GUIDES_PATH))]
    hair = [p for p in prims if p not in guide_prims]
    chosen = guide_prims if guides else hair or guide_prims
    if not chosen:
        what = f"no {GUIDES_PATH} prim" if guides else "no BasisCurves prims"
        raise Refused(f"{source}: {what}; is this a hair file?")
    return chosen


def read(path: str, source: str, time: float | None, guides: bool) -> list[dict]:
    """Every chosen BasisCurves prim of the file at ``path`` as a dict of arrays (see the
    module); messages name it ``source``."""
    root = Sdf.Layer.FindOrOpen(path)
    if root is None:
        raise Refused(f"{source}: usd-core could not open it; is it a valid USD file?")
    _Composition(source).layer(root)
    stage = Usd.Stage.Open(root, Usd.Stage.LoadAll)
    when = Usd.TimeCode.EarliestTime() if time is None else Usd.TimeCode(time)
    prims = []
    for prim in _chosen(stage, guides, source):
        part = _Prim(prim, when, source)
        point_data, curve_data = part.read()
        points = _transform(part.points, point_data, _world(prim, when, part.where), part.where)
        offsets = np.concatenate([[0], np.cumsum(part.out)])
        prims.append({"where": part.where, "points": points, "offsets": offsets,
                      "point_data": point_data, "curve_data": curve_data})  # fmt: skip
    return prims


def usd_error(exc: BaseException, first: bool = False) -> str:
    """The message of usd-core's last (or ``first``) error in ``exc``, on one line,
    without the C++ function and source file it names."""
    errors = str(exc).strip().split("Error in ")
    message = errors[1 if first and len(errors) > 1 else -1]
    if " : '" in message:  # Error in 'Function' at line N in file F : 'message'
        message = message.split(" : '", 1)[1]
    message = " ".join(message.split()).rstrip("'").strip()
    return message[:300] or type(exc).__name__


def _save(prims: list[dict], out: Path) -> dict:
    """Write the prims' arrays to ``out/arrays.npz``; the manifest naming them."""
    arrays: dict[str, np.ndarray] = {}

    def put(arr: np.ndarray) -> str:
        key = f"a{len(arrays)}"
        arrays[key] = np.ascontiguousarray(arr)
        return key

    manifest = [{"where": p["where"], "points": put(p["points"]), "offsets": put(p["offsets"]),
                 "point_data": {k: put(v) for k, v in p["point_data"].items()},
                 "curve_data": {k: put(v) for k, v in p["curve_data"].items()}}
                for p in prims]  # fmt: skip
    np.savez(out / "arrays.npz", **arrays)
    return {"prims": manifest}


def _read_request(request: dict) -> None:
    """Read ``request["source"]`` into ``request["out"]`` (see the module), with the
    address space capped at ``request["memory"]`` bytes first."""
    source, out = request["shown"], Path(request["out"])
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = request["memory"] if hard == resource.RLIM_INFINITY else min(request["memory"], hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        result = _save(read(request["source"], source, request["time"], request["guides"]), out)
    except Refused as exc:
        result = {"refused": str(exc)}
    except MemoryError:
        result = {"refused": f"{source}: usd-core needed more than {cap / 2**30:.1f} GiB"
                  " reading it; is it a valid USD file?"}  # fmt: skip
    except USD_ERRORS as exc:
        result = {"refused": f"{source}: usd-core could not read it ({usd_error(exc)});"
                  " is it a valid USD file?"}  # fmt: skip
    tmp = out / "result.json.tmp"
    tmp.write_text(json.dumps(result))
    os.replace(tmp, out / "result.json")


def _child(request: dict) -> None:
    """In the forked child: output to ``OUT/stderr.txt``, default signals, then read;
    never returns."""
    log = os.open(Path(request["out"], "stderr.txt"), os.O_WRONLY | os.O_CREAT, 0o600)
    os.dup2(log, 1)
    os.dup2(log, 2)
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    code = 1
    try:
        _read_request(request)
        code = 0
    except BaseException:  # noqa: BLE001 - the child reports every failure, then exits
        traceback.print_exc()
    finally:
        sys.stdout.flush()
        os._exit(code)


def _wait(pid: int, seconds: float) -> dict:
    """Wait up to ``seconds`` for child ``pid`` (then kill it): its exit code (negative:
    the signal that ended it) and whether it ran out of time."""
    fd = os.pidfd_open(pid)
    try:
        ready, _, _ = select.select([fd], [], [], seconds)
    finally:
        os.close(fd)
    if not ready:
        os.kill(pid, signal.SIGKILL)
    _, status = os.waitpid(pid, 0)
    return {"code": os.waitstatus_to_exitcode(status), "timed_out": not ready}


def serve() -> None:
    """The reading server: one JSON request a line on stdin (``source``, ``out``,
    ``time``, ``guides``, ``memory``, ``seconds``), each read in a child forked from
    this single-threaded process (pxr already imported and its plugins loaded, so a
    read starts in milliseconds); one ``@@``-prefixed JSON reply a line on stdout.
    Ends when stdin closes (its parent is gone)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    Usd.SchemaRegistry()  # loads the plugins once, before any fork
    for line in sys.stdin:
        request = json.loads(line)
        pid = os.fork()
        if pid == 0:
            _child(request)
        sys.stdout.write("@@" + json.dumps(_wait(pid, request["seconds"])) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    serve()
