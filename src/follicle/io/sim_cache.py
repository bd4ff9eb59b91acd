"""Simulation caches: the guide strands of every frame, written by `follicle simulate`.

A cache is an uncompressed ``.npz`` (``np.load`` reads it) with the keys

- ``format``: the string ``"follicle-sim-cache"``; ``version``: 1 (int64), or 2 when
  ``skin_vertices`` is there (older follicles read the version-1 caches still);
- ``positions`` (F, S, N, 3) float32: guide vertices per frame, world space, metres;
- ``transforms`` (F, 4, 4) float64: the head's world-from-rest rigid transform per frame;
- ``skin_vertices`` (F, V, 3) float32, only when a skin animation drove the roots
  (``[sim].skin_animation``): the skin mesh's vertices per frame, world space, metres
  (the transforms are then the identity);
- ``fps`` float64: frames per second (frame f is at time f / fps; frame 0 is the rest state);
- ``scene_toml``: the scene simulated, as TOML with every value filled in, and
  ``base_dir``: the folder its relative paths start in,

so `follicle render` can grow the same hair on every frame without the scene file.
Written atomically with fixed member timestamps: the same run gives the same bytes.

This module knows the file, not what a scene means: the stored scene is its TOML text,
which :func:`follicle.pipeline.cache_scene` reads (and
:func:`follicle.pipeline.describe_cache` describes, for `follicle info`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..arrays import RIGID_TOLERANCE, all_finite, frozen, rigid
from ..errors import FormatError, InputError
from ..validate import file_path, positive
from .npz import load_arrays, save_arrays

__all__ = [
    "write_cache",
    "CACHE_FORMAT",
    "CACHE_VERSION",
    "SimCache",
    "save_cache",
    "load_cache",
    "is_cache",
]

CACHE_FORMAT = "follicle-sim-cache"
CACHE_VERSION = 2  # 2 added skin_vertices; caches without them are still written as 1
_KEYS = ("format", "version", "positions", "transforms", "fps", "scene_toml", "base_dir")


def _text(name: str, value: object) -> str:
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind == "U":
        value = str(value[()])
    if not isinstance(value, str):
        raise InputError(f"{name}: expected a text string, got {_describe(value)}")
    if "\0" in value:
        raise InputError(f"{name}: contains a NUL character; expected plain text")
    return value


def _describe(value: object) -> str:
    if isinstance(value, np.ndarray):
        return f"{value.dtype} array of shape {value.shape}"
    return type(value).__name__


def _suspect_frames(tr: np.ndarray) -> np.ndarray:
    """Frames whose transform may not be a finite rigid motion, checked all at once: a
    loop of :func:`rigid` takes a minute on the million frames a 150 MB cache can hold."""
    rot = tr[:, :3, :3]
    scale = np.abs(np.einsum("fji,fjk->fik", rot, rot) - np.eye(3)).max(axis=(1, 2), initial=0)
    last = np.abs(tr[:, 3] - (0.0, 0.0, 0.0, 1.0)).max(axis=1, initial=0)
    finite = np.isfinite(tr).all(axis=(1, 2))
    return np.flatnonzero(~finite | (scale > RIGID_TOLERANCE) | (last > RIGID_TOLERANCE))


@dataclass(frozen=True, eq=False)
class SimCache:
    """A simulation's frames: guide ``positions`` (F, S, N, 3) float32, head ``transforms``
    (F, 4, 4) float64, ``fps``, and the scene as TOML text (``scene_toml``; its relative
    paths start in ``base_dir``), read by :func:`follicle.pipeline.cache_scene`; with a
    skin animation, the skin's ``skin_vertices`` (F, V, 3) float32 per frame.

    Every array is checked (dtype, shape, finite, rigid transforms) and kept read-only;
    ``source`` names the cache in error messages.
    """

    positions: np.ndarray
    transforms: np.ndarray
    fps: float
    scene_toml: str
    base_dir: str
    source: str = field(default="simulation cache", compare=False)
    skin_vertices: np.ndarray | None = None

    def __post_init__(self) -> None:
        pos, tr = self.positions, self.transforms
        if not isinstance(pos, np.ndarray) or pos.dtype != np.float32 or pos.ndim != 4:
            raise InputError(
                f"positions: expected a float32 (F, S, N, 3) array, got {_describe(pos)}"
            )
        f, s, n, three = pos.shape
        if f < 1 or s < 1 or n < 2 or three != 3:
            raise InputError(
                f"positions: expected (F ≥ 1, S ≥ 1, N ≥ 2, 3) frames × strands × vertices,"
                f" got shape {pos.shape}"
            )
        if not isinstance(tr, np.ndarray) or tr.dtype != np.float64 or tr.shape[1:] != (4, 4):
            raise InputError(f"transforms: expected a float64 (F, 4, 4) array, got {_describe(tr)}")
        if tr.shape[0] != f:
            raise InputError(
                f"frame counts differ: {f} frames of positions but {tr.shape[0]} transforms"
            )
        if not all_finite(pos):
            frame = int(np.flatnonzero(~np.isfinite(pos).reshape(f, -1).all(axis=1))[0])
            raise InputError(f"positions: frame {frame} contains NaN or inf")
        for k in _suspect_frames(tr)[:1]:  # rigid() says what is wrong with the first
            rigid(tr[k], f"transforms: frame {k}")  # finite, last row 0 0 0 1, no scale
        fps = self.fps
        if isinstance(fps, np.ndarray) and fps.ndim == 0:
            fps = fps.item()  # as a loaded cache stores it
        fps = positive(fps, "fps")
        skin = self.skin_vertices
        if skin is not None:
            if not isinstance(skin, np.ndarray) or skin.dtype != np.float32 or skin.ndim != 3:
                raise InputError(
                    f"skin_vertices: expected a float32 (F, V, 3) array, got {_describe(skin)}"
                )
            if skin.shape[0] != f or skin.shape[1] < 3 or skin.shape[2] != 3:
                raise InputError(
                    f"skin_vertices: expected ({f}, V ≥ 3, 3), one skin a frame, got shape"
                    f" {skin.shape}"
                )
            if not all_finite(skin):
                frame = int(np.flatnonzero(~np.isfinite(skin).reshape(f, -1).all(axis=1))[0])
                raise InputError(f"skin_vertices: frame {frame} contains NaN or inf")
            object.__setattr__(self, "skin_vertices", frozen(skin))
        object.__setattr__(self, "positions", frozen(pos))
        object.__setattr__(self, "transforms", frozen(tr))
        object.__setattr__(self, "fps", fps)
        object.__setattr__(self, "scene_toml", _text("scene_toml", self.scene_toml))
        object.__setattr__(self, "base_dir", _text("base_dir", self.base_dir))

    @property
    def frame_count(self) -> int:
        return int(self.positions.shape[0])

    @property
    def strand_count(self) -> int:
        return int(self.positions.shape[1])

    @property
    def vertex_count(self) -> int:
        """Vertices per simulated strand."""
        return int(self.positions.shape[2])


def save_cache(
    path: str | os.PathLike[str],
    positions: object,
    transforms: object,
    fps: float,
    scene_toml: str,
    base_dir: str,
    skin_vertices: object | None = None,
) -> Path:
    """Write a simulation cache to ``path`` (.npz) atomically; positions and skin vertices
    are stored as float32, transforms as float64. Bad arrays raise InputError and write
    nothing."""
    path = file_path(path, "save_cache path")
    if Path(path).suffix.lower() != ".npz":
        raise FormatError(f"{path}: a simulation cache must end in .npz")
    try:
        pos = np.asarray(positions, dtype=np.float32)
        tr = np.asarray(transforms, dtype=np.float64)
        skin = None if skin_vertices is None else np.asarray(skin_vertices, dtype=np.float32)
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"save_cache: positions, transforms and skin vertices must be numeric ({exc})"
        ) from None
    cache = SimCache(pos, tr, fps, scene_toml, str(base_dir), str(path), skin)
    arrays = {
        "format": np.array(CACHE_FORMAT),
        "version": np.array(1 if skin is None else CACHE_VERSION, dtype=np.int64),
        "positions": cache.positions,
        "transforms": cache.transforms,
        "fps": np.array(cache.fps, dtype=np.float64),
        "scene_toml": np.array(cache.scene_toml),
        "base_dir": np.array(cache.base_dir),
    }
    if cache.skin_vertices is not None:
        arrays["skin_vertices"] = cache.skin_vertices
    return save_arrays(path, arrays)


def write_cache(cache: SimCache, path: str | os.PathLike[str]) -> Path:
    """:func:`save_cache` of everything ``cache`` holds (a simulation's, before it is
    written)."""
    path = file_path(path, "write_cache path")
    return save_cache(
        path,
        cache.positions,
        cache.transforms,
        cache.fps,
        cache.scene_toml,
        cache.base_dir,
        skin_vertices=cache.skin_vertices,
    )


def is_cache(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a readable ``.npz`` whose ``format`` says simulation cache (any
    version); False for curves files, other archives, damaged, non-zip and missing files."""
    path = file_path(path, "is_cache path")
    try:
        tag = load_arrays(path, only={"format"})[1].get("format")
    except FormatError:
        return False
    return _is_tag(tag)


def _is_tag(tag: np.ndarray | None) -> bool:
    """True when ``tag`` (the ``format`` array, None if absent) names a simulation cache."""
    return (
        tag is not None and tag.ndim == 0 and tag.dtype.kind == "U" and str(tag[()]) == CACHE_FORMAT
    )


def load_cache(path: str | os.PathLike[str]) -> SimCache:
    """Read and check a cache written by :func:`save_cache`; FormatError says what is wrong."""
    path = file_path(path, "load_cache path")
    p, data = load_arrays(path)
    if not _is_tag(data.get("format")):
        raise FormatError(
            f"{p}: not a simulation cache (no format = {CACHE_FORMAT!r}); write one with"
            " `follicle simulate`"
        )
    missing = [k for k in _KEYS if k not in data]
    if missing:
        raise FormatError(f"{p}: missing array(s) {', '.join(missing)}; the cache is incomplete")
    version = data["version"]
    if version.ndim != 0 or version.dtype.kind not in "iu":
        raise FormatError(f"{p}: version: expected an integer, got {_describe(version)}")
    if not 1 <= int(version) <= CACHE_VERSION:
        fix = "upgrade follicle" if int(version) > CACHE_VERSION else "simulate again"
        raise FormatError(
            f"{p}: cache version {int(version)}; this follicle reads versions 1 to"
            f" {CACHE_VERSION}: {fix}"
        )
    fps = data["fps"]
    if fps.ndim != 0 or fps.dtype.kind != "f":
        raise FormatError(f"{p}: fps: expected a float, got {_describe(fps)}")
    try:
        return SimCache(
            data["positions"],
            data["transforms"],
            float(fps),  # a float scalar (checked above); SimCache checks it is > 0
            _text("scene_toml", data["scene_toml"]),  # stored as 0-d str arrays
            _text("base_dir", data["base_dir"]),
            source=str(p),
            skin_vertices=data.get("skin_vertices"),
        )
    except InputError as exc:
        fix = "the cache is damaged: run `follicle simulate` again"
        raise FormatError(f"{p}: {exc}; {fix}") from None
