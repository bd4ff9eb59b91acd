"""Regenerate docs/reference/: the demo's groom (the default scene, the built-in bust with
builtin:long guides, settled as ``follicle demo`` settles them, 20,000 hairs) rendered by
the OpenGL renderer with Kajiya-Kay and with the physical model and path-traced by Mitsuba 3 from the same camera under the same
lights, the three side by side, and the raster pictures' NVIDIA FLIP against Mitsuba's
(``pip install flip-evaluator``).

Run: ``.venv/bin/python docs/make_reference.py [--size 640] [--spp 256]`` (needs the
pbr extra; a few minutes on a laptop CPU).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from make_flip_report import flip  # docs/, beside this script

from follicle.cli import _DEMO_SETTLE as DEMO_SETTLE
from follicle.pipeline import grow, render_scene
from follicle.render import save_png
from follicle.scene import Scene

OUT = Path(__file__).resolve().parent / "reference"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--size", type=int, default=640, help="image width and height")
    parser.add_argument("--spp", type=int, default=256, help="Mitsuba samples per pixel")
    args = parser.parse_args()

    scene = Scene()  # the demo's: long hair settled onto the shoulders
    scene = scene.replace(groom=scene.groom.replace("make_reference", settle=DEMO_SETTLE))
    params = scene.render.replace(size=(args.size, args.size))
    mesh, curves = grow(scene)
    start = time.perf_counter()
    gl = render_scene(curves, mesh, params, out=str(OUT / "default_opengl.png"))
    physical = params.replace(shading="physical", shading_params={})
    pbr = render_scene(curves, mesh, physical, out=str(OUT / "default_physical.png"))
    middle = time.perf_counter()
    mitsuba = params.replace(engine="mitsuba", spp=args.spp)
    mi = render_scene(curves, mesh, mitsuba, out=str(OUT / "default_mitsuba.png"))
    end = time.perf_counter()
    save_png(np.concatenate([gl, pbr, mi], axis=1), OUT / "default_side_by_side.png")
    print(
        f"{curves.curve_count:,} hairs, {args.size}², OpenGL {middle - start:.1f} s (two"
        f" models), Mitsuba {args.spp} spp {end - middle:.1f} s → {OUT}"
    )
    for name, image in (("kajiya-kay", gl), ("physical", pbr)):
        print(f"FLIP {name} against Mitsuba: {flip(mi[..., :3], image[..., :3]):.3f}")


if __name__ == "__main__":
    main()
