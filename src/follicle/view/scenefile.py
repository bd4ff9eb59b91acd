"""Saving the viewer's scene as TOML that :func:`follicle.scene.load_scene` reads back to
the same scene, with its file paths rewritten for the new file's folder."""

from __future__ import annotations

import os
from pathlib import Path

from ..atomic import atomic_path
from ..errors import FormatError
from ..scene import Scene, holds_paths, scene_to_toml
from ..validate import file_path

__all__ = ["relocated", "save_scene"]


def _relative(path: str, folder: Path) -> str:
    """``path`` (absolute, or relative to the working folder) relative to ``folder``;
    absolute where no relative path leads there (another drive); builtins as they are."""
    if path.startswith("builtin:"):
        return path
    absolute = os.path.abspath(path)
    try:
        return Path(os.path.relpath(absolute, folder)).as_posix()
    except ValueError:
        return absolute


def _moved(value: object, scene: Scene, folder: Path) -> object:
    """A path value of ``scene`` (text, or a property table's ``texture``) for ``folder``."""
    if isinstance(value, str):
        return _relative(scene.resolve(value), folder)
    if isinstance(value, dict) and isinstance(value.get("texture"), str):
        return {**value, "texture": _relative(scene.resolve(value["texture"]), folder)}
    return value


def relocated(scene: Scene, folder: str | os.PathLike[str]) -> Scene:
    """A copy of ``scene`` whose relative paths start in ``folder`` instead of the scene's
    own folder, pointing at the same files."""
    folder = Path(os.path.abspath(folder))
    sections = {}
    for name, field in Scene.model_fields.items():
        model = getattr(scene, name)
        if field.exclude:
            continue
        keys = [k for k, f in type(model).model_fields.items() if holds_paths(f)]
        moved = {k: _moved(getattr(model, k), scene, folder) for k in keys}
        sections[name] = model.model_copy(update=moved)
    return scene.model_copy(update={**sections, "base_dir": folder})


def save_scene(scene: Scene, path: str | os.PathLike[str]) -> Path:
    """Write ``scene`` to the TOML file ``path`` (every key, defaults filled in, paths
    relative to the file's folder), atomically; returns the path."""
    path = file_path(path, "save_scene path")
    target = Path(path)
    if target.suffix.lower() != ".toml":
        raise FormatError(f"{target}: a scene file must end in .toml")
    text = scene_to_toml(relocated(scene, target.parent))
    try:
        with atomic_path(target) as tmp:
            tmp.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise FormatError(f"{target}: cannot write the scene: {exc}") from None
    return target
