"""Stroke logs: a groom made by hand, as the JSON list of what was done, replayable.

A :class:`~follicle.GuideEditor` records every stroke, undo and redo it is given
(:attr:`~follicle.GuideEditor.log`); :func:`save_strokes` writes that list with the
mesh and guides it started from, and :func:`~follicle.editing.editor.replay` (``follicle
groom strokes.json``) applies it again headless, byte for byte — so a hand-made groom
is reproducible, reviewable as text and testable::

    {
      "follicle_strokes": 1,
      "mesh": "builtin:head",
      "guides": "builtin:long",
      "strokes": [
        {"brush": "comb", "path": [[300, 200], [420, 210]], "radius": 60,
         "strength": 0.5, "size": [960, 540],
         "camera": {"eye": [0, 0.1, 0.8], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 30}},
        {"undo": true}
      ]
    }
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from ..atomic import atomic_path
from ..errors import FormatError, InputError
from ..inputs import input_file
from ..render.camera import Camera
from ..validate import file_path

__all__ = [
    "VERSION",
    "MAX_BYTES",
    "stroke_entry",
    "save_strokes",
    "load_strokes",
    "stroke_camera",
]

VERSION = 1
MAX_BYTES = 64 * 2**20  # a stroke log bigger than this is refused before it is parsed
_CAMERA_KEYS = ("eye", "target", "up", "fov_y", "near", "far")
_STROKE_KEYS = {"brush", "path", "radius", "strength", "size", "camera", "options", "join"}


def stroke_entry(
    brush: str,
    path: list,
    camera: Camera,
    radius: float,
    strength: float,
    size: tuple[int, int],
    options: Mapping[str, object],
) -> dict[str, object]:
    """A stroke as a log entry (plain JSON values)."""
    view = {"eye": camera.eye.tolist(), "target": camera.target.tolist()}
    view.update({"up": camera.up.tolist(), "fov_y": float(camera.fov_y)})
    if camera.near is not None:
        view["near"] = float(camera.near)
    if camera.far is not None:
        view["far"] = float(camera.far)
    entry: dict[str, object] = {"brush": brush, "path": path, "radius": float(radius)}
    entry.update({"strength": float(strength), "size": [int(size[0]), int(size[1])]})
    entry["camera"] = view
    if options:
        entry["options"] = dict(options)
    return entry


def save_strokes(
    log: Sequence[Mapping[str, object]],
    path: str | os.PathLike[str],
    mesh: str | None = None,
    guides: str | None = None,
) -> Path:
    """Write a :class:`~follicle.GuideEditor`'s ``log`` to ``path`` (JSON, atomically),
    with the ``mesh`` and ``guides`` sources (paths or ``builtin:`` names) it started
    from when given."""
    doc: dict[str, object] = {"follicle_strokes": VERSION}
    if mesh is not None:
        doc["mesh"] = str(mesh)
    if guides is not None:
        doc["guides"] = str(guides)
    head = json.dumps(doc, indent=1)[:-2]  # without the closing brace
    lines = ",\n  ".join(json.dumps(entry) for entry in log)  # a stroke a line
    text = (
        f'{head},\n "strokes": [\n  {lines}\n ]\n}}\n'
        if lines
        else f'{head},\n "strokes": []\n}}\n'
    )
    target = Path(path)
    with atomic_path(target) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return target


def load_strokes(path: str | os.PathLike[str]) -> dict[str, object]:
    """A stroke log read and checked: its version, sources and entries (each a stroke
    with known keys, or an undo or redo); FormatError or InputError naming the file and
    the entry otherwise. The strokes' own values are checked when replayed."""
    path = file_path(path, "load_strokes path")
    # a folder, FIFO or device refused by name; a URL fetched, at most MAX_BYTES of it
    local = input_file(path, "stroke log (JSON)", MAX_BYTES)
    name = os.fspath(path)
    try:
        size = os.path.getsize(local)
    except OSError as exc:
        raise InputError(f"{name}: cannot read the stroke log ({exc.strerror})") from None
    if size > MAX_BYTES:
        raise InputError(f"{name}: {size:,} bytes; stroke logs are at most {MAX_BYTES:,}")
    try:
        doc = json.loads(local.read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise FormatError(f"{name}: not a JSON stroke log ({exc})") from None
    except ValueError:  # an integer of more digits than Python converts (4,300)
        raise FormatError(
            f"{name}: a number in the stroke log has thousands of digits; not a log follicle"
            " wrote (numbers are pixels, radii and strengths)"
        ) from None
    if not isinstance(doc, dict) or doc.get("follicle_strokes") != VERSION:
        raise FormatError(
            f"{name}: not a follicle stroke log (expected an object with"
            f' "follicle_strokes": {VERSION})'
        )
    for key in ("mesh", "guides"):
        if key in doc and not isinstance(doc[key], str):
            raise InputError(f"{name}: {key}: expected a path or builtin: name")
    entries = doc.get("strokes")
    if not isinstance(entries, list):
        raise InputError(f"{name}: strokes: expected a list of strokes")
    for i, entry in enumerate(entries):
        where = f"{name}: strokes[{i}]"
        if not isinstance(entry, dict):
            raise InputError(f"{where}: expected an object")
        if entry in ({"undo": True}, {"redo": True}):
            continue
        unknown = set(entry) - _STROKE_KEYS
        if unknown or "brush" not in entry:
            raise InputError(
                f"{where}: expected a stroke (brush, path, radius, strength, size, camera,"
                f' options, join) or {{"undo": true}} / {{"redo": true}}; got keys {sorted(entry)}'
            )
    return doc


def stroke_camera(view: object) -> Camera:
    """The camera of a log entry (its ``camera`` object), checked."""
    if not isinstance(view, dict):
        raise InputError("camera: expected an object with eye and target")
    unknown = set(view) - set(_CAMERA_KEYS)
    if unknown or "eye" not in view or "target" not in view:
        raise InputError(
            f"camera: expected keys eye, target (and up, fov_y, near, far); got {sorted(view)}"
        )
    return Camera(**view)
