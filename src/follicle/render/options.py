"""Renderer options: defaults, and validation of sizes, colours, shading and meshes."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import InputError

__all__ = [
    "SHADINGS",
    "MAX_SUBDIVISIONS",
    "MAX_LIGHTS",
    "MAX_SIZE",
    "DEFAULT_HAIR_COLOR",
    "DEFAULT_HAIR_WIDTH",
    "DEFAULT_SKIN_COLOR",
    "DEFAULT_BACKGROUND",
    "DEFAULT_SHADING_PARAMS",
    "color3",
    "parse_background",
    "parse_size",
    "parse_shading",
    "check_mesh",
    "point_attr",
]

SHADINGS = ("kajiya-kay",)
MAX_SUBDIVISIONS = 16
MAX_LIGHTS = 8
MAX_SIZE = 8192

DEFAULT_HAIR_COLOR = (0.16, 0.09, 0.045)  # linear RGB, a mid brown
DEFAULT_HAIR_WIDTH = 80e-6  # diameter, metres
DEFAULT_SKIN_COLOR = (0.42, 0.25, 0.18)  # linear RGB
DEFAULT_BACKGROUND = ((0.09, 0.095, 0.11), (0.012, 0.012, 0.016))  # (top, bottom), linear

DEFAULT_SHADING_PARAMS: dict[str, object] = {
    "diffuse": 0.6,  # K_d, eq. 3.8
    "specular": 0.22,  # K_s, eq. 3.9, primary (white) highlight
    "shininess": 80.0,  # p, eq. 3.9
    "specular_color": (1.0, 0.97, 0.92),
    "specular2": 0.35,  # secondary highlight, tinted by the hair colour
    "shininess2": 20.0,
    "shift": -0.08,  # tangent shifts along the fibre normal (Scheuermann)
    "shift2": 0.12,
    "root_occlusion": 0.65,  # darkening towards the root, 0 .. 1
    "roundness": 0.35,  # darkening towards the ribbon edges, 0 .. 1
    "min_width_px": 1.0,  # thinner hair is widened to this many pixels and faded
    "skin_wrap": 0.1,  # wrap-around term of the skin's Lambert shading
}


def color3(value: object, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise InputError(f"{name}: expected 3 non-negative linear RGB numbers, got {value!r}")
    return arr


def parse_background(background: object) -> tuple[np.ndarray, np.ndarray]:
    if background is None:
        background = DEFAULT_BACKGROUND
    arr = np.asarray(background, dtype=np.float64)
    if arr.shape == (3,):
        top = bottom = color3(arr, "background")
    elif arr.shape == (2, 3):
        top, bottom = color3(arr[0], "background top"), color3(arr[1], "background bottom")
    else:
        raise InputError(
            "background: expected one linear RGB colour (r, g, b) or a vertical gradient"
            f" ((r, g, b) top, (r, g, b) bottom), got shape {arr.shape}"
        )
    return top, bottom


def parse_size(size: object) -> tuple[int, int]:
    try:
        w, h = size  # type: ignore[misc]
    except (TypeError, ValueError):
        raise InputError(f"size: expected (width, height), got {size!r}") from None
    out = []
    for v in (w, h):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 0 < v <= MAX_SIZE:
            raise InputError(
                f"size: width and height must be integers in 1..{MAX_SIZE}, got {size!r}"
            )
        out.append(int(v))
    return out[0], out[1]


def parse_shading(shading: str, params: Mapping[str, object] | None) -> dict[str, object]:
    if shading not in SHADINGS:
        raise InputError(f"shading: unknown model {shading!r}; allowed: {', '.join(SHADINGS)}")
    merged = dict(DEFAULT_SHADING_PARAMS)
    for key, value in (params or {}).items():
        if key not in DEFAULT_SHADING_PARAMS:
            raise InputError(
                f"shading_params: unknown key {key!r}; allowed: {', '.join(DEFAULT_SHADING_PARAMS)}"
            )
        if key == "specular_color":
            merged[key] = tuple(color3(value, "shading_params['specular_color']"))
        else:
            try:
                merged[key] = float(value)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                raise InputError(
                    f"shading_params[{key!r}]: expected a number, got {value!r}"
                ) from None
            if not np.isfinite(merged[key]):
                raise InputError(f"shading_params[{key!r}]: must be finite, got {value!r}")
    if merged["shininess"] <= 0 or merged["shininess2"] <= 0:
        raise InputError("shading_params: shininess and shininess2 must be positive")
    if merged["min_width_px"] <= 0:
        raise InputError("shading_params['min_width_px']: must be positive")
    return merged


def check_mesh(mesh: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    try:
        vertices = np.asarray(mesh.vertices, dtype=np.float64)  # type: ignore[attr-defined]
        faces = np.asarray(mesh.faces)  # type: ignore[attr-defined]
        normals = np.asarray(mesh.vertex_normals("current"), dtype=np.float64)  # type: ignore[attr-defined]
    except AttributeError as exc:
        raise InputError(
            "mesh: expected a SkinMesh (vertices, faces, vertex_normals),"
            f" got {type(mesh).__name__}"
        ) from exc
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise InputError(
            "mesh: expected vertices (V, 3) and faces (F, 3),"
            f" got {vertices.shape} and {faces.shape}"
        )
    if normals.shape != vertices.shape:
        raise InputError(
            f"mesh: vertex normals have shape {normals.shape}, expected {vertices.shape}"
        )
    if not (np.all(np.isfinite(vertices)) and np.all(np.isfinite(normals))):
        raise InputError("mesh: vertices or normals contain NaN or inf")
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise InputError("mesh: face indices out of range of the vertices")
    return vertices, faces, normals


def point_attr(
    pd: Mapping[str, np.ndarray], key: str, shape: tuple[int, ...], default
) -> np.ndarray:
    if key in pd:
        arr = np.asarray(pd[key], dtype=np.float32)
        if arr.shape != shape:
            raise InputError(f"point_data[{key!r}]: expected shape {shape}, got {arr.shape}")
        return arr
    return np.broadcast_to(np.asarray(default, dtype=np.float32), shape)
