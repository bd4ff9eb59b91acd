"""What the raster engines' renderers share (:class:`RasterRenderer`): the OpenGL
engine's :class:`~follicle.render.opengl.Renderer` and the CPU engine's
:class:`~follicle.render.cpu.CpuRenderer`; :mod:`~follicle.render.engines` chooses
between them."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, TypeVar

from ..validate import whole
from .options import DEFAULT_SHADOW_SIZE, MAX_SHADOW_SIZE, parse_background, parse_size

if TYPE_CHECKING:
    from .settings import RenderParams

__all__ = ["RasterRenderer"]

R = TypeVar("R", bound="RasterRenderer")


class RasterRenderer:
    """What the raster engines' renderers share: made with an image ``size`` (width,
    height), ``msaa`` samples, a ``background`` (one linear RGB colour or (top, bottom))
    and ``shadow_size`` texels a side for the key light's maps, or from a scene's
    ``[render]`` (:meth:`from_settings`); used as context managers (:meth:`release`)."""

    def __init__(
        self,
        size: Sequence[int] = (960, 960),
        msaa: int = 4,
        background: object = None,
        shadow_size: int = DEFAULT_SHADOW_SIZE,
    ) -> None:
        self.size = parse_size(size)
        self.msaa = whole(msaa, "msaa", 0, 64, what="samples per pixel (0 or 1: off)")
        self.shadow_size = whole(shadow_size, "shadow_size", 16, MAX_SHADOW_SIZE, what="texels")
        self.background = parse_background(background)

    @classmethod
    def from_settings(cls: type[R], settings: RenderParams | None = None) -> R:
        """A renderer of the ``size``, ``msaa``, background and ``shadow_size`` of
        ``settings`` (:class:`~follicle.render.settings.RenderParams`; None: defaults)."""
        from .settings import with_overrides

        s = with_overrides(settings, {})
        return cls(s.size, s.msaa, s.background, s.shadow_size)

    def release(self) -> None:
        """Free what the renderer holds (nothing here)."""

    def __enter__(self: R) -> R:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()
