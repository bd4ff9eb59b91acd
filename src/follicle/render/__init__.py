"""Rendering: camera and lights, the OpenGL and CPU hair engines, PNG output.

``follicle.render`` is this package and, called, :func:`follicle.render.engines.render`
(``follicle.render(curves, mesh=mesh, out="hair.png")``): one name for both, so that
``import follicle.render`` does not hide the function and the function does not hide the
package's names (``follicle.render.Renderer``). Its names are imported on first use,
so importing follicle loads no renderer (no numba, no moderngl).
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import Any

_LAZY = {
    "render": "engines",
    "make_renderer": "engines",
    "Camera": "camera",
    "Light": "camera",
    "default_lights": "camera",
    "fit_camera": "camera",
    "frame_camera": "camera",
    "Renderer": "opengl",
    "CpuRenderer": "cpu",
    "save_png": "image",
    "linear_to_srgb": "image",
    "srgb_to_linear": "image",
}

__all__ = list(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})


class _CallableModule(types.ModuleType):
    """This package, callable as :func:`follicle.render.engines.render`."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        from .engines import render

        return render(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
