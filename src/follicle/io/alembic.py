"""Alembic hair: ``OCurves`` written and read with alembic3d (PyAlembic's API, Ogawa).

Writing: the archive's top object holds the Xform ``/Groom`` (identity); under it each
shape sits in an identity Xform of its own (Maya's transform-over-shape layout, which
Blender folds into one object named after the Xform): the hair as one ``OCurves`` per
chunk of the stream, ``Hair_0000/Hair_0000Shape``, ``Hair_0001/Hair_0001Shape``, …
(always, even for a single chunk), the optional guides as ``Guides/GuidesShape`` and the
optional skin as the ``OPolyMesh`` ``Skin/SkinShape`` (its rest pose, triangles, UVs as
the indexed faceVarying ``uv``; in an animation with head motion
``/Groom/Head/Skin/SkinShape``, under the Xform ``/Groom/Head`` sampled per frame).

The curves are ``kLinear``, ``kNonPeriodic``, ``kNoBasis``: every stored vertex is a
point of the curve, so they read back bit for bit; Blender imports them as poly hair
curves with exactly these points (Cycles renders curves through their points as
Catmull-Rom splines, the curve follicle means), Houdini as polylines and Unreal's groom
importer as its strands. A Catmull-Rom basis would need phantom end vertices (Alembic,
like RenderMan, has no pinned wrap), which Blender reads as two extra points a curve.
Alembic declares no units and no up axis: follicle writes metres, +Y up. Attributes:

- ``P``, ``nVertices`` and ``.selfBnds`` (the vertices' bounds padded by half the
  widest width);
- ``width``, vertex scope: diameters in metres, as Alembic inherits RenderMan's width
  and as Houdini (``width``) and Blender's exporter (2 × radius) write it (Blender's
  importer in its 3.x-4.x sources read it as the radius: hair twice as thick there);
- ``N`` (``normal``), vertex scope (``normals=False`` leaves them out: renderers then
  draw round tubes rather than ribbons facing them);
- ``uv``, uniform scope: ``curve_data['root_uv']``; vertex scope when the curves have
  ``point_data['uv']`` and no ``root_uv`` (the unity target: the root's UV on each of its
  vertices, as Unity's importer sizes UVs per vertex);
- arbGeomParams: ``color`` C3f (so are a target's ``Cd`` and ``groom_color``) and
  ``opacity`` float, vertex scope, and every other ``point_data`` array (vertex scope)
  and ``curve_data`` array (uniform scope) under its own name: floats of 1-3 components
  (float32 as float, V2f, V3f; float64 as double, V2d, V3d; float16 widened), integers
  of 1-3 components as int32 (int32, V2i, V3i: int64 ids such as ``hair_id`` are
  written so when every value fits, and skipped with a warning otherwise), bool and
  uint8 as uchar. Others (4 components, strings) are skipped with a warning.

A ``target`` (:mod:`follicle.io.targets`) renames and types the attributes for the tool
that opens the file and, Alembic declaring no units, scales to its units (Unreal:
centimetres, guides flagged ``groom_guide``, each curve's ``groom_group_id``, no skin
(its groom importer refuses a file with a mesh), and its groom schema's version,
``groom_version_major`` 1 and ``groom_version_minor`` 5, int16 scalar user properties
of the top Xform ``/Groom``, where Unreal's importer reads groom-wide values (and its
own exporter writes them); as arbGeomParams of a curves object it would take them for
the strands' attributes; Unity: one curves object per interpolation group, widths and
per-vertex UVs only, no guides).

alembic3d writes in a child process (:mod:`follicle.io.alembic_sink`), fed one object
at a time through a pipe: its C++ ends the process it runs in when a write fails (a
full disk, a file-size limit), so that failure ends the child and comes back as one
FormatError naming the output, with no temporary file left; the finished archive is
checked whole (:func:`follicle.io.alembic_guard.check_archive`) before it is renamed
into place. The stream is written with bounded memory: Ogawa writes each chunk's sample
when it is set, and the chunk is released (here and in the child) before the next. The
same curves give the same bytes (with the same alembic3d: the archive names the
library's version and build).

Reading takes every curves object of the archive (any type, basis and wrap; see
:func:`load_abc`) and the first mesh (:func:`load_abc_mesh`); alembic3d reads in a child
process under memory and time limits after cheap checks of the archive's structure
(:mod:`follicle.io.alembic_guard`, :mod:`follicle.io.alembic_archive`), so a hostile file
is one FormatError, never a crash.
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import os
import signal
import subprocess
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..curves import HairCurves
from ..errors import FileAccessError, FormatError, InputError
from ..inputs import input_file
from ..io.polymesh import scaled_skin, skin_from_part
from ..mesh.skin import SkinMesh
from ..validate import number
from . import guard_server
from .alembic_archive import COLOR_NAMES, GROOM_VERSION_KEYS
from .alembic_guard import check_archive, read_curves, read_mesh
from .alembic_sink import send
from .animation import Animation, target_guides, with_groups
from .attributes import column
from .cache_writer import cache_writer
from .curve_bounds import vertex_bounds
from .guard import curves_from_parts
from .stream import Curves, as_chunks
from .targets import Target, for_target, get_target

__all__ = [
    "save_abc",
    "save_abc_cache",
    "load_abc",
    "abc_parts",
    "load_abc_mesh",
    "GROOM",
    "GUIDES",
    "SKIN",
    "HEAD",
]

log = logging.getLogger("follicle")

GROOM, GUIDES, SKIN, HEAD = "/Groom", "/Groom/Guides", "/Groom/Skin", "/Groom/Head"
GROOM_VERSION = (1, 5)  # Unreal's Alembic groom schema: /Groom's user properties
_INT32 = np.iinfo(np.int32)
# (dtype, components) -> the geometry parameter kind the writer makes of it
_KINDS = {
    ("f4", 1): "float",
    ("f4", 2): "v2f",
    ("f4", 3): "v3f",
    ("f8", 1): "double",
    ("f8", 2): "v2d",
    ("f8", 3): "v3d",
    ("i4", 1): "int",
    ("i4", 2): "v2i",
    ("i4", 3): "v3i",
    ("u1", 1): "uchar",
}


# ------------------------------------------------------------------ values
def _as_stored(arr: np.ndarray) -> np.ndarray | None:
    """``arr`` (rows of 1-3 components) in a dtype :data:`_KINDS` has, or None."""
    if arr.ndim not in (1, 2) or arr.ndim == 2 and not 1 <= arr.shape[1] <= 3:
        return None
    if arr.dtype == np.float16:
        return arr.astype(np.float32)
    if arr.dtype in (np.bool_, np.uint8):
        return arr.astype(np.uint8) if arr.ndim == 1 else None
    if arr.dtype.kind in "iu":
        fits = not arr.size or _INT32.min <= int(arr.min()) and int(arr.max()) <= _INT32.max
        return arr.astype(np.int32) if fits else None
    return arr if arr.dtype.kind == "f" and arr.dtype.itemsize in (4, 8) else None


def _bounds(points: np.ndarray, width: np.ndarray | None) -> np.ndarray:
    """(2, 3) the vertices' bounds (linear curves lie in them) padded by half the widest
    width."""
    if not len(points):
        return np.zeros((2, 3))
    pad = 0.5 * float(width.max()) if width is not None and width.size else 0.0
    lo, hi = vertex_bounds(points) if points.dtype == np.float32 else (points.min(0), points.max(0))
    return np.stack([lo - pad, hi + pad]).astype(np.float64)


def _curves_arrays(
    curves: HairCurves, normals: bool
) -> tuple[list[list[str]], dict[str, np.ndarray]]:
    """(params, arrays) of a ``curves`` operation: points, counts, bounds, widths,
    normals, uv and every other attribute as an arbGeomParam (warning of those that
    have no Alembic type)."""
    width = column(curves, "width", 1)
    arrays = {
        "points": curves.points,
        "counts": curves.counts.astype(np.int32),
        "bounds": _bounds(curves.points, width),
    }
    for key, value in (
        ("width", width),
        ("normal", column(curves, "normal", 3) if normals else None),
    ):
        if value is not None:
            arrays[key] = value
    uv = curves.curve_data.get("root_uv")
    if uv is not None:
        if uv.shape != (curves.curve_count, 2):
            raise InputError(
                f"curve_data['root_uv']: expected shape ({curves.curve_count}, 2), got {uv.shape}"
            )
        arrays["uv"] = uv.astype(np.float32)
    vertex_uv = curves.point_data.get("uv")
    if uv is None and vertex_uv is not None and vertex_uv.shape == (curves.point_count, 2):
        arrays["uv"] = vertex_uv.astype(np.float32)  # vertex scope (a target's, Unity's)
    else:
        vertex_uv = None
    params: list[list[str]] = []  # [name, kind, scope] of each arbGeomParam
    pd = curves.point_data
    for data, scope in ((pd, "Vertex"), (curves.curve_data, "Uniform")):
        for name, arr in sorted(data.items()):
            if name in (("width", "normal") if data is pd else ("root_uv",)) or (
                data is pd and name == "uv" and vertex_uv is not None
            ):
                continue
            if (
                data is pd
                and name.lower() in COLOR_NAMES
                and arr.dtype.kind == "f"
                and arr.shape == (curves.point_count, 3)
            ):  # color, or a target's Cd, …
                arrays[f"param{len(params)}"] = arr.astype(np.float32)
                params.append([name, "c3f", scope])
                continue
            stored = _as_stored(arr)
            if stored is None or name.startswith("."):  # names with a dot are Alembic's own
                log.warning(
                    "Alembic: %s '%s' (%s %s) not written: no Alembic type for it,"
                    " integers beyond int32, or a name starting with '.'",
                    "point_data" if data is pd else "curve_data",
                    name,
                    arr.dtype,
                    arr.shape,
                )
                continue
            kind = _KINDS[(stored.dtype.str[1:], 1 if stored.ndim == 1 else stored.shape[1])]
            arrays[f"param{len(params)}"] = stored
            params.append([name, kind, scope])
    return params, arrays


def _mesh_arrays(mesh: object, scale: float) -> dict[str, np.ndarray]:
    """The rest pose of a SkinMesh, times ``scale`` (a target's units per metre):
    triangles wound clockwise, as Alembic keeps polygons, and its per-vertex UVs as the
    indexed, faceVarying ``uv`` every importer reads."""
    if not isinstance(mesh, SkinMesh):
        raise InputError(
            f"mesh: expected a SkinMesh (the skin to write beside the hair), got"
            f" {type(mesh).__name__}"
        )
    corners = np.ascontiguousarray(mesh.faces[:, ::-1], dtype=np.int32).reshape(-1)
    arrays = {
        "points": (mesh.rest_vertices * scale).astype(np.float32),
        "indices": corners,
        "counts": np.full(mesh.face_count, 3, np.int32),
    }
    if mesh.uvs is not None:
        arrays["uv"] = np.asarray(mesh.uvs, dtype=np.float32)
        arrays["uv_index"] = corners
    return arrays


# ------------------------------------------------------------------ writing
class _Sink:
    """alembic3d writing archives in a child process (:mod:`follicle.io.alembic_sink`),
    fed one operation at a time. A failed write in its C++ ends the child and comes
    back as one FormatError naming the output; the child is kept for the next archive
    after one it finished (its start, importing alembic3d, takes half a second), and
    ended after anything else."""

    _idle: _Sink | None = None  # the child between archives
    _lock = threading.Lock()

    def __init__(self) -> None:
        self.stderr = tempfile.TemporaryFile()
        self.proc = subprocess.Popen(
            guard_server.command("abc-sink"),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.stderr,
        )
        stdin, stdout = self.proc.stdin, self.proc.stdout
        # stdin=PIPE and stdout=PIPE with Popen's default buffering: buffered binary files
        assert isinstance(stdin, io.BufferedWriter) and isinstance(stdout, io.BufferedReader)
        self.stdin, self.stdout = stdin, stdout
        self.target = Path()

    @classmethod
    @contextlib.contextmanager
    def writing(cls, target: Path, tmp: Path) -> Iterator[_Sink]:
        """A sink with the archive ``tmp`` open; it is finished when the block ends
        (FormatError naming ``target`` unless the child says so), the child ended if
        the block raises."""
        with cls._lock:
            sink, cls._idle = cls._idle, None
        if sink is None or sink.proc.poll() is not None:
            sink = cls()
        sink.target = target
        try:
            sink.send({"op": "open", "path": str(tmp)})
            yield sink
            sink.send({"op": "close"})
            reply = sink.stdout.readline()
            if reply.strip() != b'{"ok": true}':
                raise sink._failed(reply)
        except BaseException:
            sink.kill()
            raise
        with cls._lock:
            if cls._idle is None:
                cls._idle, sink = sink, None
        if sink is not None:
            sink.kill()

    def send(self, op: dict, arrays: dict[str, np.ndarray] | None = None) -> None:
        try:
            send(self.stdin, op, arrays)
            self.stdin.flush()
        except OSError:  # the child has ended: it says why
            raise self._failed() from None

    def _failed(self, reply: bytes | None = None) -> FormatError:
        """The child's reason for stopping (its ``reply``, read here if not given), as
        one FormatError."""
        with contextlib.suppress(OSError):
            self.stdin.close()
        code = self.proc.wait()
        line = self.stdout.readline() if reply is None else reply
        why = None
        with contextlib.suppress(ValueError, AttributeError):  # a line cut short by a crash
            why = json.loads(line).get("error")
        if why:  # alembic3d's message: the innermost of its nested ones
            why = f"a write failed: {why.rsplit('EXCEPTION: ', 1)[-1]}"
        else:
            self.stderr.seek(0)
            text = self.stderr.read().decode(errors="replace").split()
            how = f"crashed with {signal.Signals(-code).name}" if code < 0 else f"exit {code}"
            why = f"its writer process {how}: {' '.join(text)[-200:] or 'no output'}"
        return FileAccessError(
            f"{self.target}: could not write it ({why}); free disk space or write elsewhere"
        )

    def kill(self) -> None:
        self.proc.kill()
        self.proc.wait()
        for stream in (self.stdin, self.stdout, self.stderr):
            with contextlib.suppress(OSError):
                stream.close()


def _write(target: Path, fill: Callable[[_Sink], None], groom_schema: bool = False) -> None:
    """An archive at ``target``, written atomically by a sink that ``fill`` feeds, then
    checked whole (Ogawa's streams do not always report a failed write: a full disk
    can leave a file without its root group or its finished flag). With
    ``groom_schema``, ``/Groom`` carries Unreal's groom schema version."""
    version = dict(zip(GROOM_VERSION_KEYS, GROOM_VERSION, strict=True)) if groom_schema else {}
    with atomic_path(target) as tmp:
        with _Sink.writing(target, tmp) as sink:
            sink.send({"op": "xform", "path": GROOM, "user": version})
            fill(sink)
        try:
            check_archive(tmp)
        except FormatError:
            raise FormatError(
                f"{target}: could not write it (the archive came out"
                " incomplete); free disk space or write elsewhere"
            ) from None


def _check_suffix(path: str | os.PathLike[str]) -> Path:
    target = Path(path)
    if target.suffix.lower() != ".abc":
        raise FormatError(f"{target}: an Alembic file must end in .abc")
    return target


def _shape(sink: _Sink, path: str) -> str:
    """Send the (identity) Xform ``path`` and return the path of the
    shape it holds, ``path/<name>Shape``: Maya's layout, a transform over each shape,
    which Blender's importer folds into one object named after the transform (shapes
    sharing one Xform all came in named after it: "Groom", "Groom.001", …)."""
    sink.send({"op": "xform", "path": path})
    return f"{path}/{path.rpartition('/')[2]}Shape"


def _send_curves(sink: _Sink, path: str, curves: HairCurves, normals: bool) -> None:
    params, arrays = _curves_arrays(curves, normals)
    sink.send({"op": "curves", "path": path, "params": params, "keep": False}, arrays)


def _by_group(curves: Curves) -> Iterator[HairCurves]:
    """The hair of every chunk gathered by ``curve_data['group']`` (its interpolation
    group; all in one without it), groups in increasing order: Unity's hair package
    makes a strand group of each curves object it finds (com.unity.demoteam.hair,
    Editor/HairAssetBuilder.cs, BuildHairAssetAlembic), so one per chunk would split a
    groom at every 32,768 hairs. The groom is held whole (a real-time groom is small)."""
    whole = HairCurves.concatenate(list(as_chunks(curves)))
    group = whole.curve_data.get("group")
    if group is None:
        yield whole
        return
    for g in np.unique(group):
        yield whole[np.flatnonzero(group == g)]


def save_abc(
    curves: Curves,
    path: str | os.PathLike[str],
    guides: HairCurves | None = None,
    mesh: SkinMesh | None = None,
    normals: bool = True,
    target: Target | str = "generic",
) -> Path:
    """Write ``curves`` (HairCurves or a stream of chunks) as linear OCurves, one object
    per chunk under ``/Groom`` (``Hair_0000/Hair_0000Shape``, …), ``guides`` (HairCurves
    or Guides) as ``/Groom/Guides/GuidesShape`` and the skin ``mesh`` (a SkinMesh, at
    rest) as the OPolyMesh ``/Groom/Skin/SkinShape``; atomically. See the module for
    the layout and attributes.

    ``target`` (see :mod:`follicle.io.targets`) names and types the attributes for the
    tool that opens the file and, Alembic declaring no units, writes points, widths and
    the skin in its units (Unreal: centimetres, guides flagged ``groom_guide = 1``, and
    the groom schema's version on ``/Groom``; no skin, which would make its groom
    importer refuse the file). For Unity the hair is one curves object per
    interpolation group (``curve_data['group']``), the root UVs per vertex, and no
    guides (its hair package would take them for hair)."""
    out = _check_suffix(path)
    tool = get_target(target)
    guide_curves = target_guides(guides, tool) if tool.guides else None
    if guides is not None and not tool.guides:
        log.info("%s: guides left out: %s would take them for hair", out, tool.reads)
    if mesh is not None and not tool.alembic_mesh:
        log.info("%s: skin left out: %s refuses an Alembic file with a mesh", out, tool.tool)
        mesh = None
    skin = None if mesh is None else _mesh_arrays(mesh, tool.scale)
    grouped = (with_groups(chunk, guides, tool) for chunk in as_chunks(curves))
    if tool.vertex_uv:  # Unity: one curves object (one strand group) per group
        chunks: Iterator[HairCurves] = (for_target(g, tool) for g in _by_group(grouped))
    else:
        chunks = (for_target(chunk, tool) for chunk in grouped)

    def fill(sink: _Sink) -> None:
        if skin is not None:
            sink.send({"op": "mesh", "path": _shape(sink, SKIN)}, skin)
        if guide_curves is not None:
            _send_curves(sink, _shape(sink, GUIDES), guide_curves, normals)
        for i, chunk in enumerate(chunks):
            _send_curves(sink, _shape(sink, f"{GROOM}/Hair_{i:04d}"), chunk, normals)

    _write(out, fill, tool.groom_schema)
    return out


# ------------------------------------------------------------------ animation cache
def _velocities(frame: HairCurves, later: HairCurves, fps: float) -> np.ndarray:
    """Per-vertex velocities, metres per second, from ``frame`` to the frame after it."""
    return ((later.points.astype(np.float64) - frame.points) * fps).astype(np.float32)


def _send_frame(
    sink: _Sink,
    path: str,
    frame: HairCurves,
    first: HairCurves,
    velocities: np.ndarray,
    timing: dict | None,
) -> None:
    """Frame 0 (``timing`` given) with everything: topology, widths, uv and
    arbGeomParams stay as it has them; later frames with points, velocities, bounds and
    normals."""
    arrays = {
        "points": frame.points,
        "velocities": velocities,
        "bounds": _bounds(frame.points, column(first, "width", 1)),
    }
    normal = column(frame, "normal", 3) if "normal" in first.point_data else None
    if normal is not None:  # a frame without them keeps the last (as in USD's writer)
        arrays["normal"] = normal
    if timing is None:
        sink.send({"op": "sample", "path": path}, arrays)
        return
    params, everything = _curves_arrays(frame, True)
    sink.send(
        {"op": "curves", "path": path, "params": params, "keep": True, **timing},
        {**everything, **arrays},
    )


def _send_cache(sink: _Sink, anim: Animation, skin: dict[str, np.ndarray] | None) -> None:
    """The animation's operations: the head Xform's samples, the skin, then the curves
    at frame 0 and one sample per later frame, each sent once the next frame gives its
    velocities (the last frame keeps the velocities into it; a single frame has none)."""
    timing = {"fps": anim.fps, "start": anim.start / anim.fps}
    if anim.head is not None:
        sink.send({"op": "xform", "path": HEAD, **timing})
        for m in anim.head:  # a SimCache's matrices act on columns, Alembic's on rows
            sink.send({"op": "matrix", "path": HEAD}, {"matrix": m.T})
    if skin is not None and anim.skin is not None:  # a deforming skin: P sampled per frame
        where = _shape(sink, SKIN)
        sink.send({"op": "mesh", "path": where, **timing}, {**skin, "points": anim.skin[0]})
        for points in anim.skin[1:]:
            sink.send({"op": "mesh_points", "path": where}, {"points": points})
    elif skin is not None:
        where = SKIN if anim.head is None else f"{HEAD}/Skin"
        sink.send({"op": "mesh", "path": _shape(sink, where)}, skin)
    path = _shape(sink, f"{GROOM}/Hair_0000")
    frames = enumerate(anim.frames, 1)
    count, first = next(frames)  # (the stream raises InputError when it is empty)
    previous = first
    velocities: np.ndarray | None = None
    for count, frame in frames:
        velocities = _velocities(previous, frame, anim.fps)
        _send_frame(sink, path, previous, first, velocities, timing if count == 2 else None)
        previous = frame
    if velocities is None:
        velocities = np.zeros_like(first.points)
    _send_frame(sink, path, previous, first, velocities, timing if count == 1 else None)


def _write_cache(out: Path, anim: Animation, mesh: SkinMesh | None, tool: Target) -> None:
    """The animation as one archive (see :func:`save_abc_cache`)."""
    if mesh is not None and not tool.alembic_mesh:
        log.info("%s: skin left out: %s refuses an Alembic file with a mesh", out, tool.tool)
        mesh = None
    skin = None if mesh is None else _mesh_arrays(mesh, tool.scale)
    _write(out, lambda sink: _send_cache(sink, anim, skin), tool.groom_schema)


save_abc_cache = cache_writer(
    "save_abc_cache",
    _check_suffix,
    _write_cache,
    in_units=True,
    doc="""Write an animation: frame ``f`` of ``frames`` is sample ``f`` of one OCurves
    ``/Groom/Hair_0000/Hair_0000Shape``, at ``(start + f) / fps`` seconds (a uniform
    time sampling), whose topology, widths, uv and arbGeomParams come from frame 0 and
    whose ``P``, ``.velocities`` (metres per second, from each frame to the next; the
    last frame keeps the one into it), bounds and normals are sampled per frame; as
    ``target`` reads them (see :func:`save_abc`; Unreal: centimetres, so are the head's
    motion and the velocities).
    """,
)


# ------------------------------------------------------------------ reading
def load_abc(
    path: str | os.PathLike[str],
    time: float | None = None,
    guides: bool = False,
    stored: bool = False,
) -> HairCurves:
    """Hair curves from every curves object of an Alembic archive, joined in archive
    order (depth first), each moved by the Xforms above it.

    Any type, basis and wrap: each curve becomes the points it passes through, as
    :func:`follicle.io.usd.load_usd` reads USD (:mod:`follicle.io.curve_basis`): linear
    curves and curves of no basis, every vertex; cubic Catmull-Rom, all but the two end
    vertices (Alembic's are nonperiodic, as RenderMan's); Bézier, every third; uniform
    B-spline, the curve at its knots; NURBS (variable order, or cubic B-splines with
    knots: orders, knots (also Maya's, without the outer two, or none: clamped uniform
    as Blender makes them) and position weights), the curve at its knots and evenly
    between them; Blender's variable-order Catmull-Rom curves, every vertex. Periodic
    curves are refused.

    ``width`` of any scope (constant, uniform, varying, vertex) comes back per point,
    as diameters (see the module); ``N`` as ``normal``; ``uv`` of uniform or constant
    scope as ``curve_data['root_uv']`` (per vertex: ``point_data['uv']``); the C3f or
    C4f arbGeomParam named color (or Cd, displayColor, groom_color, col, else the
    first) as ``color`` with a C4f's alpha as ``opacity`` (unless an ``opacity``
    parameter gives it); other numeric arbGeomParams of vertex or varying scope per
    point, uniform ones per curve (int32 widened to int64, follicle's id type; constant
    ones skipped). ``Groom/Guides`` is skipped unless it is the only curves object, or
    ``guides=True`` reads only it. ``time`` picks the sample nearest that many seconds
    (default: each object's first sample). Alembic declares no units: values are taken
    as metres (``follicle.load_curves(path, units="cm")`` converts).

    alembic3d reads the file in a child process under memory and time limits, after
    cheap checks of the archive's structure (see :mod:`follicle.io.alembic_guard`):
    anything wrong with the file, or alembic3d crashing on it, is a FormatError naming
    it. Widths whose median is over 5 mm (a tool's default radius, not hair) are kept
    but logged as a warning. ``stored`` keeps parameters as the file names and types
    them (only one named ``color`` taken as the colour): what `follicle check` reads.
    """
    source, parts = abc_parts(path, time, guides, stored)
    return curves_from_parts(parts, source, bool(stored))


def abc_parts(
    path: str | os.PathLike[str],
    time: float | None = None,
    guides: bool = False,
    stored: bool = False,
) -> tuple[Path, list[dict]]:
    """(the file, its chosen curves objects as dicts of arrays) as :func:`load_abc`
    reads and then joins them; ``stored`` parts also say whether Unreal's groom schema
    version is on the object or an Xform above it (``groom_schema``), for `follicle
    check`."""
    time = number(time, "time", unit="s", allow_none=True)
    source = input_file(path, "Alembic file (.abc)")
    check_archive(source)
    return source, read_curves(source, time, bool(guides), bool(stored))


def load_abc_mesh(path: str | os.PathLike[str], mpu: float = 1.0) -> SkinMesh:
    """The first PolyMesh (or SubD, as its control cage) of an Alembic archive, at its
    first sample, as a SkinMesh: moved by the Xforms above it, polygons (wound
    clockwise, as Alembic keeps them) fanned into counter-clockwise triangles, its
    ``uv`` of vertex or faceVarying scope as per-vertex UVs split at seams
    (:mod:`follicle.io.polymesh`), its vertices times ``mpu`` (metres per the file's
    unit: an archive declares none). Further meshes are named in a warning and not
    read. Read in a guarded child process like :func:`load_abc`."""
    source = input_file(path, "Alembic file (.abc)")
    check_archive(source)
    return scaled_skin(skin_from_part(read_mesh(source), source), mpu, source)
