"""Grooming by hand: brush strokes on the guides, with undo, redo and save.

A :class:`GuideEditor` holds the guides' world positions at rest and applies strokes:
a brush (:data:`~follicle.groom.brushes.BRUSHES`) dragged along a polyline of pixels
of a ``size`` viewport seen through a :class:`~follicle.render.Camera` — what the
viewer sends as the mouse moves, and what a script or a stroke log replays. The
brush acts on the guide vertices under it (within ``radius`` pixels, with a smooth
falloff) that the camera sees — not those behind the head, tested against the skin's
depth drawn by the CPU engine — so a stroke over the face does not comb the back of
the head. The same strokes give the same bytes.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from ..arrays import frozen
from ..curves import HairCurves
from ..errors import FollicleError, InputError
from ..groom import brushes
from ..groom.groups import InterpolationGroups, color_label
from ..groom.guides import Guides, load_guides
from ..inputs import is_remote, is_url, remote_reach
from ..mesh.sdf import skin_sdf
from ..mesh.skin import SkinMesh
from ..mesh.texture import Texture
from ..render.camera import Camera
from ..render.options import parse_size
from ..validate import file_path, number, positive
from .attributes import Attributes
from .strokes import load_strokes, save_strokes, stroke_camera, stroke_entry

__all__ = ["GuideEditor", "replay", "replay_file"]

HISTORY = 256  # strokes kept for undo
SPACING = 0.25  # a stroke's dabs this share of the radius apart
NEIGHBOURS = 4  # existing guides an added guide takes its shape from
MAX_DABS = 100_000  # dabs in one stroke (a stroke log cannot ask for a hang)
# points of one stroke's path: cut, delete and part test every guide against every
# segment (about 3.5 ms a point at 1,000 guides); a mouse drag is logged in pieces of a
# few dozen (``join``), so this bounds one entry of a log to seconds
MAX_PATH_POINTS = 4096
# the largest |pixel coordinate| of a path point: off the image, as a drag may go, but
# not so far that its length overflows (a log's 1e308 made numpy warn, a second line)
MAX_PIXEL = 1e6
PART_STEPS = 8  # a part brush's pushes, each followed by follow-the-leader
GROUP_TEXELS = 256  # texels a side of a parting painted where there was no group texture
_RANGES = {"length": (-1.0, 1.0)}  # strength; others 0..1


@dataclass(frozen=True)
class _State:
    """One version of the guides: world positions at rest (S, V, 3) float64, each
    root's triangle (S,) and barycentric coordinates (S, 2), the interpolation
    groups (a part brush paints them) and the guides' own point and curve attributes
    (a colour the hairs inherit), carried with the points. ``loaded``: the guides the
    editor was given, for the first state only — undone to it, the guides are those
    bytes, not the float64 points rounded back to float32 (a step off where the rest
    shape's root was added back)."""

    points: np.ndarray
    triangles: np.ndarray
    bary: np.ndarray
    groups: InterpolationGroups
    attributes: Attributes
    loaded: Guides | None = None


class GuideEditor:
    """Edit ``guides`` with brushes (see :meth:`stroke`); :attr:`guides` is the current
    :class:`~follicle.Guides` (same mesh and interpolation groups, the guides' vertex
    count). ``margin`` is how far off the skin a brush leaves every vertex (None: a
    quarter of the skin SDF's voxel)."""

    def __init__(
        self, guides: Guides, mesh: SkinMesh | None = None, margin: float | None = None
    ) -> None:
        if not isinstance(guides, Guides):
            raise InputError(f"guides: expected follicle.Guides, got {type(guides).__name__}")
        if mesh is not None and not guides.mesh.same_skin(mesh):
            raise InputError(f"mesh: the guides are bound to '{guides.mesh.name}', not to it")
        self.mesh = guides.mesh
        n = guides.vertex_count
        points = guides.rest_shapes(n).astype(np.float64) + guides.root_positions[:, None]
        triangles, bary = guides.triangles.copy(), guides.bary.copy()
        attributes = Attributes.of(guides, n)
        self._state = _State(points, triangles, bary, guides.groups, attributes, guides)
        self._margin = None if margin is None else number(margin, "margin", lo=0.0, unit="m")
        self._undo: list[_State] = []
        self._redo: list[_State] = []
        self._guides: Guides | None = guides
        self._frames: tuple | None = None
        self._last_view: tuple | None = None
        self.log: list[dict[str, object]] = []  # strokes, undos and redos, in order
        self._pushed = False  # whether the stroke going on has an undo step yet

    # ------------------------------------------------------------------ state
    @property
    def guides(self) -> Guides:
        """The guides as they are now."""
        if self._guides is None:
            s = self._state
            point, curve = s.attributes.data()
            data = {**curve, "root_triangle": s.triangles, "root_bary": s.bary}
            curves = HairCurves.from_array(s.points.astype(np.float32), point, data)
            self._guides = Guides(curves, self.mesh, s.points.shape[1], s.groups)
        return self._guides

    @property
    def groups(self) -> InterpolationGroups:
        """The interpolation groups now (those of the guides given, until a part)."""
        return self._state.groups

    @property
    def attributes(self) -> Attributes:
        """The guides' own attributes now (a new object after a stroke that changed
        them: cut, length, add, delete)."""
        return self._state.attributes

    @property
    def points(self) -> np.ndarray:
        """The guides' world positions at rest (S, V, 3), read-only."""
        return frozen(self._state.points.view())

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    def undo(self) -> bool:
        """Take back the last stroke; False when there is none."""
        return self._swap(self._undo, self._redo, "undo")

    def redo(self) -> bool:
        """Apply again the last stroke taken back; False when there is none."""
        return self._swap(self._redo, self._undo, "redo")

    def _swap(self, source: list[_State], target: list[_State], action: str) -> bool:
        self._pushed = False
        if not source:
            return False
        target.append(self._state)
        self._set(source.pop())
        self.log.append({action: True})
        return True

    def _commit(self, state: _State) -> None:
        """``state`` becomes the current one; the one before is an undo step unless
        this stroke (its joined pieces) has pushed one already."""
        if not self._pushed:
            self._undo.append(self._state)
            del self._undo[:-HISTORY]
            self._pushed = True
        self._redo.clear()
        self._set(state)

    def _set(self, state: _State) -> None:
        self._state = state
        self._guides = state.loaded

    def save(self, path: str | os.PathLike[str], **options: object) -> Path:
        """Write the guides (with their root bindings) to ``path`` in the curves format
        its extension names (:func:`follicle.save`)."""
        path = file_path(path, "GuideEditor.save path")
        from ..io.dispatch import save

        return save(self.guides.curves, path, **options)

    # ---------------------------------------------------------------- strokes
    def stroke(
        self,
        brush: str,
        path: object,
        camera: Camera,
        radius: float,
        strength: float = 0.5,
        size: Sequence[int] = (960, 540),
        join: bool = False,
        **options: object,
    ) -> np.ndarray:
        """Apply ``brush`` along ``path`` ((K, 2) pixels, x right and y down from the
        top-left of a ``size`` = (w, h) viewport seen through ``camera``) with a brush
        ``radius`` pixels wide and ``strength`` (0..1; −1..1 for ``length``, negative
        shrinks). Returns the indices of the guides it changed (for ``delete``, of the
        guides removed, numbered as before the stroke; for ``add``, of the new ones).
        ``join`` continues the last stroke: one undo takes back both (a mouse drag is
        applied a piece at a time as the mouse moves, and undone at once).

        Brushes: ``comb`` drags the vertices along the stroke, keeping segment lengths;
        ``cut`` cuts the guides the stroke crosses where it crosses them; ``length``
        grows or shrinks the guides under it (extending along the tip); ``puff`` lifts
        them towards the skin normal near the root; ``smooth`` relaxes their curvature;
        ``add`` plants new guides on the skin under the stroke (one a ``spacing`` pixels,
        default the radius), shaped from their neighbours; ``delete`` removes the
        guides whose roots are under it; ``part`` combs the guides rooted within
        ``radius`` of the stroke away from it (``strength`` × radius pixels) and paints
        the parting into the interpolation groups (:meth:`_part`). Lengths stay exact
        under comb, puff and smooth, and no vertex is left inside the skin.
        """
        if brush not in brushes.BRUSHES:
            raise InputError(f"brush: {brush!r} is not one of {list(brushes.BRUSHES)}")
        if not isinstance(camera, Camera):
            raise InputError(f"camera: expected follicle.Camera, got {type(camera).__name__}")
        line = _path(path)
        radius = positive(radius, "radius", unit="px")
        lo, hi = _RANGES.get(brush, (0.0, 1.0))
        strength = number(strength, "strength", lo=lo, hi=hi)
        w, h = parse_size(size)
        spacing = options.pop("spacing", None) if brush == "add" else None
        if options:
            raise InputError(f"{brush}: unknown option(s) {sorted(options)}")
        step = None if spacing is None else positive(spacing, "spacing", unit="px")
        view = self._view(camera, (w, h))
        if not join:
            self._pushed = False  # a new stroke: its first change gets an undo step
        if brush == "cut":
            changed = self._cut(view, line)
        elif brush == "delete":
            changed = self._delete(view, line, radius)
        elif brush == "part":
            changed = self._part(view, line, radius, strength)
        elif brush == "add":
            changed = self._add(view, _dabs(line, radius if step is None else step))
        else:
            changed = self._brush(brush, view, _dabs(line, radius * SPACING), radius, strength)
        extra = {} if step is None else {"spacing": step}
        entry = stroke_entry(brush, line.tolist(), camera, radius, strength, (w, h), extra)
        if join:
            entry["join"] = True
        self.log.append(entry)
        return changed

    def save_strokes(
        self, path: str | os.PathLike[str], mesh: str | None = None, guides: str | None = None
    ) -> Path:
        """Write :attr:`log` as a stroke log (:mod:`follicle.editing.strokes`) naming the
        ``mesh`` and ``guides`` it started from, for ``follicle groom`` to replay."""
        return save_strokes(self.log, path, mesh, guides)

    def replay(self, path: str | os.PathLike[str]) -> None:
        """Apply a stroke log's strokes, undos and redos in order."""
        replay(self, load_strokes(path), os.fspath(path))

    def _brush(self, brush: str, view: _View, dabs: np.ndarray, radius: float, strength: float):
        """comb, smooth, puff and length: one dab at each point of the stroke, on the
        vertices the camera sees at the stroke's start (only guides that come within
        ``radius`` of the stroke on screen are looked at: no others can move)."""
        s = self._state
        xy, _, seen = view.seen(s.points, self.mesh)
        lo, hi = dabs.min(axis=0) - radius, dabs.max(axis=0) + radius
        near = ((xy.max(axis=1) >= lo) & (xy.min(axis=1) <= hi)).all(axis=1)
        which = np.flatnonzero(near & seen[:, 1:].any(axis=1))
        points = s.points[which]
        seen = seen[which]
        lengths = brushes.segment_lengths(points)
        normals = self._root_frames.normal[which]
        touched = np.zeros(len(which), bool)
        attributes = s.attributes
        reach = np.empty(points.shape[:2])
        depth = np.empty(points.shape[:2])
        w, h = view.size
        for k in range(len(dabs) if len(which) and strength != 0.0 else 0):
            cx, cy = dabs[k]
            hit = brushes.dab(points, view.matrix, w, h, cx, cy, radius, seen, reach, depth)
            if not hit.any():
                continue
            touched |= hit
            weight = strength * reach
            hits = np.flatnonzero(hit)
            if brush == "comb":
                if k + 1 == len(dabs):
                    break
                brushes.comb(points, weight, depth, view.step(dabs[k + 1] - dabs[k]), hits)
            elif brush == "smooth":
                brushes.smooth(points, weight, hits)
            elif brush == "puff":
                brushes.puff(points, weight, normals, hits)
            else:  # length: a stroke one radius long changes it by strength × weight
                step = np.linalg.norm(dabs[min(k + 1, len(dabs) - 1)] - dabs[k]) / radius
                grow = 1.0 + strength * reach.max(axis=1) * (step if len(dabs) > 1 else 1.0)
                sized = hit & (grow != 1.0)  # the last dab of a stroke: no step, no change
                total = lengths[sized].sum(axis=1)
                points[sized], row, share = brushes.resized(
                    points[sized], total * np.maximum(grow[sized], 0.0)
                )
                attributes = attributes.resized(which[sized], row, share)
                lengths = brushes.segment_lengths(points)
            brushes.follow(points, lengths, self._skin, self._clearance, hits)
        # a guide only the stroke's last dab reached is touched but not moved (comb and
        # length act towards the next dab): it is not reported as changed
        changed = which[touched & (points != s.points[which]).any(axis=(1, 2))]
        if len(changed):
            edited = s.points.copy()
            edited[which] = points
            self._commit(_State(edited, s.triangles, s.bary, s.groups, attributes))
        return changed

    def _cut(self, view: _View, line: np.ndarray) -> np.ndarray:
        s = self._state
        xy, depth, seen = view.seen(s.points, self.mesh)
        at = brushes.cut_lengths(s.points, xy, depth, line, seen[:, 1:] & seen[:, :-1])
        changed = np.flatnonzero(np.isfinite(at))
        if len(changed):
            points = s.points.copy()
            points[changed], row, share = brushes.resized(points[changed], at[changed])
            attributes = s.attributes.resized(changed, row, share)
            self._commit(_State(points, s.triangles, s.bary, s.groups, attributes))
        return changed

    def _delete(self, view: _View, line: np.ndarray, radius: float) -> np.ndarray:
        """The guides whose roots the camera sees within ``radius`` of the stroke."""
        s = self._state
        xy, _, seen = view.seen(s.points[:, :1], self.mesh)
        if len(line) >= 2:
            near = brushes.line_side(xy[:, 0], line)[0] <= radius
        else:
            near = np.linalg.norm(xy[:, 0] - line[0], axis=1) <= radius
        gone = np.flatnonzero(near & seen[:, 0])
        if len(gone) == len(s.points):
            raise InputError("delete: the stroke would remove every guide; keep at least one")
        if len(gone):
            keep = np.setdiff1d(np.arange(len(s.points)), gone)
            self._commit(
                _State(
                    s.points[keep],
                    s.triangles[keep],
                    s.bary[keep],
                    s.groups,
                    s.attributes.rows(keep),
                )
            )
        return gone

    def _add(self, view: _View, dabs: np.ndarray) -> np.ndarray:
        """New guides where the rays through the dabs first meet the skin, each shaped
        as the inverse-distance blend of its nearest guides' shapes in their root frames
        (Šik 2012 §2.2.4), put in its own root frame."""
        s = self._state
        hits = self._skin_hits(view, dabs)
        if len(hits) == 0:
            return np.zeros(0, np.int64)
        triangles, bary, _ = self.mesh.closest_points(hits, pose="rest")
        frame = self.mesh.evaluate(triangles, bary, pose="rest")
        old = self._root_frames
        local = np.einsum("snk,sak->sna", s.points - old.position[:, None], _axes(old))
        k = min(NEIGHBOURS, len(s.points))
        gap = np.linalg.norm(frame.position[:, None] - old.position[None], axis=2)
        near = np.argsort(gap, axis=1, kind="stable")[:, :k]
        weight = 1.0 / np.maximum(np.take_along_axis(gap, near, axis=1), 1e-9)
        weight /= weight.sum(axis=1, keepdims=True)
        shape = np.einsum("nk,nkva->nva", weight, local[near])
        new = frame.position[:, None] + np.einsum("nva,nak->nvk", shape, _axes(frame))
        # the blend's segments are shorter than its neighbours' where they point apart
        target = np.einsum("nk,nk->n", weight, brushes.segment_lengths(s.points)[near].sum(2))
        new, row, share = brushes.resized(new, target)
        brushes.follow(new, brushes.segment_lengths(new), self._skin, self._clearance)
        self._commit(
            _State(
                np.concatenate([s.points, new]),
                np.concatenate([s.triangles, triangles]),
                np.concatenate([s.bary, bary]),
                s.groups,
                s.attributes.added(near, weight, row, share),
            )
        )
        return np.arange(len(s.points), len(s.points) + len(new))

    def _part(self, view: _View, line: np.ndarray, radius: float, strength: float):
        """A parting along ``line``: the guides whose roots the camera sees within
        ``radius`` pixels of it combed away from it, each to its own side, by up to
        ``strength`` × radius pixels (the falloff of its root's distance), and every
        vertex of them that the screen shows nearer the line than its root, or across
        it, pushed back out to its root's distance on its root's side — so no guide
        crosses the parting — in :data:`PART_STEPS` pushes, each followed by
        follow-the-leader; and the interpolation groups painted, so that hairs
        rooted within ``radius`` of the line take guides of their own side only (Šik
        2012 §2.2.4: a parting is where groups meet): the texels of the skin the
        camera sees there get two new groups, one a side; elsewhere they keep theirs.
        Refused when a side would have hairs but no guide."""
        s = self._state
        if len(line) < 2:
            raise InputError("part: the path needs two points or more (the parting line)")
        xy, _, seen = view.seen(s.points[:, :1], self.mesh)
        dist, side, away = brushes.line_side(xy[:, 0], line)
        which = np.flatnonzero(seen[:, 0] & (dist <= radius))
        groups, labels = self._parted_groups(view, line, radius)
        if len(which) == 0 and groups is None:
            return which
        if groups is not None:
            _check_groups(groups, groups.group_of(self._root_frames.uv), labels)
        points = s.points.copy()
        if len(which):
            sub = points[which]
            lengths = brushes.segment_lengths(sub)
            weight = strength * np.clip(1.0 - (dist[which] / radius) ** 2, 0.0, 1.0) ** 2
            own, keep = side[which], dist[which]
            # each guide its own way, away from the line on its side (screen, y down)
            way = away[which]
            way = view.pixel * (way[:, :1] * view.right - way[:, 1:] * view.up)
            for _ in range(PART_STEPS):
                xy, depth = view.project(sub[:, 1:])
                gap, at, _ = brushes.line_side(xy.reshape(-1, 2), line)
                signed = (gap * at).reshape(xy.shape[:2]) * own[:, None]
                # pixels: a share of the push, and what brings a vertex back to its
                # root's side at least as far from the line as the root
                push = weight[:, None] * radius / PART_STEPS + np.maximum(
                    keep[:, None] - signed, 0.0
                )
                scale = push * np.maximum(depth, 0.0)
                sub[:, 1:] += scale[..., None] * way[:, None, :]
                brushes.follow(sub, lengths, self._skin, self._clearance)
            points[which] = sub
        self._commit(_State(points, s.triangles, s.bary, groups or s.groups, s.attributes))
        return which

    def _parted_groups(self, view: _View, line: np.ndarray, radius: float):
        """The groups with the parting painted and the labels of its two new groups
        (None and no labels: no texel of it in view)."""
        old = self._state.groups
        ids = _group_ids(old, self._texel_uv())
        pos, covered = self._uv_points
        h, w = covered.shape
        xy, _, seen = view.seen(pos.reshape(-1, 3), self.mesh)
        dist, side, _ = brushes.line_side(xy, line)
        band = (seen & covered.ravel() & (dist <= radius)).reshape(h, w)
        if not band.any():
            return None, []
        colors = [(int(r), int(g), int(b)) for r, g, b in old.colors]
        new = _fresh_colours(colors, 2)
        image = np.array(colors, np.uint8)[ids]
        left = band & (side.reshape(h, w) > 0)
        image[left] = new[0]
        image[band & ~left] = new[1]
        texture = Texture(image, wrap="clamp", name="parting")
        kept = {old.label(g): n for g, n in old.vertices.items()}
        return InterpolationGroups(texture, kept), [color_label(np.array(c)) for c in new]

    def save_groups(self, path: str | os.PathLike[str]) -> Path:
        """Write the interpolation groups' texture as an 8-bit PNG (one colour a group),
        for ``[groom].groups``; the guides' own (:meth:`save`) go beside it."""
        from PIL import Image

        from ..atomic import atomic_path

        s = self._state
        ids = _group_ids(s.groups, self._texel_uv())
        image = np.array([tuple(int(c) for c in rgb) for rgb in s.groups.colors], np.uint8)[ids]
        target = Path(path)
        with atomic_path(target) as tmp:
            Image.fromarray(image).save(tmp, format="PNG")
        return target

    def _texel_uv(self) -> np.ndarray:
        """The UV of every texel centre of the groups' raster (H·W, 2)."""
        h, w = self._uv_points[1].shape
        u = (np.arange(w) + 0.5) / w
        v = 1.0 - (np.arange(h) + 0.5) / h
        return np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)

    @cached_property
    def _uv_points(self) -> tuple[np.ndarray, np.ndarray]:
        """The skin under each texel of the groups' raster: the groups' own texture's
        size, or :data:`GROUP_TEXELS` a side."""
        if self.mesh.uvs is None:
            raise InputError(
                f"part: mesh '{self.mesh.name}' has no UVs, and interpolation groups are"
                " painted in UV space; give the mesh UVs"
            )
        texture = self._state.groups.texture
        h, w = texture.data.shape[:2] if texture is not None else (GROUP_TEXELS, GROUP_TEXELS)
        faces = np.ascontiguousarray(self.mesh.faces, np.int64)
        verts = np.asarray(self.mesh.rest_vertices, np.float64)
        return brushes.uv_points(np.asarray(self.mesh.uvs, np.float64), faces, verts, w, h)

    def _skin_hits(self, view: _View, dabs: np.ndarray) -> np.ndarray:
        """The first points of the skin along the camera rays through ``dabs`` (those
        that miss it left out)."""
        eye = view.camera.eye
        corners = self.mesh.rest_vertices[self.mesh.faces]  # (F, 3, 3)
        out = []
        for direction in view.rays(dabs):
            t = _ray_hits(eye, direction, corners)
            if np.isfinite(t).any():
                out.append(eye + np.nanmin(t) * direction)
        return np.array(out).reshape(-1, 3)

    # ---------------------------------------------------------------- helpers
    def _view(self, camera: Camera, size: tuple[int, int]) -> _View:
        """The view of ``camera`` at ``size``, the last one again while they stay the
        same (the skin's depth is drawn once for many strokes)."""
        key = (*camera.eye, *camera.target, *camera.up, camera.fov_y, *camera.clip_range(), *size)
        if self._last_view is None or self._last_view[0] != key:
            self._last_view = (key, _View(camera, size))
        return self._last_view[1]

    @property
    def _root_frames(self):
        """The roots' skin frames (positions, normals, tangents, binormals) now; kept
        while the roots stay where they are (only add and delete move them)."""
        s = self._state
        key = (s.triangles, s.bary)
        if self._frames is None or self._frames[0] is not s.triangles:
            self._frames = (key[0], self.mesh.evaluate(*key, pose="rest"))
        return self._frames[1]

    @property
    def _skin(self):
        """The rest skin's SDF, kept with the mesh: the groom's skin collision reads it too."""
        return skin_sdf(self.mesh)

    @cached_property
    def _clearance(self) -> float:
        return self._skin.voxel * 0.25 if self._margin is None else self._margin


class _View:
    """A camera and its viewport: projection to pixels, pixel steps to world moves, rays."""

    def __init__(self, camera: Camera, size: tuple[int, int]) -> None:
        self.camera = camera
        self.size = size
        self.right, self.up, self.forward = camera.basis()
        self.pixel = camera.pixel_scale(size[1])
        near, far = camera.clip_range()
        self.matrix = camera.projection_matrix(size[0] / size[1], near, far) @ camera.view_matrix()
        self._skin: np.ndarray | None = None

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (..., 2) and view depths (...) of points (..., 3)."""
        xy, depth = self.camera.project(points.reshape(-1, 3), self.size)
        return xy.reshape(*points.shape[:-1], 2), depth.reshape(points.shape[:-1])

    def seen(self, points: np.ndarray, mesh: SkinMesh) -> tuple[np.ndarray, ...]:
        """Pixels (..., 2) of points (..., 3), their view depths, and whether the camera
        sees each: in the picture, in front of the eye and not behind the skin (within
        2 % of its depth, so the roots, on the skin, count as seen)."""
        xy, depth = self.project(points)
        w, h = self.size
        col = np.floor(xy[..., 0]).astype(np.int64)
        row = np.floor(xy[..., 1]).astype(np.int64)
        inside = (col >= 0) & (col < w) & (row >= 0) & (row < h) & (depth > 0.0)
        skin = self.skin(mesh)[np.clip(row, 0, h - 1), np.clip(col, 0, w - 1)]
        return xy, depth, inside & (depth <= skin * 1.02)

    def skin(self, mesh: SkinMesh) -> np.ndarray:
        """The skin's view depth per pixel (+inf where none), drawn once per view."""
        if self._skin is None:
            from ..render.cpu.engine import skin_depth

            self._skin = skin_depth(mesh, self.camera, self.size)
        return self._skin

    def step(self, pixels: np.ndarray) -> np.ndarray:
        """The world move (3,) of a screen step (2,) pixels, per metre of view depth."""
        return self.pixel * (pixels[0] * self.right - pixels[1] * self.up)

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """Unit directions (K, 3) from the eye through pixel centres (K, 2)."""
        w, h = self.size
        t = math.tan(math.radians(self.camera.fov_y) / 2.0)
        x = (2.0 * pixels[:, 0] / w - 1.0) * t * (w / h)
        y = (1.0 - 2.0 * pixels[:, 1] / h) * t
        d = self.forward[None] + x[:, None] * self.right[None] + y[:, None] * self.up[None]
        return d / np.linalg.norm(d, axis=1, keepdims=True)


def _group_ids(groups: InterpolationGroups, uv: np.ndarray) -> np.ndarray:
    """The group of each texel of the groups' raster (H, W) (their own texture's, or
    :data:`GROUP_TEXELS` a side of the one group there is without)."""
    ids = groups.group_of(uv)
    side = int(round(math.sqrt(len(uv))))
    texture = groups.texture
    h, w = texture.data.shape[:2] if texture is not None else (side, side)
    return ids.reshape(h, w)


def _fresh_colours(taken: list[tuple[int, int, int]], n: int) -> list[tuple[int, int, int]]:
    """``n`` colours not among ``taken``, the same ones for the same ``taken``."""
    out: list[tuple[int, int, int]] = []
    k = 0
    while len(out) < n:
        rgb = ((97 * k + 40) % 256, (57 * k + 200) % 256, (151 * k + 20) % 256)
        if rgb not in taken and rgb not in out:
            out.append(rgb)
        k += 1
    return out


def _check_groups(groups: InterpolationGroups, guide_group: np.ndarray, labels: list[str]) -> None:
    """Refuse a parting whose new groups (``labels``) have skin but no guide: their
    hairs would have none to follow."""
    have = {groups.label(int(g)) for g in np.unique(guide_group)}
    present = {groups.label(g) for g in range(groups.count)}
    for label in labels:
        if label in present and label not in have:
            raise InputError(
                f"part: the parting leaves group {label} with skin but no guide; draw it"
                " where guides are rooted on both sides, or add guides first"
            )


def _ray_hits(origin: np.ndarray, direction: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Distance along the ray to each triangle (F, 3, 3) it meets from the front or the
    back, NaN where it misses (Möller & Trumbore 1997)."""
    e1 = corners[:, 1] - corners[:, 0]
    e2 = corners[:, 2] - corners[:, 0]
    p = np.cross(direction, e2)
    det = np.einsum("fk,fk->f", e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = origin - corners[:, 0]
        u = np.einsum("fk,fk->f", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ direction) * inv
        t = np.einsum("fk,fk->f", e2, q) * inv
    ok = (np.abs(det) > 1e-18) & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t > 0.0)
    return np.where(ok, t, np.nan)


def _axes(frame) -> np.ndarray:
    """Root frames as (S, 3, 3) rows tangent, binormal, normal (Šik 2012 §2.2.4)."""
    return np.stack([frame.tangent, frame.binormal, frame.normal], axis=1)


def _path(path: object) -> np.ndarray:
    """The stroke as a (K ≥ 1, 2) float64 array of finite pixels, or InputError."""
    try:
        line = np.asarray(path, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError("path: expected (K, 2) pixel positions") from None
    if line.ndim != 2 or line.shape[1] != 2 or len(line) == 0:
        raise InputError(f"path: expected (K ≥ 1, 2) pixel positions, got shape {line.shape}")
    if len(line) > MAX_PATH_POINTS:
        raise InputError(
            f"path: {len(line):,} points, more than {MAX_PATH_POINTS:,} in one stroke; split it"
            " into strokes joined to the one before (join)"
        )
    if not np.isfinite(line).all():
        raise InputError("path: holds NaN or inf; every point must be a finite pixel position")
    if np.abs(line).max() > MAX_PIXEL:
        raise InputError(
            f"path: a point lies {np.abs(line).max():.3g} pixels out; every coordinate must"
            f" be within ±{MAX_PIXEL:.0e} pixels"
        )
    return line


def _dabs(line: np.ndarray, spacing: float) -> np.ndarray:
    """The stroke resampled to points at most ``spacing`` pixels apart, ends included:
    the brush's work then does not depend on how often the mouse was sampled."""
    seg = np.linalg.norm(np.diff(line, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    if arc[-1] == 0.0:
        return line[:1].copy()
    n = arc[-1] / spacing
    if not n <= MAX_DABS:
        raise InputError(
            f"path: {arc[-1]:.6g} pixels long at a dab every {spacing:.3g} would take"
            f" {n:.3g} dabs (at most {MAX_DABS:,}); use a larger radius or a shorter stroke"
        )
    n = max(int(math.ceil(n)), 1)
    at = np.linspace(0.0, arc[-1], n + 1)
    return np.stack([np.interp(at, arc, line[:, 0]), np.interp(at, arc, line[:, 1])], axis=1)


def replay(editor: GuideEditor, doc: Mapping[str, object], name: str = "strokes") -> None:
    """Apply a loaded stroke log's entries (:func:`~.strokes.load_strokes`) to
    ``editor`` in order; a bad stroke is an InputError naming ``name`` and the entry."""
    strokes = doc["strokes"]
    if not isinstance(strokes, list):  # load_strokes gives a list; a hand-made doc may not
        raise InputError(f"{name}: strokes: expected a list of strokes")
    for i, entry in enumerate(strokes):
        where = f"{name}: strokes[{i}]"
        if entry == {"undo": True}:
            editor.undo()
            continue
        if entry == {"redo": True}:
            editor.redo()
            continue
        try:
            camera = stroke_camera(entry.get("camera"))
            options = entry.get("options", {})
            if not isinstance(options, dict):
                raise InputError("options: expected an object")
            join = entry.get("join", False)
            if not isinstance(join, bool):
                raise InputError("join: expected true or false")
            editor.stroke(
                entry["brush"],
                entry.get("path"),
                camera,
                entry.get("radius"),
                entry.get("strength", 0.5),
                entry.get("size", (960, 540)),
                join,
                **options,
            )
        except (InputError, TypeError) as exc:
            raise InputError(f"{where}: {exc}") from None


def replay_file(
    path: str | os.PathLike[str], guides: str | None = None, mesh: str | None = None
) -> GuideEditor:
    """A :class:`GuideEditor` on the guides and mesh the log at ``path`` names (or
    ``guides`` / ``mesh``, paths or ``builtin:`` names, when given; the mesh defaults
    to ``builtin:head``) with the log replayed — what ``follicle groom`` runs."""
    from ..io.mesh_load import load_mesh

    name = os.fspath(file_path(path, "replay_file path"))
    doc = load_strokes(name)
    source = guides or _beside(name, doc, "guides")
    if source is None:
        raise InputError(f"{name} names no guides; give them (follicle groom --guides)")
    where = mesh or _beside(name, doc, "mesh")
    with _named_in(name, "mesh", where if mesh is None else None):
        skin = load_mesh(where or "builtin:head")
    with _named_in(name, "guides", source if guides is None else None):
        editor = GuideEditor(load_guides(source, skin))
    replay(editor, doc, name)
    return editor


@contextlib.contextmanager
def _named_in(log: str, key: str, source: str | None) -> Iterator[None]:
    """A FollicleError loading the ``key`` source the log names (``source``; None: one
    the caller gave, or the default) names the log and its key too: a damaged log can
    name a file that is not there, or an empty or garbled name that says nothing."""
    try:
        yield
    except FollicleError as exc:
        if source is None:
            raise
        why = str(exc).removeprefix(f"{source}: ")
        raise type(exc)(f"{log}: the {key} it names, {source!r}: {why}") from None


def _beside(log: str, doc: Mapping[str, object], key: str) -> str | None:
    """The ``mesh`` or ``guides`` source a stroke log names, as read: a log fetched
    from another machine (a URL) names files beside it on its own server (relative
    paths become URLs there), never a file of this machine nor of another server."""
    value = doc.get(key)
    if not isinstance(value, str) or not is_remote(log):
        return value if isinstance(value, str) else None
    reason = remote_reach(log, value)
    if reason is not None:
        raise InputError(
            f"{log}: {key}: {value} is {reason}; a stroke log from a URL names files"
            " beside it (relative paths) or builtin: names"
        )
    if value.startswith("builtin:") or is_url(value):
        return value
    return f"{log.rsplit('/', 1)[0]}/{value}"
