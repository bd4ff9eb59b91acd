"""Hair colour by melanin: do the raster engines and the path tracer draw the same hair?

For blond, brown and black melanin (0.2, 0.6, 0.95) the demo's groom (``--count``
hairs, 20,000 by default, ``builtin:long`` on the bust, parted, the guides settled
``--settle`` seconds as ``follicle demo`` does; or ``--mesh builtin:head``) is drawn
by the CPU engine (and OpenGL through EGL with ``--opengl``), once per shading model of
``--shading`` (Kajiya-Kay and physical by default), and by Mitsuba (``--spp``
samples per pixel), with the same camera, lights and background. The raster engines
shade each hair with its melanin's colour (:func:`follicle.melanin.melanin_color`);
Mitsuba's ``hair`` BSDF takes the pigments' absorption σ_a itself (Chiang 2016 §4.2).

Only hair pixels count: those the CPU engine draws the same over a black background and
black skin as over a white background and white skin (the hair covers them wholly),
less one pixel of border. The table gives the mean colour of those pixels (linear RGB
averaged, then CIELAB, D65) in each engine and their CIEDE2000 difference (Sharma, Wu
& Dalal 2005, by scikit-image; checked against their published pairs first). Target: ΔE2000 ≤ 5.

``--diffuse 1.0 1.5`` and ``--unshadowed`` add rows of the CPU engine with another
Kajiya-Kay diffuse weight K_d (default 0.6) or without shadows, against the same
reference: how much of a difference is the raster shading's energy.

Run: ``.venv/bin/python benchmarks/melanin_colour.py [--count 20000] [--size 384]
[--spp 64] [--opengl] [--shading kajiya-kay physical ...] [--mesh builtin:bust]
[--settle 2] [--diffuse K ...] [--unshadowed]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from skimage.color import deltaE_ciede2000

import follicle
from follicle.cli import _DEMO_SETTLE
from follicle.color import lab_from_linear
from follicle.pipeline import grow
from follicle.render.camera import frame_scene
from follicle.render.image import srgb_to_linear
from follicle.scene import parse_scene

MELANIN = {"blond": 0.2, "brown": 0.6, "black": 0.95}
TARGET = 5.0


# Sharma 2005 Table 1: pairs 1, 7, 17, 25 and their ΔE00
_SHARMA = [
    ((50.0, 2.6772, -79.7751), (50.0, 0.0, -82.7485), 2.0425),
    ((50.0, 0.0, 0.0), (50.0, -1.0, 2.0), 2.3669),
    ((50.0, 2.5, 0.0), (73.0, 25.0, -18.0), 27.1492),
    ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644),
]


def hair_mask(curves, mesh, camera, size) -> np.ndarray:
    """Pixels wholly covered by hair in the CPU engine, less a pixel of border."""
    dark = follicle.render_image(
        curves, mesh, camera, engine="cpu", size=size, background=(0, 0, 0), skin_color=(0, 0, 0)
    )
    light = follicle.render_image(
        curves, mesh, camera, engine="cpu", size=size, background=(1, 1, 1), skin_color=(1, 1, 1)
    )
    same = np.abs(dark[..., :3].astype(int) - light[..., :3]).max(axis=-1) <= 1
    inner = same.copy()
    inner[1:] &= same[:-1]
    inner[:-1] &= same[1:]
    inner[:, 1:] &= same[:, :-1]
    inner[:, :-1] &= same[:, 1:]
    return inner


def mean_lab(image: np.ndarray, mask: np.ndarray) -> np.ndarray:
    return lab_from_linear(srgb_to_linear(image[..., :3][mask] / 255.0).mean(axis=0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=20000)
    parser.add_argument(
        "--settle", type=float, default=_DEMO_SETTLE, help="seconds the guides settle (0: none)"
    )
    parser.add_argument("--size", type=int, default=384)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--opengl", action="store_true", help="also the OpenGL engine (EGL)")
    parser.add_argument(
        "--diffuse",
        type=float,
        nargs="*",
        default=[],
        help="also the CPU engine with these Kajiya-Kay K_d (default 0.6): the raster energy",
    )
    parser.add_argument(
        "--unshadowed", action="store_true", help="also the CPU engine without shadows"
    )
    parser.add_argument(
        "--shading",
        nargs="+",
        default=["kajiya-kay", "physical"],
        help="the raster engines' shading models, each a row",
    )
    parser.add_argument("--mesh", default="builtin:bust", help="the skin (builtin:head before)")
    args = parser.parse_args()
    for lab1, lab2, expected in _SHARMA:
        got = float(deltaE_ciede2000(np.array(lab1), np.array(lab2)))
        assert abs(got - expected) < 1e-4, (lab1, lab2, got, expected)

    size = (args.size, args.size)
    rasters: dict[str, dict] = {}
    for shading in args.shading:
        rasters[f"cpu {shading}"] = {"engine": "cpu", "shading": shading}
        if args.opengl:
            rasters[f"opengl {shading}"] = {"engine": "opengl", "shading": shading}
    for k in args.diffuse:
        rasters[f"cpu Kd={k:g}"] = {"engine": "cpu", "shading_params": {"diffuse": k}}
    if args.unshadowed:
        rasters["cpu no shadows"] = {"engine": "cpu", "shadows": False}
    print(
        f"{args.count:,} hairs, {size[0]}×{size[1]}, Mitsuba {args.spp} spp;"
        f" ΔE2000 target ≤ {TARGET:g}"
    )
    print(
        f"{'hair':6} {'melanin':>7} {'engine':20} {'pixels':>7} {'raster L*a*b*':>22}"
        f" {'Mitsuba L*a*b*':>22} {'ΔE2000':>7}"
    )
    camera = None
    for name, melanin in MELANIN.items():
        groom = {"count": args.count, "melanin": melanin, "settle": args.settle}
        tables = {"mesh": {"path": args.mesh}, "guides": {"path": "builtin:long"}, "groom": groom}
        mesh, curves = grow(parse_scene(tables, "melanin"))
        if camera is None:
            camera = frame_scene(curves, mesh, 30.0, 1.0)
        mask = hair_mask(curves, mesh, camera, size)
        start = time.perf_counter()
        reference = follicle.render_image(
            curves, mesh, camera, engine="mitsuba", size=size, spp=args.spp
        )
        seconds = time.perf_counter() - start
        ref = mean_lab(reference, mask)
        for engine, options in rasters.items():
            raster = mean_lab(
                follicle.render_image(curves, mesh, camera, size=size, **options), mask
            )
            de = float(deltaE_ciede2000(raster, ref))
            print(
                f"{name:6} {melanin:7.2f} {engine:20} {int(mask.sum()):7d}"
                f" {np.array2string(raster, precision=1, floatmode='fixed'):>22}"
                f" {np.array2string(ref, precision=1, floatmode='fixed'):>22} {de:7.2f}"
                f"{'' if de <= TARGET else '  (over target)'}"
            )
        print(f"{'':6} (Mitsuba {seconds:.0f} s)")


if __name__ == "__main__":
    main()
