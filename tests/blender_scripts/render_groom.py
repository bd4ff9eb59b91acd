"""Run by Blender's Python (bpy): render a follicle groom file in Blender with Cycles.

    python render_groom.py GROOM.usdc OUT.png [--size 640] [--samples 16] [--melanin M]

What a user would do with ``follicle grow … -o groom.usdc --target blender``: import
it (File → Import, default settings) and give the hair a Principled Hair BSDF (Chiang
model). A groom grown from melanin comes in with per-hair ``melanin``,
``melanin_redness`` (FLOAT) and ``dye`` (FLOAT_VECTOR) curve attributes: Attribute
nodes of those names feed its Melanin, Melanin Redness and Tint (Melanin concentration
parametrisation, Random Color 0: each hair's values are drawn already), so every hair
has its own pigment; other hair takes its own colour (the ``displayColor`` attribute
the importer made of our ``color``); ``--melanin M`` gives every hair melanin M. The
skin gets a plain skin-toned Principled BSDF, the guides are hidden, and Cycles renders
on the CPU: three area lights (key, fill, and a rim light behind, which hair needs to
read as hair), a grey-blue world, a camera framing skin and hair from the front-left
as follicle's own renderer does (its default view direction (0.35, 0.15, 1) in Y up is
(0.35, -1, 0.15) in Blender's Z up), OpenImageDenoise on. docs/blender.png (the default
scene: 20,000 hairs on the built-in bust, settled; it has no melanin) is made so, from
the repository root, after the Blender tests have made .venv-blender (or with any
Python that has bpy 5.0.1):

    printf '[groom]\nsettle = 2.0\n' > /tmp/default.toml   # the demo's scene: settled
    .venv/bin/follicle grow /tmp/default.toml --count 20000 --target blender \
        -o /tmp/groom.usdc
    .venv-blender/bin/python tests/blender_scripts/render_groom.py /tmp/groom.usdc \
        docs/blender.png

(16 samples: 20–102 s of rendering on two shared cores, 2026-12-06). It prints what it
imported, what colours the hair, and the render time. ``melanin_render.py`` uses its
parts (it runs this file's functions, not its ``main``).
"""

import argparse
import math
import os
import sys
import time

import bpy
import numpy as np
from mathutils import Vector


def _args():
    parser = argparse.ArgumentParser(description="render a follicle groom in Blender")
    parser.add_argument("groom", help="USD or Alembic file from follicle grow / export")
    parser.add_argument("out", help="PNG to write")
    parser.add_argument("--size", type=int, default=640, help="image width and height")
    parser.add_argument("--samples", type=int, default=16, help="Cycles samples per pixel")
    parser.add_argument(
        "--melanin",
        type=float,
        default=None,
        help="colour every hair by this melanin (0-1) instead of its own (its melanin"
        " attributes if it has them, else its colour)",
    )
    parser.add_argument(
        "--eye",
        type=float,
        nargs=3,
        default=None,
        help="the camera's eye in follicle's coordinates (Y up, metres), as a scene's"
        " [render] eye; with --target: that view instead of the framing one",
    )
    parser.add_argument("--target", type=float, nargs=3, default=None, help="what it looks at")
    parser.add_argument("--fov", type=float, default=30.0, help="vertical field of view, degrees")
    return parser.parse_args(sys.argv[1:])


def _z_up(p):
    """A point of follicle's Y-up frame in Blender's Z-up one (USD import's conversion)."""
    return np.array([p[0], -p[2], p[1]], dtype=np.float64)


def _basis(back):
    """(right, up, back) of a camera looking along −``back``, Z up."""
    back = back / np.linalg.norm(back)
    right = np.cross(back, [0.0, 0.0, 1.0])
    right /= -np.linalg.norm(right)
    return np.stack([right, np.cross(back, right), back])


def _nodes(block):
    """``block``'s node tree (Blender 5 makes one for every material and world; the
    ``use_nodes`` switch of earlier versions is deprecated)."""
    if block.node_tree is None:
        block.use_nodes = True
    return block.node_tree


PIGMENTS = ("melanin", "melanin_redness", "dye")  # what a groom grown from melanin carries


def is_hair(obj):
    """Whether ``obj`` is hair: a Curves object other than the guides (data "Guides")."""
    return obj.type == "CURVES" and obj.data.name != "Guides"


def has_pigments(objects):
    """Whether every hair Curves object of ``objects`` has follicle's per-hair ``melanin``
    and ``melanin_redness`` (what the USD importer makes of a melanin groom's primvars)."""
    hair = [o for o in objects if is_hair(o)]
    return bool(hair) and all(
        n in o.data.attributes for o in hair for n in ("melanin", "melanin_redness")
    )


def hair_material(melanin=None, pigments=False, dye=True):
    """A Principled Hair BSDF (Chiang model). ``melanin`` (0-1): that melanin for every
    hair; else with ``pigments`` each hair's own: Attribute nodes ``melanin``,
    ``melanin_redness`` (and ``dye``, to the Tint, when ``dye``) into the Melanin
    concentration parametrisation, Random Color 0 (the values are per hair already);
    else the hair's own colour, the ``displayColor`` the importer made of ``color``."""
    mat = bpy.data.materials.new("follicle hair")
    _nodes(mat)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    hair = nodes.new("ShaderNodeBsdfHairPrincipled")
    out = nodes.new("ShaderNodeOutputMaterial")
    links.new(hair.outputs[0], out.inputs["Surface"])
    hair.model = "CHIANG"
    hair.inputs["Roughness"].default_value = 0.25
    hair.inputs["Radial Roughness"].default_value = 0.5
    hair.inputs["Coat"].default_value = 0.1

    def attribute(name, output, socket):
        node = nodes.new("ShaderNodeAttribute")
        node.attribute_name = name
        links.new(node.outputs[output], hair.inputs[socket])

    if melanin is not None:
        hair.parametrization = "MELANIN"
        hair.inputs["Melanin"].default_value = melanin
        hair.inputs["Melanin Redness"].default_value = 0.6
    elif pigments:
        hair.parametrization = "MELANIN"
        hair.inputs["Random Color"].default_value = 0.0
        attribute("melanin", "Factor", "Melanin")
        attribute("melanin_redness", "Factor", "Melanin Redness")
        if dye:
            attribute("dye", "Color", "Tint")
    else:
        hair.parametrization = "COLOR"  # direct colouring, from the hair's own colour
        attribute("displayColor", "Color", "Color")
    return mat


def skin_material():
    mat = bpy.data.materials.new("follicle skin")
    bsdf = _nodes(mat).nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.62, 0.38, 0.27, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.55
    return mat


def world_points(obj):
    if obj.type == "CURVES":
        n = len(obj.data.points)
        local = np.empty(n * 3, np.float32)
        obj.data.attributes["position"].data.foreach_get("vector", local)
    else:
        local = np.empty(len(obj.data.vertices) * 3, np.float32)
        obj.data.vertices.foreach_get("co", local)
    m = np.array(obj.matrix_world)
    return local.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]


def area_light(name, location, target, energy, size):
    light = bpy.data.lights.new(name, "AREA")
    light.energy, light.size = energy, size
    obj = bpy.data.objects.new(name, light)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = location
    obj.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    return obj


def import_groom(path):
    """An empty scene with ``path`` (USD or Alembic) imported as File → Import does."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if path.endswith(".abc"):
        bpy.ops.wm.alembic_import(filepath=path, as_background_job=False)
    else:
        bpy.ops.wm.usd_import(filepath=path)


def dress(hair_mat, skin_mat):
    """``hair_mat`` on every hair Curves object, ``skin_mat`` (smooth) on every mesh, the
    guides hidden (they are for grooming, not for the picture): the objects shown."""
    shown = []
    for obj in bpy.data.objects:
        if is_hair(obj):
            obj.data.materials.clear()
            obj.data.materials.append(hair_mat)
            shown.append(obj)
        elif obj.type == "CURVES":
            obj.hide_render = True
        elif obj.type == "MESH":
            obj.data.materials.clear()
            obj.data.materials.append(skin_mat)
            for poly in obj.data.polygons:
                poly.use_smooth = True
            shown.append(obj)
    return shown


def world(color, strength):
    """A plain world of ``color`` (linear RGB) at ``strength``."""
    block = bpy.data.worlds.new("world")
    background = _nodes(block).nodes["Background"]
    background.inputs["Color"].default_value = (*color, 1)
    background.inputs["Strength"].default_value = strength
    bpy.context.scene.world = block


def cycles(size, samples, out, denoise=True):
    """Cycles on the CPU, ``size``² pixels, ``samples`` per pixel, hair as thick curves
    with the transmission bounces it needs to light up, to the PNG ``out``."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = denoise
    scene.cycles.max_bounces = 8
    scene.cycles_curves.shape = "THICK"
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = os.path.abspath(out)  # Blender's own relative paths start at the .blend


def main():
    args = _args()
    import_groom(args.groom)
    pigments = args.melanin is None and has_pigments(bpy.data.objects)
    hair_mat = hair_material(args.melanin, pigments)
    shown = dress(hair_mat, skin_material())
    print(
        "render_groom: showing",
        [(o.name, o.type) for o in shown],
        "coloured by",
        f"melanin {args.melanin}"
        if args.melanin is not None
        else ("each hair's melanin" if pigments else "displayColor"),
    )
    points = np.concatenate([world_points(o) for o in shown])
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = 0.5 * (lo + hi)
    radius = 0.5 * float(np.linalg.norm(hi - lo))  # for the lights' placement and size

    scene = bpy.context.scene
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(cam)
    fov = math.radians(args.fov)
    cam.data.angle = fov
    framing = _basis(np.array([0.35, -1.0, 0.15]))  # from the centre towards the eye
    if args.eye is not None and args.target is not None:
        eye, look_at = _z_up(args.eye), _z_up(args.target)
        view = _basis(eye - look_at)
    else:
        right, up, back = framing
        rel = points - centre
        across, height, depth = np.abs(rel @ right), np.abs(rel @ up), rel @ back
        # the nearest eye distance d at which every point is inside the view (5 % border):
        # |across| and |height| ≤ tan(fov / 2) · (d − depth)
        half = math.tan(fov / 2) / 1.1
        distance = float(np.max(np.maximum(across, height) / half + depth))
        eye, look_at, view = centre + back * distance, centre, framing
    cam.location = eye.tolist()
    cam.rotation_euler = (
        (Vector(look_at.tolist()) - Vector(eye.tolist())).to_track_quat("-Z", "Y").to_euler()
    )
    scene.camera = cam
    r = radius
    c = centre
    # the lights sit as they do for the framing view, turned with the camera: they follow
    # it, as follicle's camera-space lights do
    turn = view.T @ framing
    for name, offset, energy, size in (
        ("key", (2.0, -2.5, 2.0), 60.0, 1.0),
        ("fill", (-3.0, -1.5, 0.3), 18.0, 2.0),
        ("rim", (-0.8, 3.0, 2.5), 80.0, 1.0),
    ):
        place = c + turn @ (np.array(offset) * r)
        area_light(name, tuple(place), c, energy * r * r, size * r)

    world((0.2, 0.23, 0.28), 0.6)
    cycles(args.size, args.samples, args.out)
    scene.view_settings.view_transform = "AgX"
    scene.view_settings.look = "AgX - Medium High Contrast"
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    print(
        f"render_groom: {args.out} ({args.size}×{args.size}, {args.samples} samples) in"
        f" {time.perf_counter() - start:.1f} s"
    )


if __name__ == "__main__":
    main()
