"""What a RenderMan procedural needs to regrow one frame's hair: the voxel grid and the
frame file (Šik 2012 §2.3.3).

The grid is uniform over the rest mesh's bounds with cubic cells: ``voxels`` cells
along the longest side, as many as cover the other sides. A triangle belongs to the
cell holding its rest-pose barycentre, a hair to its root triangle's cell, so a hair
keeps its voxel however the mesh is posed.

The frame file is ``follicle-frame 1\\n`` and a zlib stream of one JSON line (the scene
as TOML text with the command line's overrides applied, the folder its relative paths
start in, the time, the grid and every voxel's root count) followed by the current
pose's vertices (little-endian float64, V × 3) when the mesh is posed. Hair ids are not
stored: the procedural resamples the roots, which is exact and cheap (docs: How-to › Formats ›
Render-time procedural).
"""

from __future__ import annotations

import json
import math
import os
import stat
import zlib
from dataclasses import dataclass

import numpy as np

from ..errors import FormatError
from ..mesh.skin import SkinMesh
from ..validate import file_path, number, whole

__all__ = ["VoxelGrid", "FrameData", "MAX_VOXELS"]

MAX_VOXELS = 256  # cells along the longest side
_MAGIC = b"follicle-frame 1\n"
_LIMIT = 1 << 30  # bytes a frame file may hold or inflate to


@dataclass(frozen=True)
class VoxelGrid:
    """Cubic cells of side ``cell`` from ``origin``, ``dims`` = (nx, ny, nz) of them;
    cell (i, j, k) has index (i·ny + j)·nz + k."""

    origin: tuple[float, float, float]
    cell: float
    dims: tuple[int, int, int]

    @staticmethod
    def check(voxels: object) -> int:
        """``voxels`` as cells along the longest side; InputError unless a whole number in
        1 … MAX_VOXELS."""
        return whole(voxels, "voxels", 1, MAX_VOXELS)

    @classmethod
    def over(cls, mesh: SkinMesh, voxels: int) -> VoxelGrid:
        """The grid of ``voxels`` cells along the longest side of ``mesh``'s rest bounds."""
        voxels = cls.check(voxels)
        lo, hi = mesh.bounds("rest")
        cell = float((hi - lo).max()) / voxels
        nx, ny, nz = (min(voxels, max(1, math.ceil(float(e) / cell))) for e in hi - lo)
        return cls((float(lo[0]), float(lo[1]), float(lo[2])), cell, (nx, ny, nz))

    @property
    def size(self) -> int:
        return int(np.prod(self.dims))

    def cell_of(self, index: int) -> tuple[int, int, int]:
        """(i, j, k) of cell ``index``."""
        i, j, k = np.unravel_index(index, self.dims)
        return int(i), int(j), int(k)

    def triangle_voxels(self, mesh: SkinMesh) -> np.ndarray:
        """The cell of every triangle's rest-pose barycentre, int64 (F,)."""
        centres = mesh.rest_vertices[mesh.faces].mean(axis=1)
        ijk = np.floor((centres - np.asarray(self.origin)) / self.cell).astype(np.int64)
        np.clip(ijk, 0, np.asarray(self.dims) - 1, out=ijk)
        return np.ravel_multi_index(tuple(ijk.T), self.dims)


@dataclass
class FrameData:
    """One frame's procedural data; ``roots`` maps each non-empty voxel to its root count,
    ``pose`` is the current pose's vertices (V, 3) or None for the rest pose. The scene
    is its TOML text (relative paths start in ``base_dir``), read by
    :func:`follicle.apps.procedural.frame_scene`."""

    scene_toml: str
    base_dir: str
    time: float
    grid: VoxelGrid
    roots: dict[int, int]
    pose: np.ndarray | None = None

    def to_bytes(self) -> bytes:
        header = {
            "scene_toml": self.scene_toml,
            "base_dir": self.base_dir,
            "time": self.time,
            "origin": list(self.grid.origin),
            "cell": self.grid.cell,
            "dims": list(self.grid.dims),
            "roots": [[v, n] for v, n in sorted(self.roots.items())],
            "pose_vertices": None if self.pose is None else len(self.pose),
        }
        pose = b"" if self.pose is None else np.asarray(self.pose, "<f8").tobytes()
        body = json.dumps(header, ensure_ascii=False).encode() + b"\n" + pose
        return _MAGIC + zlib.compress(body, 9)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> FrameData:
        """Read a frame file; FormatError naming the file and the fault if it is not one."""
        path = file_path(path, "FrameData.load path")
        where = str(path)
        try:
            if not stat.S_ISREG(os.stat(path).st_mode):  # a pipe or a device could hang
                raise FormatError(f"{where}: the frame file is not a regular file")
            with open(path, "rb") as fh:
                raw = fh.read(_LIMIT + 1)
        except OSError as exc:
            raise FormatError(f"{where}: cannot read the frame file ({exc.strerror})") from None
        if not raw.startswith(_MAGIC) or len(raw) > _LIMIT:
            raise FormatError(f"{where}: not a follicle frame file (bad signature or size)")
        inflate = zlib.decompressobj()
        try:
            body = inflate.decompress(raw[len(_MAGIC) :], _LIMIT)
        except zlib.error as exc:
            raise FormatError(f"{where}: corrupt frame file ({exc})") from None
        if not inflate.eof or inflate.unconsumed_tail or inflate.unused_data:
            raise FormatError(f"{where}: corrupt frame file (truncated or trailing data)")
        text, _, pose = body.partition(b"\n")
        try:
            return cls._from_header(json.loads(text), pose)
        except (ValueError, TypeError, KeyError, RecursionError) as exc:
            raise FormatError(f"{where}: corrupt frame file ({exc})") from None

    @classmethod
    def _from_header(cls, h: dict, pose: bytes) -> FrameData:
        """Check every field's type and range (ValueError, TypeError or KeyError if off)."""
        want = {
            "scene_toml",
            "base_dir",
            "time",
            "origin",
            "cell",
            "dims",
            "roots",
            "pose_vertices",
        }
        if set(h) != want:
            raise ValueError(f"fields {sorted(h)}, expected {sorted(want)}")
        dims = tuple(whole(d, "dims", 1, MAX_VOXELS) for d in h["dims"])
        origin = tuple(number(x, "origin") for x in h["origin"])
        cell = number(h["cell"], "cell")
        if len(dims) != 3 or len(origin) != 3 or not cell > 0:
            raise ValueError("bad grid")
        grid = VoxelGrid(origin, cell, dims)
        roots = {
            whole(v, "voxel", 0, grid.size - 1): whole(n, "roots", 1, 2**53) for v, n in h["roots"]
        }
        count = h["pose_vertices"]
        if count is None:
            vertices = None
            if pose:
                raise ValueError("pose data but no pose")
        else:
            if whole(count, "pose_vertices", 1, 2**40) * 24 != len(pose):
                raise ValueError(f"{len(pose)} bytes of pose for {count} vertices")
            vertices = np.frombuffer(pose, "<f8").reshape(count, 3).astype(np.float64)
        if not isinstance(h["scene_toml"], str) or not isinstance(h["base_dir"], str):
            raise TypeError("scene_toml and base_dir must be text")
        return cls(h["scene_toml"], h["base_dir"], number(h["time"], "time"), grid, roots, vertices)
