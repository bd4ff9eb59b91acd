"""Run by Blender's Python (bpy): render a follicle groom coloured by each hair's melanin.

    python melanin_render.py GROOM.usdc OUT.json [--size 96] [--samples 8]

Imports the groom (File → Import, default settings) and renders it twice with Cycles,
with the Principled Hair BSDF that ``render_groom.py`` gives hair (Chiang model, Melanin
concentration parametrisation): ``OUT_attributes.png`` with Attribute nodes ``melanin``,
``melanin_redness`` and ``dye`` feeding its Melanin, Melanin Redness and Tint (each
hair's own values), and ``OUT_constant.png`` with the same file and one melanin (0.5)
in the shader. The camera looks at the hair from the front (along +Y, orthographic,
image right = +X) and the light is symmetric about the hair's centre in X, so the
image's left and right halves are lit alike; the background is transparent, so the
alpha says which pixels are hair. The findings name both pictures and the hair's X
extent; the test side (tests/test_blender.py) reads the pixels: this script only renders.
"""

import argparse
import json
import sys
import time
from pathlib import Path

import bpy
import numpy as np
from render_groom import (
    area_light,
    cycles,
    dress,
    hair_material,
    has_pigments,
    import_groom,
    skin_material,
    world,
    world_points,
)


def _args():
    parser = argparse.ArgumentParser(description="render a groom by its hairs' melanin")
    parser.add_argument("groom")
    parser.add_argument("out", help="findings (JSON); the PNGs beside it")
    parser.add_argument("--size", type=int, default=96)
    parser.add_argument("--samples", type=int, default=8)
    return parser.parse_args(sys.argv[1:])


def _front_camera(lo, hi):
    """An orthographic camera in front of the box (lo, hi) (at −Y, looking along +Y),
    framing its X and Z extent with a 10 % border."""
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    bpy.context.scene.collection.objects.link(cam)
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 1.1 * float(max(hi[0] - lo[0], hi[2] - lo[2]))
    centre = 0.5 * (lo + hi)
    cam.location = (centre[0], lo[1] - 1.0, centre[2])
    cam.rotation_euler = (np.pi / 2, 0.0, 0.0)  # −Z (its view) turned to +Y, up +Z
    bpy.context.scene.camera = cam


def main():
    args = _args()
    out = Path(args.out)
    import_groom(args.groom)
    pigments = has_pigments(bpy.data.objects)
    found = {"blender": bpy.app.version_string, "pigments": pigments, "renders": {}}
    for mode, melanin in (("attributes", None), ("constant", 0.5)):
        shown = dress(hair_material(melanin, pigments=True), skin_material())
        if mode == "attributes":
            points = np.concatenate([world_points(o) for o in shown])
            lo, hi = points.min(axis=0), points.max(axis=0)
            centre, r = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
            _front_camera(lo, hi)
            c = centre
            area_light("key", (c[0], c[1] - 2 * r, c[2] + r), c, 40.0 * r * r, r)
            area_light("rim", (c[0], c[1] + 2 * r, c[2] + r), c, 40.0 * r * r, r)
            world((0.5, 0.5, 0.5), 0.5)
            bpy.context.scene.render.film_transparent = True
            bpy.context.scene.view_settings.view_transform = "Standard"
            found["x_range"] = [float(lo[0]), float(hi[0])]
        png = str(out.with_name(f"{out.stem}_{mode}.png"))
        cycles(args.size, args.samples, png, denoise=False)
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        found["renders"][mode] = {"png": png, "seconds": time.perf_counter() - start}
    out.write_text(json.dumps(found, indent=1))


main()
