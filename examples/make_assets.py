"""Make the small assets of the examples: short_fur's torus with UVs and two textures,
and hand_groomed's guides replayed from its stroke log.

    .venv/bin/python examples/make_assets.py [OUT_DIR]

writes into ``OUT_DIR`` (default ``examples/assets``; about 250 KB in all, the same
bytes on every run):

* ``assets/torus.obj`` — a torus lying in the x-z plane (major radius 0.12 m, tube
  radius 0.05 m), 64 × 32 quads, per-vertex UVs: u runs once around the ring, v once
  around the tube (v = 0.5 on the outer equator, v = 0 / 1 on the inner one). The seam
  vertices are duplicated so the UVs do not jump.
* ``assets/fur_density.png`` — 8-bit grey density: 1 on the coat, fading to 0 on a band
  along the inner equator (the bald "belly" in the hole of the ring).
* ``assets/fur_color.png`` — 8-bit colour: an orange coat with wavy dark tiger stripes
  across the ring and a cream belly, multiplied into root_color / tip_color. follicle
  reads texels as value / 255 (no sRGB decoding), so the PNG holds LINEAR RGB.

* ``assets/hand_groomed.npz`` and ``assets/hand_groomed_groups.png`` — the guides and
  interpolation groups of ``examples/hand_groomed.strokes.json`` replayed, as
  ``follicle groom examples/hand_groomed.strokes.json -o … --groups …`` writes them.

Texture rows run from v = 1 (top row) to v = 0 (bottom row), as follicle samples them.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from PIL import Image

from follicle.editing.editor import replay_file

HERE = Path(__file__).resolve().parent / "assets"
MAJOR, MINOR = 0.12, 0.05  # m
RING, TUBE = 64, 32  # quads around the ring and around the tube
TEX_W, TEX_H = 256, 128
HAND_GROOMED = ("hand_groomed.npz", "hand_groomed_groups.png")


def torus() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices (n, 3), UVs (n, 2) and quads (m, 4) of the torus, outward facing."""
    u = np.linspace(0.0, 1.0, RING + 1)
    v = np.linspace(0.0, 1.0, TUBE + 1)
    uu, vv = np.meshgrid(u, v, indexing="ij")  # (RING+1, TUBE+1)
    a = 2 * np.pi * uu  # around the ring (y axis)
    b = 2 * np.pi * vv + np.pi  # around the tube; v = 0.5 on the outer equator
    r = MAJOR + MINOR * np.cos(b)
    pos = np.stack([r * np.cos(a), MINOR * np.sin(b), -r * np.sin(a)], axis=-1)
    uv = np.stack([uu, vv], axis=-1)
    idx = np.arange((RING + 1) * (TUBE + 1)).reshape(RING + 1, TUBE + 1)
    corners = [idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]]
    quads = np.stack(corners, axis=-1).reshape(-1, 4)
    pos, uv = pos.reshape(-1, 3), uv.reshape(-1, 2)
    # make the winding agree with the outward normal (centre of the tube → vertex)
    q = pos[quads]
    normal = np.cross(q[:, 1] - q[:, 0], q[:, 3] - q[:, 0])
    centre = q.mean(axis=1)
    ring = centre * [1.0, 0.0, 1.0]
    ring *= (MAJOR / np.linalg.norm(ring, axis=1))[:, None]
    if np.mean(np.sum(normal * (centre - ring), axis=1) < 0) > 0.5:
        quads = quads[:, ::-1]
    return pos, uv, quads


def write_obj(path: Path, pos: np.ndarray, uv: np.ndarray, quads: np.ndarray) -> None:
    lines = ["# torus for examples/short_fur.toml, made by examples/make_assets.py"]
    lines += [f"v {x:.4f} {y:.4f} {z:.4f}" for x, y, z in pos]
    lines += [f"vt {s:.4f} {t:.4f}" for s, t in uv]
    lines += ["f " + " ".join(f"{i + 1}/{i + 1}" for i in quad) for quad in quads]
    path.write_text("\n".join(lines) + "\n", encoding="ascii")


def _smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def texture_grid() -> tuple[np.ndarray, np.ndarray]:
    """(u, v) at the texel centres, (TEX_H, TEX_W) each, top row v ≈ 1."""
    u = (np.arange(TEX_W) + 0.5) / TEX_W
    v = 1.0 - (np.arange(TEX_H) + 0.5) / TEX_H
    return np.meshgrid(u, v)


def belly(v: np.ndarray) -> np.ndarray:
    """1 on the inner equator (v = 0 or 1), fading to 0 at 0.16 turns of the tube away."""
    d = np.minimum(v, 1.0 - v)  # tube distance from the inner equator, in turns
    return 1.0 - _smoothstep(0.06, 0.16, d)


def density() -> np.ndarray:
    u, v = texture_grid()
    bald = 1.0 - _smoothstep(0.05, 0.09, np.minimum(v, 1.0 - v))
    return np.rint(255 * (1.0 - bald)).astype(np.uint8)


def color() -> np.ndarray:
    u, v = texture_grid()
    # stripes across the ring: 14 of them, wavy, thinning towards the belly
    wobble = 0.35 * np.sin(2 * np.pi * (2 * v + 3 * u)) + 0.15 * np.sin(2 * np.pi * 5 * v)
    phase = np.sin(2 * np.pi * 14 * u + 2.0 * wobble)
    side = np.abs(v - 0.5) * 2  # 0 on the outer equator, 1 on the inner one
    stripe = _smoothstep(0.55 + 0.35 * side, 0.75 + 0.3 * side, phase)
    coat = np.array([0.85, 0.25, 0.035])  # linear RGB: orange
    dark = np.array([0.03, 0.018, 0.01])  # near black-brown
    cream = np.array([0.80, 0.66, 0.45])
    rgb = coat * (1 - stripe[..., None]) + dark * stripe[..., None]
    w = belly(v)[..., None]
    rgb = rgb * (1 - w) + cream * w
    return np.rint(255 * np.clip(rgb, 0, 1)).astype(np.uint8)


def main(out: Path = HERE) -> None:
    out.mkdir(parents=True, exist_ok=True)
    pos, uv, quads = torus()
    write_obj(out / "torus.obj", pos, uv, quads)
    Image.fromarray(density(), "L").save(out / "fur_density.png", optimize=True)
    Image.fromarray(color(), "RGB").save(out / "fur_color.png", optimize=True)
    editor = replay_file(Path(__file__).resolve().parent / "hand_groomed.strokes.json")
    editor.save(out / "hand_groomed.npz")
    editor.save_groups(out / "hand_groomed_groups.png")
    for name in ("torus.obj", "fur_density.png", "fur_color.png", *HAND_GROOMED):
        print(f"{out / name}: {(out / name).stat().st_size / 1024:.1f} KiB")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE)
