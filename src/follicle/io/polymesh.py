"""Polygon meshes from scene files (USD, Alembic) as a SkinMesh.

The guarded readers (:mod:`follicle.io.usd_mesh`, :mod:`follicle.io.alembic_archive`)
hand over a mesh as a file holds it: points, polygon sizes, polygon corners and UVs per
vertex or per corner (faceVarying). :func:`skin_from_part` checks those against each
other, turns polygons into triangles (a fan from each polygon's first corner: exact for
the convex polygons skins are made of) and gives UVs one per vertex: a vertex whose
corners carry different UVs (a seam) is split into one vertex per distinct UV, the
first keeping its index, so a mesh without seams keeps its vertex order.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError
from ..inputs import input_file
from ..mesh.skin import SkinMesh
from .usd_guard import check_container, read_meshes

__all__ = [
    "skin_from_part",
    "scaled_skin",
    "polygon_layout",
    "load_usd_mesh",
    "fan_triangles",
    "split_seams",
]

log = logging.getLogger("follicle")


def fan_triangles(counts: np.ndarray) -> np.ndarray:
    """(T, 3) corner indices of the triangles fanning each polygon of ``counts`` corners
    (corners numbered one polygon after another) from its first corner."""
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    per = counts.astype(np.int64) - 2
    polygon = np.repeat(np.arange(len(counts)), per)
    k = np.arange(int(per.sum())) - np.repeat(np.cumsum(per) - per, per) + 1
    base = starts[polygon]
    return np.stack([base, base + k, base + k + 1], axis=1)


def split_seams(
    corner_vertex: np.ndarray, corner_uv: np.ndarray, vertex_count: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-corner UVs made per-vertex: (vertex of each corner, source vertex of each
    output vertex, (V', 2) UVs). Each distinct (vertex, UV) pair is one output vertex;
    a vertex's first pair (in corner order) keeps its index, the others are appended
    in the order they first appear. Vertices no corner uses keep UV (0, 0)."""
    keys = np.empty(len(corner_vertex), dtype=[("v", "<i8"), ("u", "<f8"), ("w", "<f8")])
    keys["v"], keys["u"], keys["w"] = corner_vertex, corner_uv[:, 0], corner_uv[:, 1]
    unique, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    order = np.lexsort((first, unique["v"]))  # by vertex, then by first appearance
    leads = np.ones(len(order), bool)
    leads[1:] = unique["v"][order][1:] != unique["v"][order][:-1]
    lead = np.zeros(len(unique), bool)
    lead[order[leads]] = True
    extra = np.flatnonzero(~lead)
    extra = extra[np.argsort(first[extra], kind="stable")]
    new_id = unique["v"].copy()
    new_id[extra] = vertex_count + np.arange(len(extra))
    source = np.concatenate([np.arange(vertex_count), unique["v"][extra]])
    uvs = np.zeros((vertex_count + len(extra), 2))
    uvs[new_id, 0], uvs[new_id, 1] = unique["u"], unique["w"]
    return new_id[inverse.reshape(-1)], source, uvs


def _uvs(
    part: dict, corner_vertex: np.ndarray, corner: np.ndarray, count: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(vertex of each corner, source vertex of each output vertex, UVs or None); the
    file's ``corner`` of each corner picks its faceVarying UV."""
    where = part["where"]
    keep = (corner_vertex, np.arange(count), None)
    uv, scope = part.get("uv"), part.get("uv_scope")
    if uv is None:
        return keep
    corners = len(corner_vertex)
    if uv.ndim != 2 or uv.shape[1] != 2 or uv.dtype.kind != "f":
        log.warning(
            "%s: its UVs are %s of shape %s, not two numbers each; read without UVs",
            where,
            uv.dtype,
            uv.shape,
        )
        return keep
    if scope not in ("vertex", "faceVarying"):
        log.warning(
            "%s: its UVs have %s scope; only vertex and faceVarying ones are read, so"
            " it is read without UVs",
            where,
            scope or "no",
        )
        return keep
    need = count if scope == "vertex" else corners
    if len(uv) != need:
        raise FormatError(f"{where}: UVs have {len(uv)} values; {scope} UVs need {need}")
    if scope == "vertex":
        return corner_vertex, np.arange(count), uv.astype(np.float64)
    return split_seams(corner_vertex, uv[corner].astype(np.float64), count)


def polygon_layout(
    part: dict, vertex_count: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """A mesh part's polygons (``face_counts``, ``face_indices``, ``flip``, optional
    ``uv`` with ``uv_scope``) over ``vertex_count`` points as a SkinMesh lays them out:
    (triangles (T, 3), the file's point of each SkinMesh vertex, UVs or None).
    FormatError naming the mesh for counts and indices that do not fit."""
    where = part["where"]
    counts, index = part["face_counts"], part["face_indices"]
    if counts.dtype.kind not in "iu" or index.dtype.kind not in "iu":
        raise FormatError(
            f"{where}: face counts and indices must be whole numbers, got"
            f" {counts.dtype} and {index.dtype}"
        )
    counts, index = counts.astype(np.int64), index.astype(np.int64)
    if np.any(counts < 3):
        i = int(np.argmax(counts < 3))
        raise FormatError(
            f"{where}: face {i} has {int(counts[i])} corners; a polygon needs 3 or more"
        )
    if int(counts.sum()) != len(index):
        raise FormatError(
            f"{where}: face counts sum to {int(counts.sum())} but there are"
            f" {len(index)} face indices"
        )
    bad = (index < 0) | (index >= vertex_count)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise FormatError(
            f"{where}: face index {i} is {int(index[i])}, outside the {vertex_count} points"
        )
    corner = np.arange(len(index))
    if part["flip"]:  # reverse each polygon's corners: counter-clockwise, as follicle's
        starts = np.repeat(np.cumsum(counts) - counts, counts)
        corner = 2 * starts + np.repeat(counts, counts) - 1 - corner
        index = index[corner]
    corner_vertex, vertex_source, uvs = _uvs(part, index, corner, vertex_count)
    return corner_vertex[fan_triangles(counts)], vertex_source, uvs


def skin_from_part(part: dict, source: Path) -> SkinMesh:
    """The SkinMesh of a mesh part from a guarded reader (``where``, ``name``,
    ``points``, ``face_counts``, ``face_indices``, optional ``uv`` with ``uv_scope``,
    ``flip`` for clockwise polygons, ``others``: meshes not read). FormatError naming
    the mesh for counts and indices that do not fit (:func:`polygon_layout`), and naming
    the file for geometry a SkinMesh refuses (NaN, coordinates beyond its limit, only
    zero-area faces): the file holds it, so it is the file that is unreadable as a skin."""
    if part["others"]:
        log.warning(
            "%s is the skin (the file's first mesh); %d more meshes were not read: %s",
            part["where"],
            len(part["others"]),
            ", ".join(part["others"][:3]) + (", …" if len(part["others"]) > 3 else ""),
        )
    points = np.asarray(part["points"], dtype=np.float64)
    faces, vertex_source, uvs = polygon_layout(part, len(points))
    try:
        return SkinMesh(points[vertex_source], faces, uvs, name=part["name"])
    except InputError as exc:
        raise FormatError(f"{source}: {exc}") from None


def scaled_skin(mesh: SkinMesh, mpu: float, source: Path) -> SkinMesh:
    """``mesh`` with its vertices times ``mpu`` (metres per the file's unit), the file's
    geometry as it holds it checked first (:func:`skin_from_part`); an InputError naming
    ``source`` when the scaled mesh is refused (a unit that puts it out of range)."""
    if mpu == 1.0:
        return mesh
    try:
        return SkinMesh(mesh.rest_vertices * mpu, mesh.faces, mesh.uvs, name=mesh.name)
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from exc


def load_usd_mesh(path: str | os.PathLike[str], mpu: float = 1.0) -> SkinMesh:
    """The first Mesh prim of a USD stage as a SkinMesh (transforms, metersPerUnit and a
    Z up axis applied; ``primvars:st``, ``UVMap`` or ``uv`` of vertex or faceVarying
    interpolation as its UVs, split at seams; polygons fanned into triangles). Further
    meshes are named in a warning and not read. usd-core reads the file in a guarded
    child process (see :mod:`follicle.io.usd_guard`): anything wrong with the file is a
    FormatError naming it. ``mpu`` scales the vertices after the stage's own
    metersPerUnit, the signature of :data:`follicle.io.dispatch.MESH_READERS`
    (:func:`follicle.load_mesh` gives 1: the stage declares its unit)."""
    source = input_file(path, "USD file (.usd, .usda, .usdc or .usdz)")
    check_container(source)
    (part,) = read_meshes(source)
    return scaled_skin(skin_from_part(part, source), mpu, source)
