"""The raster engines and the choice between them: ``opengl`` (:class:`~.opengl.Renderer`,
shaders through EGL), ``cpu`` (:class:`~.cpu.CpuRenderer`, follicle's own strand
rasterizer) and ``auto``, which takes OpenGL where the GL context is a GPU's and the CPU
engine where it is a software rasterizer (Mesa's llvmpipe, softpipe) or where no EGL
context can be made at all — so a machine without Mesa still renders.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from ..errors import FollicleError, InputError
from .image import save_png
from .options import ENGINES

if TYPE_CHECKING:
    from ..curves import HairCurves
    from .camera import Camera
    from .cpu import CpuRenderer
    from .opengl import Renderer
    from .settings import RenderParams

__all__ = [
    "ENGINES",
    "SOFTWARE_GL",
    "resolve_engine",
    "make_renderer",
    "render_image",
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
    """``opengl`` or ``cpu``: the engine itself, or what ``auto`` picks on this machine
    (decided once per process)."""
    if engine not in ENGINES:
        raise InputError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")
    if engine != "auto":
        return engine
    pid = os.getpid()
    if pid not in _automatic:
        _automatic[pid] = _choose()
    return _automatic[pid]


def make_renderer(settings: RenderParams | None = None) -> Renderer | CpuRenderer:
    """A renderer of the ``engine`` (resolved by :func:`resolve_engine`), ``size``,
    ``msaa``, background and ``shadow_size`` of ``settings`` (None: defaults)."""
    from .settings import with_overrides

    settings = with_overrides(settings, {})
    if resolve_engine(settings.engine) == "cpu":
        from .cpu import CpuRenderer

        return CpuRenderer.from_settings(settings)
    from .opengl import Renderer

    return Renderer.from_settings(settings)


def render_image(
    curves: HairCurves | None,
    mesh: object | None = None,
    camera: Camera | None = None,
    settings: RenderParams | None = None,
    out: str | os.PathLike[str] | None = None,
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
    (atomically). The engine is ``settings.engine`` (:func:`resolve_engine`); see
    :meth:`follicle.render.Renderer.draw` for the rest.
    """
    from .settings import with_overrides

    settings = with_overrides(settings, overrides)
    with make_renderer(settings) as r:
        image = r.draw(curves, mesh, camera=camera, settings=settings)
    if out is not None:
        save_png(image, out)
    return image
