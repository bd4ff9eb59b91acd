"""follicle: grow, simulate and render hair and fur.

The public API, re-exported lazily so that ``import follicle`` stays quick (no numba,
USD, Alembic, OpenGL or Dask until they are used)::

    mesh = follicle.load_mesh("builtin:head")
    guides = follicle.load_guides("builtin:long", mesh)
    curves = follicle.Groom(mesh, guides).generate(count=20000)
    follicle.render(curves, mesh=mesh, out="hair.png")
    follicle.save(curves, "hair.npz")
"""

from __future__ import annotations

import importlib
from typing import Any

from . import render
from .errors import (
    ConfigError,
    FileAccessError,
    FollicleError,
    FormatError,
    InputError,
    ResourceError,
    SimulationError,
)

__version__ = "0.1.0"

_LAZY = {
    "HairCurves": "follicle.curves",
    "Camera": "follicle.render.camera",
    "Light": "follicle.render.camera",
    "SkinMesh": "follicle.mesh.skin",
    "Texture": "follicle.mesh.texture",
    "DensitySampler": "follicle.mesh.sampling",
    "PropertyMap": "follicle.mesh.property",
    "displace": "follicle.mesh.displacement",
    "load_mesh": "follicle.io.mesh_load",
    "Guides": "follicle.groom.guides",
    "load_guides": "follicle.groom.guides",
    "GuideEditor": "follicle.groom.editor",
    "Groom": "follicle.groom.generator",
    "Simulator": "follicle.sim.simulator",
    "Scene": "follicle.scene",
    "load_scene": "follicle.scene",
    "grow": "follicle.pipeline",
    "save": "follicle.io.dispatch",
    "load_curves": "follicle.io.dispatch",
}

__all__ = [
    "FollicleError",
    "InputError",
    "FormatError",
    "FileAccessError",
    "ConfigError",
    "SimulationError",
    "ResourceError",
    "render",
    *_LAZY,
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'follicle' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
