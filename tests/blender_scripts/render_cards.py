"""Run by Blender's Python (bpy): import follicle's hair cards (.glb) and render them.

    python render_cards.py CARDS.glb|CARDS.usda VIEWS.json OUT_DIR FINDINGS.json

What a user would do with ``follicle cards … -o hair_cards.glb``: File → Import → glTF
2.0 (or Universal Scene Description, for a .usd/.usda/.usdc) with the default settings.
Written to FINDINGS: the objects the importer made (name, vertices, faces, material,
the images loaded), and for each view of VIEWS (a list of ``{"name", "eye", "target",
"up", "fov_y", "size"}`` in follicle's Y up metres, and optionally ``"lod"``, 0 when not
given, and ``"unlit"``) the path of a Cycles render of that level (the other levels
hidden) on a transparent film, lit by a uniform white world, RGBA PNG; an unlit view
shows each card's texture colour as it is (the imported material's base colour texture
wired to an emission of strength 1, its alpha test kept), for comparing colours without
comparing lighting. Both files are Y up;
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


def _unlit_surfaces():
    """Each imported material's output, lit (its Principled BSDF) and unlit (the base
    colour's link as an emission, mixed with transparency by the BSDF's alpha link)."""
    outputs = []
    for mat in bpy.data.materials:
        if not mat.use_nodes:
            continue
        tree = mat.node_tree
        bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
        out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
        emit = tree.nodes.new("ShaderNodeEmission")
        emit.inputs["Strength"].default_value = 1.0
        tree.links.new(bsdf.inputs["Base Color"].links[0].from_socket, emit.inputs["Color"])
        mix = tree.nodes.new("ShaderNodeMixShader")
        tree.links.new(bsdf.inputs["Alpha"].links[0].from_socket, mix.inputs["Fac"])
        tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[1])
        tree.links.new(emit.outputs[0], mix.inputs[2])
        outputs.append((tree, out, bsdf.outputs[0], mix.outputs[0]))
    return outputs


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
    surfaces = _unlit_surfaces()
    for view in json.loads(Path(views_path).read_text()):
        for tree, out, lit, unlit in surfaces:
            tree.links.new(unlit if view.get("unlit") else lit, out.inputs["Surface"])
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
