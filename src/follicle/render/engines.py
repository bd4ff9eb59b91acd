"""The raster engines and the choice between them: ``opengl`` (:class:`~.opengl.Renderer`,
shaders through EGL), ``cpu`` (:class:`~.cpu.CpuRenderer`, follicle's own strand
rasterizer) and ``auto``, which takes OpenGL where the GL context is a GPU's and the CPU
engine where it is a software rasterizer (Mesa's llvmpipe, softpipe) or where no EGL
context can be made at all — so a machine without Mesa still renders.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConfigError, FollicleError, InputError
from .image import save_png
from .options import ENGINE_NAMES, RASTER_ENGINES

if TYPE_CHECKING:
    from ..curves import HairCurves
    from .camera import Camera
    from .cpu import CpuRenderer
    from .opengl import Renderer
    from .settings import RenderParams

__all__ = [
    "SOFTWARE_GL",
    "resolve_engine",
    "make_renderer",
    "draw_raster",
]

SOFTWARE_GL = ("llvmpipe", "softpipe", "swrast", "swr")  # GL_RENDERER of a CPU's GL
_automatic: dict[int, str] = {}  # pid -> the engine "auto" chose


def _choose() -> str:
    from .context import get_context

    try:
        ctx = get_context()
    except FollicleError:
        return "cpu"
    name = str(ctx.info.get("GL_RENDERER", "")).lower()
    return "cpu" if any(word in name for word in SOFTWARE_GL) else "opengl"


def resolve_engine(engine: str) -> str:
    """``opengl`` or ``cpu``: the raster engine itself, or what ``auto`` picks on this
    machine (decided once per process); a ConfigError for an engine that draws stills
    only (:mod:`follicle.render.backends`: Mitsuba's path tracer)."""
    if engine not in ENGINE_NAMES:
        raise InputError(f"engine: expected one of {', '.join(RASTER_ENGINES)}, got {engine!r}")
    if engine not in RASTER_ENGINES:
        raise ConfigError(
            f"[render].engine = {engine!r}: the viewer, a simulation cache's frames and"
            f" videos are drawn by a raster engine: {', '.join(RASTER_ENGINES)}"
        )
    if engine != "auto":
        return engine
    pid = os.getpid()
    if pid not in _automatic:
        _automatic[pid] = _choose()
    return _automatic[pid]


def make_renderer(settings: RenderParams | None = None) -> Renderer | CpuRenderer:
    """A raster renderer of the ``engine`` (resolved by :func:`resolve_engine`), ``size``,
    ``msaa``, background and ``shadow_size`` of ``settings`` (None: defaults): what the
    viewer and a cache's frames draw with, so a stills-only engine is a ConfigError."""
    from .settings import with_overrides

    settings = with_overrides(settings, {})
    if resolve_engine(settings.engine) == "cpu":
        from .cpu import CpuRenderer

        return CpuRenderer.from_settings(settings)
    from .opengl import Renderer

    return Renderer.from_settings(settings)


def draw_raster(
    curves: HairCurves | None,
    mesh: object | None = None,
    camera: Camera | None = None,
    settings: RenderParams | None = None,
    out: str | os.PathLike[str] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> np.ndarray:
    """A still drawn by the raster engine ``settings.engine`` names
    (:func:`make_renderer`): the raster engines' entry in the registry."""
    with make_renderer(settings) as r:
        image = r.draw(curves, mesh, camera=camera, settings=settings)
    if out is not None:
        save_png(image, out)
    if progress is not None:
        progress(1, 1)
    return image
