"""Regenerate docs/three_renderers.png: gallery scenes drawn by follicle's CPU engine (the
physical model), path-traced by Mitsuba 3 (Chiang 2016's hair BSDF) and by Blender's
Cycles (Principled Hair, the same groom exported for the blender target and imported as
a Blender user would), from each scene's camera; a row per scene.

follicle and Mitsuba share the lights exactly; Cycles gets ``render_groom.py``'s own key,
fill and rim area lights turned with the camera, so compare the hair's look (colour,
translucency, sheen, where it rests), not the exposure. Needs the pbr extra and Blender
(bpy 5.0.1, a Python 3.11 venv: ``FOLLICLE_BLENDER_PYTHON``, else ``.venv-blender``, which
the Blender tests make).

Run: ``.venv/bin/python docs/make_three_renderers.py [--size 320] [--spp 256]
[--samples 32] [--scenes wavy,curly,blond_multistrand]``
"""

from __future__ import annotations

import argparse
import os
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

from follicle import HairCurves, SkinMesh, save
from follicle.pipeline import grow, render_scene
from follicle.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "three_renderers.png"
GAP = 4  # pixels between pictures


def cycles(
    name: str, curves: HairCurves, mesh: SkinMesh, scene, size: int, samples: int, folder: Path
) -> np.ndarray:
    """Blender's Cycles picture of the grown hair and its skin, exported for the blender
    target, rendered by ``tests/blender_scripts/render_groom.py``."""
    blender = os.environ.get("FOLLICLE_BLENDER_PYTHON", str(ROOT / ".venv-blender/bin/python"))
    groom, png = folder / f"{name}.usdc", folder / f"{name}.png"
    save(curves, groom, target="blender", mesh=mesh)
    r = scene.render
    view = ["--eye", *map(str, r.eye), "--target", *map(str, r.target), "--fov", str(r.fov)]
    script = ROOT / "tests" / "blender_scripts" / "render_groom.py"
    subprocess.run(
        [blender, str(script), str(groom), str(png), "--size", str(size),
         "--samples", str(samples), *view],
        check=True, stdout=subprocess.DEVNULL,
    )  # fmt: skip
    return np.asarray(Image.open(png).convert("RGB"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--size", type=int, default=320, help="image width and height")
    parser.add_argument("--spp", type=int, default=256, help="Mitsuba samples per pixel")
    parser.add_argument("--samples", type=int, default=32, help="Cycles samples per pixel")
    parser.add_argument("--scenes", default="wavy,curly,blond_multistrand")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="follicle-three-") as tmp:
        for name in args.scenes.split(","):
            path = ROOT / "examples" / f"{name}.toml"
            scene = load_scene(path)
            mesh, curves = grow(scene)
            params = scene.render.replace(size=(args.size, args.size))
            start = time.perf_counter()
            ours = render_scene(curves, mesh, params.replace(engine="cpu", shading="physical"))
            t_ours = time.perf_counter() - start
            mitsuba = render_scene(curves, mesh, params.replace(engine="mitsuba", spp=args.spp))
            t_mitsuba = time.perf_counter() - start - t_ours
            blender = cycles(name, curves, mesh, scene, args.size, args.samples, Path(tmp))
            t_cycles = time.perf_counter() - start - t_ours - t_mitsuba
            print(
                f"{name}: follicle CPU {t_ours:.1f} s, Mitsuba {args.spp} spp {t_mitsuba:.0f} s,"
                f" Cycles {args.samples} samples {t_cycles:.0f} s (export and import included)",
                flush=True,
            )
            gap = np.full((args.size, GAP, 3), 255, np.uint8)
            pictures = (ours[..., :3], gap, mitsuba[..., :3], gap, blender)
            rows.append(np.concatenate(pictures, axis=1))
    between = np.full((GAP, rows[0].shape[1], 3), 255, np.uint8)
    sheet = np.concatenate([x for row in rows for x in (row, between)][:-1], axis=0)
    small = Image.fromarray(sheet).quantize(256, dither=Image.Dither.FLOYDSTEINBERG)
    small.save(OUT, optimize=True)
    print(f"→ {OUT}")


if __name__ == "__main__":
    main()
