"""Run by Blender's Python (bpy): import follicle's hair cards (.glb) and render them.

    python render_cards.py CARDS.glb|CARDS.usda VIEWS.json OUT_DIR FINDINGS.json

What a user would do with ``follicle cards … -o hair_cards.glb``: File → Import → glTF
2.0 (or Universal Scene Description, for a .usd/.usda/.usdc) with the default settings.
Written to FINDINGS: the objects the importer made (name, vertices, faces, material,
the images loaded), and for each view of VIEWS (a list of ``{"name", "eye", "target",
"up", "fov_y", "size"}`` in follicle's Y up metres, and optionally ``"lod"``, 0 when not
given) the path of a Cycles render of that level (the other levels hidden) on a
transparent film, lit by a uniform white world, RGBA PNG. Both files are Y up;
Blender's importers turn a point (x, y, z) into (x, −z, y), and so are the cameras
placed here.
"""

import json
import math
import sys
from pathlib import Path

import bpy
from mathutils import Matrix, Vector


def _blender(v):
    """follicle's Y up (x, y, z) as Blender's Z up."""
    return Vector((v[0], -v[2], v[1]))


def _camera(view):
    eye, target = _blender(view["eye"]), _blender(view["target"])
    forward = (target - eye).normalized()
    up = _blender(view["up"])
    right = forward.cross(up).normalized()
    up = right.cross(forward)
    data = bpy.data.cameras.new(view["name"])
    data.sensor_fit = "VERTICAL"
    data.angle_y = math.radians(view["fov_y"])
    data.clip_start = 0.01
    data.clip_end = 100.0
    cam = bpy.data.objects.new(view["name"], data)
    bpy.context.scene.collection.objects.link(cam)
    rot = Matrix((right, up, -forward)).transposed().to_4x4()
    cam.matrix_world = Matrix.Translation(eye) @ rot
    return cam


def main():
    glb, views_path, out_dir, findings_path = sys.argv[-4:]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if glb.lower().endswith(".glb"):
        bpy.ops.import_scene.gltf(filepath=glb)
    else:  # USD: the coarser levels are invisible, and not imported by default
        bpy.ops.wm.usd_import(filepath=glb)
    found = {"objects": []}
    scene = bpy.context.scene
    for obj in bpy.data.objects:
        if obj.type != "MESH":
            continue
        if scene.collection not in obj.users_collection:
            # a coarser level (MSFT_lod) is no node of the scene: the importer puts it
            # in an "Orphan Nodes" collection, which does not render
            scene.collection.objects.link(obj)
        mat = obj.active_material
        found["objects"].append(
            {
                "name": obj.name,
                "vertices": len(obj.data.vertices),
                "faces": len(obj.data.polygons),
                "material": mat.name if mat else None,
                "images": sorted(i.name for i in bpy.data.images),
            }
        )
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False
    scene.render.film_transparent = True
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    world = bpy.data.worlds.new("white")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (1, 1, 1, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    scene.world = world
    found["renders"] = {}
    for view in json.loads(Path(views_path).read_text()):
        for obj in bpy.data.objects:
            if obj.type == "MESH":
                obj.hide_render = not obj.name.endswith(f"LOD{view.get('lod', 0)}")
        scene.camera = _camera(view)
        scene.render.resolution_x = scene.render.resolution_y = view["size"]
        scene.render.resolution_percentage = 100
        out = str(Path(out_dir) / f"blender_{view['name']}.png")
        scene.render.filepath = out
        bpy.ops.render.render(write_still=True)
        found["renders"][view["name"]] = out
    Path(findings_path).write_text(json.dumps(found, indent=1))


main()
