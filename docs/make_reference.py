"""Regenerate docs/reference/: the default groom (built-in head, builtin:long guides,
20,000 hairs) rendered by the OpenGL renderer (Kajiya-Kay) and path-traced by Mitsuba 3
from the same camera under the same lights, and the two side by side.

Run: ``.venv/bin/python docs/make_reference.py [--size 640] [--spp 256]`` (needs the
pbr extra; a few minutes on a laptop CPU).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from follicle.pipeline import grow, render_scene
from follicle.render import save_png
from follicle.scene import Scene

OUT = Path(__file__).resolve().parent / "reference"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--size", type=int, default=640, help="image width and height")
    parser.add_argument("--spp", type=int, default=256, help="Mitsuba samples per pixel")
    args = parser.parse_args()

    scene = Scene()
    params = scene.render.replace(size=(args.size, args.size))
    mesh, curves = grow(scene)
    start = time.perf_counter()
    gl = render_scene(curves, mesh, params, out=str(OUT / "default_opengl.png"))
    middle = time.perf_counter()
    mitsuba = params.replace(engine="mitsuba", spp=args.spp)
    mi = render_scene(curves, mesh, mitsuba, out=str(OUT / "default_mitsuba.png"))
    end = time.perf_counter()
    save_png(np.concatenate([gl, mi], axis=1), OUT / "default_side_by_side.png")
    print(
        f"{curves.curve_count:,} hairs, {args.size}², OpenGL {middle - start:.1f} s,"
        f" Mitsuba {args.spp} spp {end - middle:.1f} s → {OUT}"
    )


if __name__ == "__main__":
    main()
