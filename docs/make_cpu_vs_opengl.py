"""The CPU engine beside the OpenGL engine on examples of the gallery.

Writes ``docs/cpu_vs_opengl.png``: for each scene a row, OpenGL on the left and the
CPU engine on the right, 400 × 400 each, at the scene's own settings; prints each
scene's difference (mean and 99th percentile over the RGB of every pixel, 8-bit sRGB
levels — the measure of ``tests/test_render_cpu.py``). Run from anywhere:
``.venv/bin/python docs/make_cpu_vs_opengl.py [scene ...]`` (default: parting, curly,
short_fur).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from PIL import Image

from follicle.pipeline import grow, render_scene
from follicle.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
SIZE = (400, 400)
GAP = 8  # pixels between the pictures


def difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    d = np.abs(a[..., :3].astype(int) - b[..., :3].astype(int))
    return float(d.mean()), float(np.percentile(d, 99))


def main() -> None:
    names = sys.argv[1:] or ["parting", "curly", "short_fur"]
    rows = []
    for name in names:
        scene = load_scene(ROOT / "examples" / f"{name}.toml")
        mesh, curves = grow(scene)
        pair = [
            render_scene(curves, mesh, scene.render.replace(size=SIZE, engine=engine))
            for engine in ("opengl", "cpu")
        ]
        mean, p99 = difference(*pair)
        print(f"{name:<18} mean {mean:.2f}  p99 {p99:.0f} levels")
        gap = np.full((SIZE[1], GAP, 3), 255, np.uint8)
        rows.append(np.concatenate([pair[0][..., :3], gap, pair[1][..., :3]], axis=1))
    between = np.full((GAP, rows[0].shape[1], 3), 255, np.uint8)
    sheet = np.concatenate([x for row in rows for x in (row, between)][:-1], axis=0)
    Image.fromarray(sheet).save(ROOT / "docs" / "cpu_vs_opengl.png", optimize=True)


if __name__ == "__main__":
    main()
