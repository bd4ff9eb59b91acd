"""Run by Blender's Python (bpy): model a small four-legged creature and export it.

    python make_creature.py OUT_FOLDER OUT.json

What a modeller might block out in Blender and hand follicle to grow fur on: a
metaball creature — an ellipsoid body, a ball head and four capsule legs, melted
together — converted to a mesh (Object → Convert → Mesh) and exported as OBJ with the
default exporter settings (Y up, −Z forward, metres) to ``creature.obj``. Written to
OUT.json: the file's name and the mesh's vertex and face counts.
"""

import json
import sys
from pathlib import Path

import bpy


def main():
    folder, findings = Path(sys.argv[-2]), Path(sys.argv[-1])
    bpy.ops.wm.read_factory_settings(use_empty=True)
    ball = bpy.data.metaballs.new("Creature")
    ball.resolution = 0.025
    ball.render_resolution = 0.025
    body = ball.elements.new(type="ELLIPSOID")
    body.co, body.radius = (0.0, 0.0, 0.36), 0.3
    body.size_x, body.size_y, body.size_z = 1.4, 0.75, 0.7
    head = ball.elements.new(type="BALL")
    head.co, head.radius = (0.33, 0.0, 0.5), 0.19
    for x in (-0.17, 0.17):
        for y in (-0.09, 0.09):
            leg = ball.elements.new(type="CAPSULE")
            leg.co, leg.radius, leg.size_x = (x, y, 0.2), 0.09, 0.12
            leg.rotation = (0.7071068, 0.0, 0.7071068, 0.0)  # the capsule's x axis down
    obj = bpy.data.objects.new("Creature", ball)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    bpy.ops.object.convert(target="MESH")
    mesh_obj = bpy.context.view_layer.objects.active
    out = folder / "creature.obj"
    bpy.ops.wm.obj_export(filepath=str(out), export_materials=False)
    found = {
        "file": out.name,
        "vertices": len(mesh_obj.data.vertices),
        "faces": len(mesh_obj.data.polygons),
    }
    findings.write_text(json.dumps(found))


main()
