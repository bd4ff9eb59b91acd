"""The cards as glTF 2.0 binary (.glb; Khronos glTF 2.0 specification §4.4 "GLB File
Format Specification"), written by hand: a JSON chunk and a BIN chunk holding every
vertex array and the PNG images.

One mesh and node per level of detail, the coarser ones linked from the first by the
MSFT_lod extension (optional: a reader without it shows the finest level, the default
scene's only node); one material, alpha-masked (``alphaMode`` MASK) and double sided,
whose base colour texture is the atlas's colour with the coverage as alpha. The other
maps (depth, attribute, tangent) are textures of the file too, named in the
material's ``extras``.
"""

from __future__ import annotations

import io
import json
import struct
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..atomic import atomic_path

__all__ = ["LodMesh", "png_bytes", "write_glb"]

_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_FLOAT, _UNSIGNED_INT = 5126, 5125
_LINEAR, _LINEAR_MIPMAP_LINEAR, _CLAMP_TO_EDGE = 9729, 9987, 33071


class LodMesh(NamedTuple):
    """One level's cards as triangles (see :func:`.strips.strip_mesh`)."""

    positions: np.ndarray  # (V, 3) float32
    normals: np.ndarray  # (V, 3) float32
    uvs: np.ndarray  # (V, 2) float32
    indices: np.ndarray  # (T, 3) uint32


def png_bytes(image: np.ndarray) -> bytes:
    """An 8-bit image (H, W) or (H, W, 3 | 4) as PNG bytes (no time stamp: same image,
    same bytes)."""
    from PIL import Image

    out = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image)).save(out, format="PNG", compress_level=6)
    return out.getvalue()


class _Bin:
    """The BIN chunk under construction and the buffer views into it."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[dict] = []

    def add(self, blob: bytes, target: int | None = None) -> int:
        self.data += b"\0" * (-len(self.data) % 4)  # every view 4-byte aligned
        view: dict = {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(blob)}
        if target is not None:
            view["target"] = target
        self.data += blob
        self.views.append(view)
        return len(self.views) - 1


def _accessors(bin_: _Bin, mesh: LodMesh, accessors: list[dict]) -> dict:
    """Accessors of one level's arrays; returns its primitive's attributes and indices."""

    def add(array: np.ndarray, kind: str, target: int, ctype: int, bounds: bool) -> int:
        acc: dict = {
            "bufferView": bin_.add(np.ascontiguousarray(array).tobytes(), target),
            "componentType": ctype,
            "count": len(array),
            "type": kind,
        }
        if bounds:  # POSITION must have them (§5.1.1)
            acc["min"] = array.min(axis=0).tolist()
            acc["max"] = array.max(axis=0).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    return {
        "attributes": {
            "POSITION": add(mesh.positions, "VEC3", _ARRAY_BUFFER, _FLOAT, True),
            "NORMAL": add(mesh.normals, "VEC3", _ARRAY_BUFFER, _FLOAT, False),
            "TEXCOORD_0": add(mesh.uvs, "VEC2", _ARRAY_BUFFER, _FLOAT, False),
        },
        "indices": add(
            mesh.indices.reshape(-1), "SCALAR", _ELEMENT_ARRAY_BUFFER, _UNSIGNED_INT, False
        ),
    }


def write_glb(
    path: str | Path,
    lods: list[LodMesh],
    images: dict[str, bytes],
    alpha_cutoff: float,
    extras: dict,
) -> None:
    """Write ``lods`` with the PNG ``images`` (the first the base colour with coverage
    as alpha) to ``path`` atomically."""
    bin_ = _Bin()
    accessors: list[dict] = []
    primitives = [_accessors(bin_, mesh, accessors) for mesh in lods]
    names = list(images)
    nodes: list[dict] = [{"name": f"cards_LOD{i}", "mesh": i} for i in range(len(lods))]
    if len(lods) > 1:
        nodes[0]["extensions"] = {"MSFT_lod": {"ids": list(range(1, len(lods)))}}
    doc: dict = {
        "asset": {"version": "2.0", "generator": "follicle cards"},
        "scene": 0,
        "scenes": [{"name": "hair_cards", "nodes": [0]}],
        "nodes": nodes,
        "meshes": [
            {"name": f"cards_LOD{i}", "primitives": [{**p, "material": 0, "mode": 4}]}
            for i, p in enumerate(primitives)
        ],
        "materials": [
            {
                "name": "hair_cards",
                "pbrMetallicRoughness": {
                    "baseColorTexture": {"index": 0},
                    "metallicFactor": 0.0,
                    "roughnessFactor": 0.6,
                },
                "alphaMode": "MASK",
                "alphaCutoff": alpha_cutoff,
                "doubleSided": True,
                "extras": {"maps": {n: i for i, n in enumerate(names)}, **extras},
            }
        ],
        "samplers": [
            {
                "magFilter": _LINEAR,
                "minFilter": _LINEAR_MIPMAP_LINEAR,
                "wrapS": _CLAMP_TO_EDGE,
                "wrapT": _CLAMP_TO_EDGE,
            }
        ],
        "textures": [{"sampler": 0, "source": i, "name": n} for i, n in enumerate(names)],
        "images": [
            {"name": n, "mimeType": "image/png", "bufferView": bin_.add(images[n])} for n in names
        ],
        "accessors": accessors,
        "bufferViews": bin_.views,
    }
    if len(lods) > 1:
        doc["extensionsUsed"] = ["MSFT_lod"]
    bin_.data += b"\0" * (-len(bin_.data) % 4)
    doc["buffers"] = [{"byteLength": len(bin_.data)}]
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)  # the JSON chunk is padded with spaces (§4.4.3.1)
    total = 12 + 8 + len(text) + 8 + len(bin_.data)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(struct.pack("<4sII", b"glTF", 2, total))
        fh.write(struct.pack("<I4s", len(text), b"JSON") + text)
        fh.write(struct.pack("<I4s", len(bin_.data), b"BIN\0") + bytes(bin_.data))
