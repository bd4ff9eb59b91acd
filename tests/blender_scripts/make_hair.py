"""Run by Blender's Python (bpy): make hair in Blender, export it to USD and Alembic.

    python make_hair.py OUT_FOLDER OUT.json

Builds, in an empty scene, what a Blender user would hand follicle:

- ``Head``: a UV sphere (radius 0.1 m, with its UV map), the skin;
- ``Hair``: a hair Curves object (Blender's ``CURVES`` type, Catmull-Rom, as its hair
  tools make) with one guide on each sphere vertex of the upper half, 8 points each,
  a tapering ``radius`` and a ``color`` attribute (FLOAT_COLOR, point domain: RGB and
  an alpha below 1);
- ``Nurbs``, ``Poly``, ``Bezier``: legacy curve objects, one spline each of that type
  (NURBS of order 4 with endpoint knots, rational weights; Bézier with auto handles),
  rooted on the sphere, radius 1e-4 m.

Every object is moved and turned by the same transform (up 1.6 m, 30° about Z), so
the exporters write it as an Xform and the reader must apply it. Each object is
exported on its own to ``<name>.usda`` (``wm.usd_export``, selected only, default
settings: Z up) and ``<name>.abc`` (``wm.alembic_export``: Alembic is Y up, Blender
converts). The findings (JSON; arrays in ``OUT.npz``) are the truth in Blender's world
space (Z up): the Curves' points, radii and colours, the head's vertices, corner
UVs and area, the legacy splines' control points, and each legacy curve evaluated by
Blender densely (its depsgraph mesh at high resolution), for the test side to compare
with what follicle reads.
"""

import json
import math
import sys
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix

RADIUS = 0.1  # the head sphere, metres
HAIR_POINTS = 8
CURVE_RADIUS = 1e-4  # metres: 0.2 mm thick, hair-like (Blender's default would be 1 cm)
TRANSFORM = Matrix.Translation((0.0, 0.0, 1.6)) @ Matrix.Rotation(math.radians(30.0), 4, "Z")


def _link(name, data):
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    obj.matrix_world = TRANSFORM
    return obj


def _head():
    bpy.ops.mesh.primitive_uv_sphere_add(radius=RADIUS, segments=24, ring_count=12)
    head = bpy.context.active_object
    head.name = head.data.name = "Head"
    head.matrix_world = TRANSFORM
    return head


def _hair(head):
    """Guides on the upper sphere vertices: out along the normal, then falling (−Z)."""
    co = np.array([v.co for v in head.data.vertices], dtype=np.float64)
    roots = co[co[:, 2] > 0.25 * RADIUS]
    roots = roots[np.lexsort((roots[:, 1], roots[:, 0], roots[:, 2]))]
    t = np.linspace(0.0, 1.0, HAIR_POINTS)[None, :, None]
    normal = roots / np.linalg.norm(roots, axis=1, keepdims=True)
    pos = roots[:, None] + 0.04 * t * normal[:, None] - 0.12 * t**2 * np.array([0, 0, 1.0])
    curves = bpy.data.hair_curves.new("Hair")
    curves.add_curves([HAIR_POINTS] * len(roots))
    curves.attributes["position"].data.foreach_set("vector", pos.astype(np.float32).ravel())
    radius = np.tile(np.linspace(CURVE_RADIUS, 0.4 * CURVE_RADIUS, HAIR_POINTS), len(roots))
    if "radius" not in curves.attributes:
        curves.attributes.new("radius", "FLOAT", "POINT")
    curves.attributes["radius"].data.foreach_set("value", radius.astype(np.float32))
    rng = np.random.default_rng(21)
    color = rng.random((len(roots) * HAIR_POINTS, 4)).astype(np.float32)
    color[:, 3] = 0.5 + 0.5 * color[:, 3]  # alpha in [0.5, 1]: an opacity to carry
    curves.attributes.new("color", "FLOAT_COLOR", "POINT").data.foreach_set("color", color.ravel())
    return _link("Hair", curves)


_SPLINE = [
    (0.0, 0.0, RADIUS),
    (0.0, 0.03, 0.12),
    (0.02, 0.06, 0.11),
    (0.02, 0.08, 0.08),
    (0.03, 0.09, 0.03),
    (0.03, 0.095, -0.02),
]


def _legacy(kind):
    curve = bpy.data.curves.new(kind, "CURVE")
    curve.dimensions = "3D"
    curve.resolution_u = 64  # dense evaluation for the truth; the exporters write CVs
    spline = curve.splines.new(kind.upper())
    if kind == "Bezier":
        spline.bezier_points.add(len(_SPLINE) - 1)
        for bp, p in zip(spline.bezier_points, _SPLINE, strict=True):
            bp.co = p
            bp.handle_left_type = bp.handle_right_type = "AUTO"
            bp.radius = CURVE_RADIUS
    else:
        spline.points.add(len(_SPLINE) - 1)
        weights = [1.0, 1.0, 2.0, 0.5, 1.0, 1.0] if kind == "Nurbs" else [1.0] * len(_SPLINE)
        for pt, p, w in zip(spline.points, _SPLINE, weights, strict=True):
            pt.co = (*p, w)
            pt.radius = CURVE_RADIUS
        if kind == "Nurbs":
            spline.order_u = 4
            spline.use_endpoint_u = True
    return _link(kind, curve)


def _world(obj, local):
    m = np.array(obj.matrix_world, dtype=np.float64)
    return np.asarray(local, dtype=np.float64) @ m[:3, :3].T + m[:3, 3]


def _truth(obj, arrays):
    """What Blender holds for ``obj``, world space."""
    info = {"type": obj.type}
    if obj.type == "CURVES":
        data = obj.data
        n = len(data.points)
        for name, field, comps in (
            ("position", "vector", 3),
            ("radius", "value", 1),
            ("color", "color", 4),
        ):
            flat = np.empty(n * comps, np.float32)
            data.attributes[name].data.foreach_get(field, flat)
            arrays[f"{obj.name}/{name}"] = flat.reshape(n, comps) if comps > 1 else flat
        arrays[f"{obj.name}/position"] = _world(obj, arrays[f"{obj.name}/position"])
        offsets = np.empty(len(data.curves) + 1, np.int32)
        data.curve_offset_data.foreach_get("value", offsets)
        arrays[f"{obj.name}/offsets"] = offsets
        info.update(curves=len(data.curves), points=n)
    elif obj.type == "CURVE":
        spline = obj.data.splines[0]
        if spline.type == "BEZIER":
            cvs = [bp.co[:] for bp in spline.bezier_points]
        else:
            cvs = [pt.co[:3] for pt in spline.points]
        arrays[f"{obj.name}/control_points"] = _world(obj, cvs)
        evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
        arrays[f"{obj.name}/evaluated"] = _world(obj, [v.co[:] for v in evaluated.vertices])
        info.update(spline=spline.type, control_points=len(cvs))
    elif obj.type == "MESH":
        mesh = obj.data
        arrays[f"{obj.name}/position"] = _world(obj, [v.co[:] for v in mesh.vertices])
        corners = [loop.vertex_index for loop in mesh.loops]
        arrays[f"{obj.name}/corner_position"] = arrays[f"{obj.name}/position"][corners]
        arrays[f"{obj.name}/corner_uv"] = np.array(
            [d.uv[:] for d in mesh.uv_layers.active.data], dtype=np.float64
        )
        info.update(
            vertices=len(mesh.vertices),
            faces=len(mesh.polygons),
            uv_maps=[u.name for u in mesh.uv_layers],
            area=sum(p.area for p in mesh.polygons),
        )  # a rigid transform keeps it
    return info


def main():
    folder, out = Path(sys.argv[1]), Path(sys.argv[2])
    bpy.ops.wm.read_factory_settings(use_empty=True)
    head = _head()
    objects = [head, _hair(head), *(_legacy(k) for k in ("Nurbs", "Poly", "Bezier"))]
    bpy.context.view_layer.update()
    arrays, report = {}, {"blender": bpy.app.version_string, "objects": {}, "files": {}}
    for obj in objects:
        report["objects"][obj.name] = _truth(obj, arrays)
    for obj in objects:
        for other in objects:
            other.select_set(other is obj)
        bpy.context.view_layer.objects.active = obj
        usd, abc = folder / f"{obj.name}.usda", folder / f"{obj.name}.abc"
        done_usd = bpy.ops.wm.usd_export(
            filepath=str(usd), selected_objects_only=True, export_materials=False
        )
        done_abc = bpy.ops.wm.alembic_export(
            filepath=str(abc), selected=True, as_background_job=False
        )
        report["files"][obj.name] = {
            "usd": [str(usd), sorted(done_usd)],
            "abc": [str(abc), sorted(done_abc)],
        }
    np.savez(out.with_suffix(".npz"), **arrays)
    report["arrays"] = str(out.with_suffix(".npz"))
    out.write_text(json.dumps(report, indent=1))


main()
