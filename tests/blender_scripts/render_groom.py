"""Run by Blender's Python (bpy): render a follicle groom file in Blender with Cycles.

    python render_groom.py GROOM.usdc OUT.png [--size 640] [--samples 16]

What a user would do with ``follicle grow … -o groom.usdc --target blender``: import
it (File → Import, default settings), give the hair a Principled Hair BSDF whose colour
is the hair's own (the ``displayColor`` attribute the importer made of our ``color``),
give the skin a plain skin-toned Principled BSDF, hide the guides, and render with
Cycles on the CPU: three area lights (key, fill, and a rim light behind, which hair
needs to read as hair), a grey-blue world, a camera framing skin and hair from the
front-left as follicle's own renderer does (its default view direction (0.35, 0.15, 1)
in Y up is (0.35, -1, 0.15) in Blender's Z up), OpenImageDenoise on. docs/blender.png
(the default scene's 20,000 hairs) is made so, from the repository root, after the
Blender tests have made .venv-blender (or with any Python that has bpy 5.0.1):

    printf '' > /tmp/default.toml   # an empty scene file: the default scene
    .venv/bin/follicle grow /tmp/default.toml --count 20000 --target blender \
        -o /tmp/groom.usdc
    .venv-blender/bin/python tests/blender_scripts/render_groom.py /tmp/groom.usdc \
        docs/blender.png

(16 samples: under a minute of rendering on two cores). It prints what it imported
and the render time.
"""

import argparse
import math
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
        help="colour the hair by melanin (0-1) instead of its own colour",
    )
    return parser.parse_args(sys.argv[1:])


def _nodes(block):
    """``block``'s node tree (Blender 5 makes one for every material and world; the
    ``use_nodes`` switch of earlier versions is deprecated)."""
    if block.node_tree is None:
        block.use_nodes = True
    return block.node_tree


def _hair_material(melanin):
    mat = bpy.data.materials.new("follicle hair")
    _nodes(mat)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    hair = nodes.new("ShaderNodeBsdfHairPrincipled")
    out = nodes.new("ShaderNodeOutputMaterial")
    links.new(hair.outputs[0], out.inputs["Surface"])
    hair.inputs["Roughness"].default_value = 0.25
    hair.inputs["Radial Roughness"].default_value = 0.5
    hair.inputs["Coat"].default_value = 0.1
    if melanin is not None:
        hair.parametrization = "MELANIN"
        hair.inputs["Melanin"].default_value = melanin
        hair.inputs["Melanin Redness"].default_value = 0.6
    else:
        hair.parametrization = "COLOR"  # direct colouring, from the hair's own colour
        attr = nodes.new("ShaderNodeAttribute")
        attr.attribute_name = "displayColor"
        links.new(attr.outputs["Color"], hair.inputs["Color"])
    return mat


def _skin_material():
    mat = bpy.data.materials.new("follicle skin")
    bsdf = _nodes(mat).nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.62, 0.38, 0.27, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.55
    return mat


def _world_points(obj):
    if obj.type == "CURVES":
        n = len(obj.data.points)
        local = np.empty(n * 3, np.float32)
        obj.data.attributes["position"].data.foreach_get("vector", local)
    else:
        local = np.empty(len(obj.data.vertices) * 3, np.float32)
        obj.data.vertices.foreach_get("co", local)
    m = np.array(obj.matrix_world)
    return local.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]


def _area_light(name, location, target, energy, size):
    light = bpy.data.lights.new(name, "AREA")
    light.energy, light.size = energy, size
    obj = bpy.data.objects.new(name, light)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = location
    obj.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    return obj


def main():
    args = _args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if args.groom.endswith(".abc"):
        bpy.ops.wm.alembic_import(filepath=args.groom, as_background_job=False)
    else:
        bpy.ops.wm.usd_import(filepath=args.groom)
    hair_mat, skin_mat = _hair_material(args.melanin), _skin_material()
    shown = []
    for obj in bpy.data.objects:
        data_name = obj.data.name if obj.data is not None else ""
        if obj.type == "CURVES" and data_name == "Guides":
            obj.hide_render = True  # the guides are for grooming, not for the picture
        elif obj.type == "CURVES":
            obj.data.materials.clear()
            obj.data.materials.append(hair_mat)
            shown.append(obj)
        elif obj.type == "MESH":
            obj.data.materials.clear()
            obj.data.materials.append(skin_mat)
            for poly in obj.data.polygons:
                poly.use_smooth = True
            shown.append(obj)
    print("render_groom: showing", [(o.name, o.type) for o in shown])
    points = np.concatenate([_world_points(o) for o in shown])
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = 0.5 * (lo + hi)
    radius = 0.5 * float(np.linalg.norm(hi - lo))  # for the lights' placement and size

    scene = bpy.context.scene
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(cam)
    fov = math.radians(30.0)
    cam.data.angle = fov
    back = np.array([0.35, -1.0, 0.15])  # from the centre towards the eye
    back /= np.linalg.norm(back)
    right = np.cross(back, [0.0, 0.0, 1.0])
    right /= -np.linalg.norm(right)
    up = np.cross(back, right)
    rel = points - centre
    across, height, depth = np.abs(rel @ right), np.abs(rel @ up), rel @ back
    # the nearest eye distance d at which every point is inside the view (5 % border):
    # |across| and |height| ≤ tan(fov / 2) · (d − depth)
    half = math.tan(fov / 2) / 1.1
    distance = float(np.max(np.maximum(across, height) / half + depth))
    eye = centre + back * distance
    cam.location = eye.tolist()
    cam.rotation_euler = (
        (Vector(centre.tolist()) - Vector(eye.tolist())).to_track_quat("-Z", "Y").to_euler()
    )
    scene.camera = cam
    r = radius
    c = centre
    _area_light("key", (c[0] + 2.0 * r, c[1] - 2.5 * r, c[2] + 2.0 * r), c, 60.0 * r * r, r)
    _area_light("fill", (c[0] - 3.0 * r, c[1] - 1.5 * r, c[2] + 0.3 * r), c, 18.0 * r * r, 2 * r)
    _area_light("rim", (c[0] - 0.8 * r, c[1] + 3.0 * r, c[2] + 2.5 * r), c, 80.0 * r * r, r)

    world = bpy.data.worlds.new("world")
    background = _nodes(world).nodes["Background"]
    background.inputs["Color"].default_value = (0.2, 0.23, 0.28, 1)
    background.inputs["Strength"].default_value = 0.6
    scene.world = world

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = args.samples
    scene.cycles.use_denoising = True
    scene.cycles.max_bounces = 8  # hair needs a few transmission bounces to light up
    scene.cycles_curves.shape = "THICK"
    scene.render.resolution_x = scene.render.resolution_y = args.size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.view_settings.view_transform = "AgX"
    scene.view_settings.look = "AgX - Medium High Contrast"
    scene.render.filepath = args.out
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    print(
        f"render_groom: {args.out} ({args.size}×{args.size}, {args.samples} samples) in"
        f" {time.perf_counter() - start:.1f} s"
    )


main()
