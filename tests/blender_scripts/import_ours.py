"""Run by Blender's Python (bpy): import follicle's USD and Alembic files, report what came in.

    python import_ours.py FILE [FILE …] OUT.json

Each FILE is imported into an empty scene (``wm.usd_import`` / ``wm.alembic_import``
with their default settings, as a user's File → Import would). For every object the
findings name its type, its data's name, its parent and its world matrix; for hair
curves the curve and point counts and every attribute (name, domain, data type); for a
mesh its vertex, face and corner counts and UV maps. The arrays (world-space positions
after Blender's own axis conversion, radii, curve offsets, curve-domain attribute
values, corner UVs, face vertex indices) go to ``OUT.npz`` under ``"<file>/<data
name>/<what>"``; the JSON says where. The test side (tests/test_blender.py) compares
them with the curves follicle wrote: this script only measures.
"""

import json
import sys
from pathlib import Path

import bpy
import numpy as np

_COMPONENTS = {
    "FLOAT": 1,
    "INT": 1,
    "INT8": 1,
    "BOOLEAN": 1,
    "FLOAT2": 2,
    "INT32_2D": 2,
    "FLOAT_VECTOR": 3,
    "FLOAT_COLOR": 4,
    "BYTE_COLOR": 4,
    "QUATERNION": 4,
}
_FIELD = {
    "FLOAT_VECTOR": "vector",
    "FLOAT2": "vector",
    "FLOAT_COLOR": "color",
    "BYTE_COLOR": "color",
    "QUATERNION": "value",
}  # others: "value"


def _values(attribute, count):
    """An attribute's values as a numpy array (count rows)."""
    comps = _COMPONENTS.get(attribute.data_type)
    if comps is None:
        return None
    dtype = np.int32 if attribute.data_type in ("INT", "INT8", "INT32_2D") else np.float32
    if attribute.data_type == "BOOLEAN":
        dtype = bool
    flat = np.empty(count * comps, dtype)
    attribute.data.foreach_get(_FIELD.get(attribute.data_type, "value"), flat)
    return flat.reshape(count, comps) if comps > 1 else flat


def _world(obj, local):
    m = np.array(obj.matrix_world, dtype=np.float64)
    return (local.astype(np.float64) @ m[:3, :3].T + m[:3, 3]).astype(np.float64)


def _curves(obj, key, arrays):
    data = obj.data
    n_points, n_curves = len(data.points), len(data.curves)
    offsets = np.empty(n_curves + 1, np.int32)
    data.curve_offset_data.foreach_get("value", offsets)
    arrays[f"{key}/offsets"] = offsets
    attrs = []
    for a in data.attributes:
        if a.name.startswith("."):
            continue  # Blender's internal ones (selection and the like)
        attrs.append({"name": a.name, "domain": a.domain, "type": a.data_type})
        count = n_points if a.domain == "POINT" else n_curves
        values = _values(a, count)
        if values is None:
            continue
        if a.name == "position":
            arrays[f"{key}/local_position"] = values
            values = _world(obj, values)
        arrays[f"{key}/{a.name}"] = values
    return {"curves": n_curves, "points": n_points, "attributes": attrs}


def _mesh(obj, key, arrays):
    mesh = obj.data
    local = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", local)
    arrays[f"{key}/position"] = _world(obj, local.reshape(-1, 3))
    corners = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    arrays[f"{key}/corner_vertex"] = corners
    sizes = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("loop_total", sizes)
    arrays[f"{key}/face_sizes"] = sizes
    for layer in mesh.uv_layers:
        uv = np.empty(len(mesh.loops) * 2, np.float32)
        layer.data.foreach_get("uv", uv)
        arrays[f"{key}/uv:{layer.name}"] = uv.reshape(-1, 2)
    return {
        "vertices": len(mesh.vertices),
        "faces": len(mesh.polygons),
        "corners": len(mesh.loops),
        "uv_maps": [u.name for u in mesh.uv_layers],
        "attributes": [
            {"name": a.name, "domain": a.domain, "type": a.data_type}
            for a in mesh.attributes
            if not a.name.startswith(".")
        ],
    }


def main():
    *files, out = sys.argv[1:]
    out = Path(out)
    arrays, report = {}, {"blender": bpy.app.version_string, "files": {}}
    for name in files:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        if name.endswith(".abc"):
            result = bpy.ops.wm.alembic_import(filepath=name, as_background_job=False)
        else:
            result = bpy.ops.wm.usd_import(filepath=name)
        objects = []
        for obj in sorted(bpy.data.objects, key=lambda o: o.name):
            data_name = obj.data.name if obj.data is not None else None
            entry = {
                "name": obj.name,
                "type": obj.type,
                "data": data_name,
                "parent": obj.parent.name if obj.parent else None,
                "matrix_world": [list(row) for row in obj.matrix_world],
            }
            key = f"{Path(name).name}/{data_name}"
            if obj.type == "CURVES":
                entry.update(_curves(obj, key, arrays))
            elif obj.type == "MESH":
                entry.update(_mesh(obj, key, arrays))
            entry["key"] = key
            objects.append(entry)
        report["files"][Path(name).name] = {"result": sorted(result), "objects": objects}
    np.savez(out.with_suffix(".npz"), **arrays)
    report["arrays"] = str(out.with_suffix(".npz"))
    out.write_text(json.dumps(report, indent=1))


main()
