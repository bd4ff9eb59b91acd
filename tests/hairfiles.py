"""Hair shared by the format tests: random curves, TressFX 3 files built by hand, and a
RIB reader for checking what the RIB writers print."""

from __future__ import annotations

import re
import struct

import numpy as np

from follicle import HairCurves


def hair(counts: tuple[int, ...] = (4, 6, 2, 5), seed: int = 0, uv: bool = True) -> HairCurves:
    """Random-walk curves with width, color and opacity (and root_uv)."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(scale=0.01, size=(sum(counts), 3))
    ends = np.cumsum(counts)
    pts = np.concatenate([np.cumsum(s, axis=0) for s in np.split(steps, ends[:-1])])
    p = len(pts)
    point_data = {
        "width": rng.uniform(2e-5, 1e-4, p).astype(np.float32),
        "color": rng.random((p, 3)).astype(np.float32),
        "opacity": rng.random(p).astype(np.float32),
    }
    curve_data = {"root_uv": rng.random((len(counts), 2)).astype(np.float32)} if uv else {}
    return HairCurves.from_polylines(np.split(pts, ends[:-1]), point_data, curve_data)


def tfx3_table(
    strands: int,
    n: int,
    vertices: object,
    thickness: object = None,
    uv: object = None,
    colors: object = None,
) -> bytes:
    """A TressFX 3 file with the offset table of TressFX 3's TressFXFileFormat.h: the
    144-byte preamble, six offsets and 32 reserved uints, then 8-aligned sections."""
    sections, offsets, end = [], [0] * 6, 296
    for slot, arr in ((0, vertices), (1, thickness), (2, uv), (3, colors)):
        if arr is not None:
            data = np.asarray(arr, "<f4").tobytes()
            data += bytes(-len(data) % 8)
            offsets[slot] = end
            sections.append(data)
            end += len(data)
    head = struct.pack("<f4I31I", 3.0, strands, n, 2, 0, *[0] * 31)
    return head + struct.pack("<6I32I", *offsets, *[0] * 32) + b"".join(sections)


# ------------------------------------------------------------------ RIB
RIB_COMPONENTS = {"width": 1, "Cs": 3, "Os": 3, "N": 3}


def parse_rib(path):
    """The RIB as [request, args…] lists: strings unquoted, [...] arrays as lists."""
    requests, array = [], None
    lines = [line for line in path.read_text().splitlines() if not line.startswith("##")]
    for token in re.findall(r'"[^"]*"|\[|\]|[^\s\[\]"]+', "\n".join(lines)):
        if token == "[":
            array = []
        elif token == "]":
            requests[-1].append(array)
            array = None
        elif array is not None:
            array.append(token.strip('"'))
        elif token[0].isalpha():  # a bare word: a request
            requests.append([token])
        else:
            requests[-1].append(token.strip('"'))
    return requests


def curves_requests(path):
    """Each Curves request as (nverts, wrap, {token: float array})."""
    out = []
    for req in parse_rib(path):
        if req[0] != "Curves":
            continue
        assert req[1] == "cubic"
        nverts = np.array(req[2], dtype=np.int64)
        params = {req[i]: np.array(req[i + 1], dtype=np.float64) for i in range(4, len(req), 2)}
        out.append((nverts, req[3], params))
    return out


def strip_ends(p, nverts):
    """P of curves with duplicated end vertices, the duplicates checked and removed."""
    p = p.reshape(-1, 3)
    offs = np.concatenate([[0], np.cumsum(nverts)])
    assert np.array_equal(p[offs[:-1]], p[offs[:-1] + 1])
    assert np.array_equal(p[offs[1:] - 1], p[offs[1:] - 2])
    keep = np.ones(len(p), bool)
    keep[offs[:-1]] = keep[offs[1:] - 1] = False
    return p[keep]


def check_counts(nverts, wrap, params, curves):
    assert wrap == "nonperiodic"
    nsegs = nverts - 3  # cubic nonperiodic, vstep 1: (nverts − 4) / 1 + 1
    varying = int(np.sum(nsegs + 1))
    assert params["P"].size == 3 * int(nverts.sum())
    for token, comps in RIB_COMPONENTS.items():
        if token in params:
            assert params[token].size == comps * varying, token
    c = len(nverts)
    assert params["uniform float[2] hair_uv"].size == 2 * c
    assert params["uniform float[2] strand_uv"].size == 2 * c
    assert params["uniform int hair_index"].size == params["uniform int strand_index"].size == c
    assert np.array_equal(nverts, curves.counts + 2) and varying == curves.point_count


def close7(rib_values, values):
    """Equal to 7 significant digits."""
    values = np.asarray(values, np.float64).reshape(-1)
    np.testing.assert_allclose(np.reshape(rib_values, -1), values, rtol=6e-7, atol=1e-30)
