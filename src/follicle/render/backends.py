"""The engine registry: every way follicle draws an image, by name, with what it can do.

``[render].engine``, ``follicle render --engine``, :func:`follicle.render_image` and the
viewer all read this one table: the names a scene may give, the function that draws a
still (a lazy ``"module:function"`` entry with :func:`~follicle.render.render_image`'s
parameters), and the capability flags that decide which settings and which jobs an
engine takes — so ``--engine mitsuba --msaa 8`` and a path-traced video are refused by
the same rule in the CLI and in Python. The settings model takes the names from
:mod:`follicle.render.options` (``ENGINE_NAMES``, ``RASTER_ENGINES``), which this table
must match (checked at import), so that the settings do not import the engines.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..errors import InputError
from .options import ENGINE_NAMES, RASTER_ENGINES

if TYPE_CHECKING:
    import numpy as np

    from ..curves import HairCurves
    from .camera import Camera
    from .settings import RenderParams

__all__ = ["Engine", "ENGINES", "get_engine", "render_image"]


@dataclass(frozen=True)
class Engine:
    """One engine: its ``name``, the ``draw`` entry (``"module:function"``), a one-line
    ``summary``, and what it can do."""

    name: str
    draw: str
    summary: str
    sequences: bool  # a cache's frames, a video, the viewer's window (False: stills only;
    # the engines that draw them are options.RASTER_ENGINES, which make_renderer takes)
    spp: bool  # takes [render].spp, samples per pixel (a path tracer)
    msaa: bool  # takes [render].msaa (a rasterizer)
    shading: bool  # takes [render].shading and shading_params (a hair shading model)
    needs_gl: bool  # needs an OpenGL context through EGL (Mesa's libEGL)
    extra: str | None = None  # the pip extra it needs, if any

    def drawer(self) -> Callable[..., Any]:
        """The function that draws a still, imported on first use."""
        module, _, name = self.draw.partition(":")
        return getattr(importlib.import_module(module), name)


_RASTER = "follicle.render.engines:draw_raster"
ENGINES: dict[str, Engine] = {
    engine.name: engine
    for engine in (
        Engine(
            "auto",
            _RASTER,
            "OpenGL on a GPU, follicle's CPU strand rasterizer on a software GL or without EGL",
            sequences=True,
            spp=False,
            msaa=True,
            shading=True,
            needs_gl=False,
        ),
        Engine(
            "opengl",
            _RASTER,
            "shaders through EGL",
            sequences=True,
            spp=False,
            msaa=True,
            shading=True,
            needs_gl=True,
        ),
        Engine(
            "cpu",
            _RASTER,
            "follicle's CPU strand rasterizer",
            sequences=True,
            spp=False,
            msaa=True,
            shading=True,
            needs_gl=False,
        ),
        Engine(
            "mitsuba",
            "follicle.render.mitsuba:render_mitsuba",
            "a path-traced reference still with Mitsuba 3 (the pbr extra)",
            sequences=False,
            spp=True,
            msaa=False,
            shading=False,
            needs_gl=False,
            extra="pbr",
        ),
    )
}
assert tuple(ENGINES) == ENGINE_NAMES  # the names the settings model takes
assert tuple(n for n, e in ENGINES.items() if e.sequences) == RASTER_ENGINES


def get_engine(name: str) -> Engine:
    """The engine called ``name``; InputError listing the names when there is none."""
    if name not in ENGINES:
        raise InputError(f"engine: expected one of {', '.join(ENGINE_NAMES)}, got {name!r}")
    return ENGINES[name]


def render_image(
    curves: HairCurves | None,
    mesh: object | None = None,
    camera: Camera | None = None,
    settings: RenderParams | None = None,
    out: str | os.PathLike[str] | None = None,
    progress: Callable[[int, int], None] | None = None,
    **overrides: object,
) -> np.ndarray:
    """Render hair (and an optional skin mesh) to an (H, W, 4) uint8 sRGB image.

    ``settings`` is a :class:`~follicle.render.settings.RenderParams` (a scene's
    ``[render]``; None: its defaults); keyword ``overrides`` change its keys (``size=(800,
    600)``, ``shading="marschner"``, ``engine="cpu"``, ``shadows=False``, ...) through
    ``settings.replace``, so a bad value is a ConfigError naming ``[render].key``;
    ``background`` also takes one colour or (top, bottom), and ``lights``
    :class:`~follicle.render.Light` objects. ``camera`` None takes the settings' eye and
    target, else frames the union of hair and mesh bounds at ``fov`` degrees
    (vertical). When ``out`` is given the image is also written there as PNG
    (atomically). The engine is ``settings.engine``, drawn by its entry in
    :data:`~follicle.render.backends.ENGINES`: the raster engines
    (:func:`~follicle.render.engines.draw_raster`; see
    :meth:`follicle.render.Renderer.draw`) or Mitsuba's path
    tracer (:func:`follicle.render.mitsuba.render_mitsuba`, ``spp`` samples per pixel).
    ``progress(done, total)`` hears the engine's progress (Mitsuba's per cent; a raster
    engine's one still).
    """
    from .settings import with_overrides

    settings = with_overrides(settings, overrides)
    draw = get_engine(settings.engine).drawer()
    return draw(curves, mesh, camera=camera, settings=settings, out=out, progress=progress)
