"""RenderMan render-time hair: a RIB of ``Procedural "RunProgram"`` calls, one per voxel,
and the ``follicle-procedural`` program that grows each voxel's hair when the renderer
asks (Šik 2012 §2.3.2–2.3.5).

:func:`export_rib` grows the whole groom once, chunk by chunk, to bound every voxel's
hair exactly: each Catmull-Rom hair (end vertices doubled, as the RIB writes it) as
cubic Bézier segments (Šik 2012 §2.2.8), whose control points' box holds the curve, padded
by half the voxel's widest width. The RIB holds no geometry, only the boxes and the
frame file's name (:mod:`follicle.io.procedural_data`).

The program speaks RenderMan's RunProgram protocol: it reads a request line
``<detail> <frame file> <voxel>`` from stdin, writes the voxel's hair as RIB (the
``Curves`` of :mod:`follicle.io.rib`) and the byte 0xFF to stdout, until EOF. A bad
request or data file gets a ``# follicle-procedural: <error>`` comment instead (also on
stderr), never a crash. The last frame's groom and roots stay loaded between requests.
"""

from __future__ import annotations

import io
import os
import re
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, TextIO

import numpy as np

from .. import spline
from ..atomic import atomic_path
from ..curves import HairCurves
from ..errors import FollicleError, FormatError, InputError
from ..groom.generator import CHUNK, Groom
from ..inputs import base_folder
from ..io.procedural_data import FrameData, VoxelGrid
from ..io.rib import write_block
from ..mesh.skin import SkinMesh
from ..pipeline import groom_scene
from ..scene import Scene, scene_from_toml, scene_to_toml
from ..validate import number

__all__ = [
    "export_rib",
    "Export",
    "Procedural",
    "Request",
    "frame_scene",
    "parse_request",
    "serve",
    "main",
]

PROGRAM = "follicle-procedural"
_SEGMENTS = 1 << 18  # Bézier segments converted at a time (24 MB)
_MAX_LINE = 1 << 16  # longest request line read whole
_ROUNDING = 1e-6  # the %.7g RIB numbers are within 0.5 ppm of the float32 values
_REQUEST = re.compile(
    r"(?P<detail>[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|[+]?inf)"
    r" (?P<frame>[^\x00-\x1f\x7f]+) (?P<voxel>[0-9]{1,9})"
)


# ------------------------------------------------------------------ roots by voxel
@dataclass
class _Roots:
    """Every root of a groom sorted by voxel, by id within one; voxel v's roots are
    rows ``starts[v]`` … ``starts[v + 1]``."""

    ids: np.ndarray
    triangles: np.ndarray
    bary: np.ndarray
    starts: np.ndarray


def _sorted_roots(groom: Groom, triangle_voxels: np.ndarray, size: int) -> _Roots:
    n = groom.params.count
    tri = np.empty(n, np.int32)
    bary = np.empty((n, 2), np.float32)
    for a in range(0, n, CHUNK):
        tri[a : a + CHUNK], bary[a : a + CHUNK] = groom.roots(min(CHUNK, n - a), a)
    voxel = triangle_voxels[tri]
    ids = np.argsort(voxel, kind="stable")
    starts = np.zeros(size + 1, np.int64)
    np.cumsum(np.bincount(voxel, minlength=size), out=starts[1:])
    return _Roots(ids, tri[ids], bary[ids], starts)


# ------------------------------------------------------------------ export
def _hulls(curves: HairCurves) -> tuple[np.ndarray, np.ndarray]:
    """Per curve (C, 3) low and high corners of its Bézier control points."""
    lo, hi = np.empty((curves.curve_count, 3)), np.empty((curves.curve_count, 3))
    offs = curves.offsets
    step = max(1, _SEGMENTS // max(1, int(curves.counts.max(initial=1))))
    for a in range(0, curves.curve_count, step):
        b = min(curves.curve_count, a + step)
        part = offs[a : b + 1] - offs[a]
        bezier = spline.to_bezier(curves.points[offs[a] : offs[b]], part)  # (segments, 4, 3)
        first = part[:-1] - np.arange(b - a)  # each curve's first segment
        lo[a:b] = np.minimum.reduceat(bezier.min(axis=1), first)
        hi[a:b] = np.maximum.reduceat(bezier.max(axis=1), first)
    return lo, hi


@dataclass
class Export:
    """What :func:`export_rib` wrote: per voxel with hair its index, roots, the sampler's
    expected roots (count × P(voxel's triangles)), curves and box (2, 3)."""

    rib: Path
    frame: Path
    grid: VoxelGrid
    voxels: list[int]
    roots: list[int]
    expected: list[float]
    curves: list[int]
    boxes: np.ndarray


def _voxel_boxes(
    groom: Groom,
    triangle_voxels: np.ndarray,
    size: int,
    time: float,
    progress: Callable[[int, int], None] | None,
    pose: SkinMesh | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Each voxel's curve count (V,) and box (V, 2, 3) of its hair on ``pose`` as the
    RIB draws it (infinite where it has none)."""
    count = groom.params.count
    lo, hi = np.full((size, 3), np.inf), np.full((size, 3), -np.inf)
    width = np.zeros(size)
    curves = np.zeros(size, np.int64)
    for done, chunk in enumerate(groom.chunks(CHUNK, time=time, pose=pose), 1):
        if chunk.curve_count:
            voxel = triangle_voxels[chunk.curve_data["root_triangle"]]
            c_lo, c_hi = _hulls(chunk)
            np.minimum.at(lo, voxel, c_lo)
            np.maximum.at(hi, voxel, c_hi)
            widest = np.maximum.reduceat(chunk.point_data["width"], chunk.offsets[:-1])
            np.maximum.at(width, voxel, widest)
            curves += np.bincount(voxel, minlength=size)
        if progress is not None:
            progress(min(done * CHUNK, count), count)
    # the curve's tube reaches half its width out; the printed numbers may round outwards
    filled = curves > 0
    pad = 0.5 * width[filled, None] * (1 + _ROUNDING)
    pad = pad + _ROUNDING * np.maximum(abs(lo[filled]), abs(hi[filled]))
    lo[filled] -= pad
    hi[filled] += pad
    return curves, np.stack([lo, hi], axis=1)


def _rib_string(text: str, what: str) -> str:
    if re.search(r'["\\\x00-\x1f\x7f]', text):
        raise InputError(
            f"{what} {text!r}: a RIB string here cannot hold quotes, backslashes"
            " or control characters; choose another path"
        )
    return text


def export_rib(
    scene: Scene,
    path: str | os.PathLike[str],
    voxels: int = 8,
    pose: np.ndarray | None = None,
    time: float = 0.0,
    progress: Callable[[int, int], None] | None = None,
) -> Export:
    """Write ``path`` (a RIB of one RunProgram procedural per voxel with hair) and its frame
    file beside it (``path`` with suffix ``.follicle.z``), both or neither.

    ``voxels`` cells span the rest mesh's longest side; ``pose`` (V, 3) poses the mesh
    (default: the rest pose) and ``time`` drives animated frizz.
    """
    VoxelGrid.check(voxels)  # before the slow part
    time = number(time, "time", unit="s")
    rib_path = Path(path)
    frame_path = rib_path.with_suffix(".follicle.z")
    datablock = _rib_string(str(frame_path.resolve()), "frame file")
    toml = scene_to_toml(scene, comments=False)
    groom = groom_scene(scene)
    grid = VoxelGrid.over(groom.mesh, voxels)
    skin = None if pose is None else groom.mesh.posed(vertices=pose)
    tri_voxels = grid.triangle_voxels(groom.mesh)
    count = groom.params.count
    roots = np.zeros(grid.size, np.int64)
    for a in range(0, count, CHUNK):
        triangles = groom.roots(min(CHUNK, count - a), a)[0]
        roots += np.bincount(tri_voxels[triangles], minlength=grid.size)
    curves, boxes = _voxel_boxes(groom, tri_voxels, grid.size, time, progress, skin)
    filled = np.flatnonzero(curves)
    expected = [count * groom.sampler.region_probability(tri_voxels == v) for v in filled]
    frame = FrameData(
        toml,
        scene.base_dir if isinstance(scene.base_dir, str) else str(scene.base_dir.resolve()),
        time,
        grid,
        {int(v): int(roots[v]) for v in np.flatnonzero(roots)},
        None if skin is None else skin.vertices,
    )
    lines = [
        "##RenderMan RIB",
        "version 3.04",
        f"# follicle {count:,} hairs: {len(filled)} voxels with hair of a"
        f" {'×'.join(map(str, grid.dims))} grid (cells {grid.cell:.6g} wide) over the rest mesh,"
        f" grown at render time by {PROGRAM} from {frame_path.name}",
    ]
    for v, expect in zip(filled, expected, strict=True):
        box = " ".join(repr(float(x)) for x in boxes[v].T.reshape(-1))
        lines.append(
            f"# voxel {v} {grid.cell_of(int(v))}: {roots[v]} hairs (count × P(voxel) ="
            f" {expect:.1f}), {curves[v]} curves"
        )
        lines.append(f'Procedural "RunProgram" ["{PROGRAM}" "{datablock} {v}"] [{box}]')
    with atomic_path(rib_path) as rib_tmp, atomic_path(frame_path) as frame_tmp:
        frame_tmp.write_bytes(frame.to_bytes())  # renamed first, then the RIB
        rib_tmp.write_bytes(("\n".join(lines) + "\n").encode())
    return Export(
        rib_path,
        frame_path,
        grid,
        filled.tolist(),
        roots[filled].tolist(),
        expected,
        curves[filled].tolist(),
        boxes[filled],
    )


# ------------------------------------------------------------------ render time
def frame_scene(frame: FrameData, source: str = "frame file") -> Scene:
    """The scene a frame file stores, its relative paths resolved against its
    ``base_dir``; ConfigError naming ``source: stored scene`` if it does not parse."""
    return scene_from_toml(frame.scene_toml, f"{source}: stored scene", base_folder(frame.base_dir))


class _Frame:
    """A frame file ready to grow: its groom, the skin's pose and roots sorted by voxel."""

    def __init__(self, path: str) -> None:
        data = FrameData.load(path)
        self.groom = groom_scene(frame_scene(data, path))
        self.pose = None if data.pose is None else self.groom.mesh.posed(vertices=data.pose)
        self.time = data.time
        self.size = data.grid.size
        self.roots = _sorted_roots(
            self.groom, data.grid.triangle_voxels(self.groom.mesh), self.size
        )
        counts = np.diff(self.roots.starts)
        if {int(v): int(counts[v]) for v in np.flatnonzero(counts)} != data.roots:
            raise FormatError(
                f"{path}: the hair roots differ from the exported ones (the mesh"
                " or density map changed); export the RIB again"
            )

    def curves(self, voxel: int) -> Iterator[HairCurves]:
        """The hairs of ``voxel``, in id order, a chunk at a time."""
        if not 0 <= voxel < self.size:
            raise InputError(f"voxel {voxel}: the frame has voxels 0 … {self.size - 1}")
        r = self.roots
        for a in range(r.starts[voxel], r.starts[voxel + 1], CHUNK):
            b = min(a + CHUNK, r.starts[voxel + 1])
            yield self.groom.generate_at(
                r.triangles[a:b], r.bary[a:b], r.ids[a:b], self.time, pose=self.pose
            )

    def rib(self, voxel: int) -> bytes:
        chunks = list(self.curves(voxel))
        if not chunks:
            return f"# {PROGRAM}: voxel {voxel} has no hair\n".encode()
        out = io.BytesIO()
        write_block(out, chunks)
        return out.getvalue()


@dataclass(frozen=True)
class Request:
    """One RunProgram request: the pixel-area ``detail`` and the datablock's frame file and
    voxel."""

    detail: float
    frame: str
    voxel: int


def parse_request(line: bytes) -> Request:
    """``<detail> <frame file> <voxel>`` (one line, UTF-8, the newline optional); InputError
    on anything else."""
    text = line.removesuffix(b"\n").removesuffix(b"\r").decode("utf-8", errors="replace")
    match = _REQUEST.fullmatch(text)
    if match is None or "\ufffd" in text:
        raise InputError(
            f"malformed request {text[:200]!r}; expected '<detail> <frame file> <voxel>'"
        )
    return Request(float(match["detail"]), match["frame"], int(match["voxel"]))


class Procedural:
    """Answers requests with RIB; keeps the last frame file loaded (reloaded if it changes)."""

    def __init__(self) -> None:
        self._key: tuple | None = None
        self._frame: _Frame | None = None

    def frame(self, path: str) -> _Frame:
        try:
            stat = os.stat(path)
        except OSError as exc:
            raise FormatError(f"{path}: cannot read the frame file ({exc.strerror})") from None
        key = (os.path.abspath(path), stat.st_mtime_ns, stat.st_size)
        if key != self._key or self._frame is None:
            self._key, self._frame = None, None  # let the old frame go first
            self._frame, self._key = _Frame(path), key
        return self._frame

    def reply(self, line: bytes | None, errors: TextIO | None = None) -> bytes:
        """The RIB answering request ``line`` (None: one too long to read; without the
        0xFF); an error becomes a RIB comment, and a line on ``errors``."""
        try:
            if line is None:
                raise InputError(f"request longer than {_MAX_LINE} bytes")
            request = parse_request(line)
            return self.frame(request.frame).rib(request.voxel)
        except Exception as exc:  # the renderer waits for an answer to every request
            what = str(exc) if isinstance(exc, FollicleError) else f"{type(exc).__name__}: {exc}"
            what = re.sub(r"[\x00-\x1f\x7f]+", " ", what)
            if errors is not None:
                print(f"{PROGRAM}: {what}", file=errors, flush=True)
            return f"# {PROGRAM}: {what}\n".encode()


def _lines(stream: BinaryIO) -> Iterator[bytes | None]:
    """Request lines; one longer than _MAX_LINE is read to its end and given as None."""
    while line := stream.readline(_MAX_LINE + 1):
        if len(line) > _MAX_LINE and not line.endswith(b"\n"):
            while (rest := stream.readline(_MAX_LINE)) and not rest.endswith(b"\n"):
                pass
            yield None
        else:
            yield line


def serve(requests: BinaryIO, out: BinaryIO, errors: TextIO | None = None) -> None:
    """The RunProgram loop: every request line of ``requests`` gets its RIB and 0xFF."""
    procedural = Procedural()
    for line in _lines(requests):
        out.write(procedural.reply(line, errors) + b"\xff")
        out.flush()


_HELP = f"""usage: {PROGRAM}

Serve RenderMan RunProgram requests: read '<detail> <frame file> <voxel>' lines on
stdin and write each voxel's hair as RIB, then the byte 0xFF, on stdout, until EOF.
The renderer runs it for the RIB that `follicle export-rib` writes (docs: Formats ›
Render-time procedural; `follicle docs` says where the docs are).

Example (voxel 84 of `follicle export-rib examples/wavy.toml -o wavy.rib`):
  printf '100 wavy.follicle.z 84\\n' | {PROGRAM} > voxel84.rib
"""


def main(argv: list[str] | None = None) -> None:
    """``follicle-procedural``: serve RunProgram requests on stdin and stdout. The renderer
    gives it no arguments; ``--help`` says what it does, any other argument is refused
    (exit 2) rather than left waiting on stdin."""
    args = sys.argv[1:] if argv is None else argv
    if args in (["-h"], ["--help"]):
        sys.stdout.write(_HELP)
        return
    if args:
        sys.stderr.write(f"{PROGRAM}: takes no arguments (got {args[0]!r}); see {PROGRAM} --help\n")
        raise SystemExit(2)
    serve(sys.stdin.buffer, sys.stdout.buffer, sys.stderr)


if __name__ == "__main__":
    main()
