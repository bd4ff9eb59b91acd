"""AMD TressFX ``.tfx`` hair: read (3.x and 4.x) and write (4.x).

Little-endian. TressFX stores the same number of vertices in every strand.

4.x (written): a 160-byte header: float version (4.0); uint numHairStrands,
numVerticesPerStrand; uint byte offsets (from the start of the file, multiples of 8,
0 for an absent section) of vertex positions, strand UVs, vertex UVs, strand
thickness and vertex colours; uint reserved[32]. Sections:

- vertex positions, float4 per vertex: x, y, z and w = 0 for the root (immovable,
  pinned to the scalp) or 1 for the other (movable) vertices;
- strand UV, float2 per strand: ``root_uv`` (written when the hair has it);
- vertex UV, float2 per vertex: (root u, t), t the arc length fraction from root (0)
  to tip (1) and root u 0 without ``root_uv`` (always written; not read back);
- strand thickness, float per strand: the root ``width`` (a diameter, metres; when the
  hair has widths); read back as that width at every vertex of the strand;
- vertex colour, float4 per vertex: linear RGB ``color`` and ``opacity`` as alpha
  (when the hair has either; the other is written as 1).

The writer resamples every curve whose vertex count differs from ``vertices`` (default:
the first curve's count) to that count, evenly by arc length along its polyline
(positions, colours and opacity); curves already of that count are written as they
are. TressFX's runtime wants 4, 8, 16, 32 or 64 vertices per strand.

3.x (read only), after AMD's ``TressFXFileFormat.h`` of TressFX 3: a 144-byte
preamble: float version; uint numGuideHairStrands, numVerticesPerStrand,
numFollowHairsPerGuideHair, bothEndsImmovable; uint reserved1[31]. Then a table of
uint offsets: vertices (float3 per vertex), strand thickness (float), strand texture
coordinates (float2), vertex colours (float4), guide-strand flags (uint per strand)
and vertex texture coordinates (float2), and uint reserved2[32] (296 bytes in all);
the sections follow as in 4.x. A file of exactly 144 + 12 × strands × vertices bytes
is the packed variant: float3 vertices straight after the preamble, nothing else.
Only the guide strands in the file are read (TressFX makes follow hairs at run time).
"""

from __future__ import annotations

import math
import os
import struct
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..curves import HairCurves
from ..errors import ResourceError
from ..validate import whole
from .attributes import consistent
from .binary import BinaryFile, Spool, check_finite, open_binary

__all__ = ["save_tfx", "load_tfx", "resample_fixed"]

HEADER4 = struct.Struct("<f7I32I")  # 160 bytes
PREAMBLE3 = struct.Struct("<f4I31I")  # 144 bytes
TABLE3 = struct.Struct("<6I32I")  # 152 bytes, after the preamble
_SECTIONS = ("positions", "strand_uv", "vertex_uv", "thickness", "colors")


def save_tfx(
    chunks: Iterator[HairCurves], path: str | os.PathLike[str], vertices: int | None = None
) -> Path:
    """Write hair as a TressFX 4.0 file with ``vertices`` vertices per strand, streaming:
    each section goes to its own temporary file, joined after the header at the end."""
    n = None if vertices is None else whole(vertices, "vertices", 2)
    target = Path(path)
    strands = 0
    present = {"positions", "vertex_uv"}
    with atomic_path(target) as tmp, Spool(tmp.parent, _SECTIONS) as spool:
        for i, chunk in enumerate(consistent(chunks)):
            if i == 0:
                pd = chunk.point_data
                present |= {"strand_uv"} if "root_uv" in chunk.curve_data else set()
                present |= {"thickness"} if "width" in pd else set()
                present |= {"colors"} if "color" in pd or "opacity" in pd else set()
            if not chunk.curve_count:
                continue
            n = n or int(chunk.counts[0])
            _write_chunk(spool, chunk, n, present)
            strands += chunk.curve_count
        offsets, end = {}, HEADER4.size
        for name in _SECTIONS:
            if name in present:
                offsets[name] = end
                end += spool.sizes[name] + (-spool.sizes[name] % 8)
        if end > 2**32 - 1:
            raise ResourceError(
                f"curves: the TressFX file would take {end:,} bytes; its offsets"
                " are uint32 (at most 4 GiB): write fewer hairs per file"
            )
        header = HEADER4.pack(
            4.0, strands, n or 0, *(offsets.get(s, 0) for s in _SECTIONS), *[0] * 32
        )
        with open(tmp, "wb") as out:
            out.write(header)
            spool.join(out, [s for s in _SECTIONS if s in present], align=8)
    return target


def _write_chunk(spool: Spool, chunk: HairCurves, n: int, present: set[str]) -> None:
    attrs: dict[str, np.ndarray] = {
        k: chunk.point_data[k] for k in ("color", "opacity") if k in chunk.point_data
    }
    pos, attrs = resample_fixed(chunk, n, attrs)
    c = chunk.curve_count
    xyzw = np.ones((c, n, 4), dtype="<f4")
    xyzw[..., :3] = pos
    xyzw[:, 0, 3] = 0.0  # the root is immovable
    spool.write("positions", xyzw)
    uv = chunk.curve_data.get("root_uv")
    if "strand_uv" in present:
        assert uv is not None  # present has strand_uv where the hair has root_uv
        spool.write("strand_uv", uv.astype("<f4"))
    vertex_uv = np.zeros((c, n, 2), dtype="<f4")
    vertex_uv[..., 0] = 0.0 if uv is None else uv[:, None, 0]
    vertex_uv[..., 1] = _arc_fraction(pos)
    spool.write("vertex_uv", vertex_uv)
    if "thickness" in present:
        spool.write("thickness", chunk.point_data["width"][chunk.offsets[:-1]].astype("<f4"))
    if "colors" in present:
        rgba = np.ones((c, n, 4), dtype="<f4")
        if "color" in attrs:
            rgba[..., :3] = attrs["color"]
        if "opacity" in attrs:
            rgba[..., 3] = attrs["opacity"][..., 0]
        spool.write("colors", rgba)


def _arc_fraction(pos: np.ndarray) -> np.ndarray:
    """(C, n) arc length from the root over the total, 0 along zero-length curves."""
    seg = np.linalg.norm(np.diff(pos.astype(np.float64), axis=1), axis=2)
    cum = np.zeros(pos.shape[:2])
    np.cumsum(seg, axis=1, out=cum[:, 1:])
    total = cum[:, -1:]
    return np.divide(cum, total, out=np.zeros_like(cum), where=total > 0)


def resample_fixed(
    curves: HairCurves,
    n: int,
    attrs: dict[str, np.ndarray],
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Positions (C, n, 3) float32 and per-vertex ``attrs`` (C, n, k) with ``n`` vertices
    per curve: curves of n vertices as they are, the others resampled evenly by arc
    length along their polylines (linear interpolation, root and tip kept)."""
    c = curves.curve_count
    flat = {
        k: np.asarray(v, dtype=np.float32).reshape(curves.point_count, -1) for k, v in attrs.items()
    }
    pos = np.empty((c, n, 3), dtype=np.float32)
    out = {k: np.empty((c, n, v.shape[1]), dtype=np.float32) for k, v in flat.items()}
    same = curves.counts == n
    if same.any():
        rows = _vertex_rows(curves.offsets, np.flatnonzero(same))
        pos[same] = curves.points[rows].reshape(-1, n, 3)
        for k, v in flat.items():
            out[k][same] = v[rows].reshape(-1, n, v.shape[1])
    if not same.all():
        which = np.flatnonzero(~same)
        rows = _vertex_rows(curves.offsets, which)
        sub_offsets = np.zeros(len(which) + 1, dtype=np.int64)
        np.cumsum(curves.counts[which], out=sub_offsets[1:])
        pts = curves.points[rows].astype(np.float64)
        a, b, w = _arc_stencil(pts, sub_offsets, n)
        for dst, v in [(pos, pts)] + [(out[k], f[rows]) for k, f in flat.items()]:
            vv = v.astype(np.float64, copy=False)
            dst[which] = ((1.0 - w)[:, None] * vv[a] + w[:, None] * vv[b]).reshape(
                len(which), n, -1
            )
    return pos, out


def _vertex_rows(offsets: np.ndarray, which: np.ndarray) -> np.ndarray:
    """Indices of the vertices of curves ``which``, in order."""
    counts = offsets[which + 1] - offsets[which]
    starts = np.repeat(offsets[which] - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts)
    return starts + np.arange(int(counts.sum()))


def _arc_stencil(
    pts: np.ndarray,
    offsets: np.ndarray,
    n: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For n points per curve evenly spaced by arc length: the vertices (a, b) each lies
    between and the weight w of b, flat over all curves."""
    c = len(offsets) - 1
    counts = np.diff(offsets)
    curve = np.repeat(np.arange(c), counts)
    seg = np.zeros(len(pts))
    seg[1:] = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    seg[offsets[:-1]] = 0.0
    cum = np.cumsum(seg)
    cum -= cum[offsets[:-1]][curve]
    total = cum[offsets[1:] - 1]
    uniform = (np.arange(len(pts)) - offsets[:-1][curve]) / (counts[curve] - 1)
    s = np.where(total[curve] > 0, cum / np.where(total > 0, total, 1.0)[curve], uniform)
    t = np.tile(np.linspace(0.0, 1.0, n), c)
    t_curve = np.repeat(np.arange(c), n)
    a = np.searchsorted(curve + 0.5 * s, t_curve + 0.5 * t, side="right") - 1
    a = np.clip(a, offsets[:-1][t_curve], offsets[1:][t_curve] - 2)
    span = s[a + 1] - s[a]
    w = np.clip(np.divide(t - s[a], span, out=np.zeros_like(t), where=span > 0), 0.0, 1.0)
    return a, a + 1, w


# ------------------------------------------------------------------ reading
def load_tfx(path: str | os.PathLike[str]) -> HairCurves:
    """Read a TressFX 3.x or 4.x ``.tfx`` file (see the module notes for what is kept)."""
    with open_binary(path) as f:
        (version,) = f.unpack("header version", "<f")
        if not (math.isfinite(version) and 3.0 <= version < 5.0):
            raise f.fail(f"header version {version} is not a TressFX 3.x or 4.x version")
        return _read_v4(f) if version >= 4.0 else _read_v3(f)


def _read_v4(f: BinaryFile) -> HairCurves:
    _, strands, n, *offs = f.unpack("header", HEADER4.format)[:8]
    sizes = dict(zip(_SECTIONS, (16, 8, 8, 4, 16), strict=True))
    per_strand = {"strand_uv", "thickness"}
    return _read_sections(
        f,
        HEADER4.size,
        strands,
        n,
        {
            name: (off, sizes[name] * (strands if name in per_strand else strands * n))
            for name, off in zip(_SECTIONS, offs, strict=True)
        },
        {"positions": 4, "strand_uv": 2, "thickness": 0, "colors": 4},
    )


def _read_v3(f: BinaryFile) -> HairCurves:
    _, strands, n, *_ = f.unpack("header", PREAMBLE3.format)
    if f.size == PREAMBLE3.size + 12 * strands * n:  # packed: vertices right after
        table = {"positions": (PREAMBLE3.size, 12 * strands * n)}
        return _read_sections(f, PREAMBLE3.size, strands, n, table, {"positions": 3})
    names = ("positions", "thickness", "strand_uv", "colors", "guide_flags", "vertex_uv")
    sizes = (
        12 * strands * n,
        4 * strands,
        8 * strands,
        16 * strands * n,
        4 * strands,
        8 * strands * n,
    )
    offs = f.unpack("offset table", TABLE3.format, PREAMBLE3.size)[:6]
    table = {name: (off, size) for name, off, size in zip(names, offs, sizes, strict=True)}
    return _read_sections(
        f,
        PREAMBLE3.size + TABLE3.size,
        strands,
        n,
        table,
        {"positions": 3, "strand_uv": 2, "thickness": 0, "colors": 4},
    )


def _read_sections(
    f: BinaryFile,
    header_size: int,
    strands: int,
    n: int,
    table: dict[str, tuple[int, int]],
    widths: dict[str, int],
) -> HairCurves:
    """Validate the sections ``name -> (offset, bytes)`` (offset 0: absent) and read the
    float ones named in ``widths`` (floats per item; 0 for one float per strand)."""
    if strands and n < 2:
        raise f.fail(f"header numVerticesPerStrand {n}: a strand needs at least 2 vertices")
    if strands and table["positions"][0] == 0:
        raise f.fail("header vertex positions offset is 0: the file has no vertices")
    present = {k: v for k, v in table.items() if v[0] or k == "positions"}
    for name, (offset, size) in present.items():
        f.need(f"{name} (numHairStrands {strands} × numVerticesPerStrand {n})", offset, size)
    f.sections(header_size, {k: v for k, v in present.items() if v[1]})
    arrays = {}
    for name, k in widths.items():
        if name in present:
            offset, size = present[name]
            count = size // (4 * max(k, 1))
            arrays[name] = check_finite(
                f, name, f.array(name, offset, count, "<f4", (k,) if k else ())
            )
    points = strands * n
    point_data, curve_data = {}, {}
    if "thickness" in arrays:
        point_data["width"] = np.repeat(arrays["thickness"], n)
    if "colors" in arrays:
        point_data["color"] = np.ascontiguousarray(arrays["colors"][:, :3])
        point_data["opacity"] = np.ascontiguousarray(arrays["colors"][:, 3])
    if "strand_uv" in arrays:
        curve_data["root_uv"] = arrays["strand_uv"]
    xyz = arrays["positions"][:, :3] if points else np.zeros((0, 3), np.float32)
    return HairCurves(xyz, np.arange(strands + 1, dtype=np.int64) * n, point_data, curve_data)
