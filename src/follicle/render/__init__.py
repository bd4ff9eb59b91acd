"""Rendering: camera and lights, the OpenGL and CPU hair engines, PNG output.

:func:`render_image` (also ``follicle.render_image``) draws hair to an image with the
engine a :class:`~follicle.render.settings.RenderParams` names. The package's names are
imported on first use, so importing it loads no renderer (no numba, no moderngl).

Calling the package itself (``follicle.render(curves, ...)``, the name of
:func:`render_image` before 0.2) still works for this release, with a
DeprecationWarning.
"""

from __future__ import annotations

import sys
import types
import warnings
from typing import Any

from ..lazy import attach_stub

__getattr__, __dir__, __all__ = attach_stub(__name__, __file__)


class _DeprecatedCall(types.ModuleType):
    """This package, callable for one more release as :func:`render_image` was named."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        warnings.warn(
            "follicle.render(...) is now follicle.render_image(...); follicle.render is"
            " the rendering package, and calling it stops working in follicle 0.3",
            DeprecationWarning,
            stacklevel=2,
        )
        from .backends import render_image

        return render_image(*args, **kwargs)


sys.modules[__name__].__class__ = _DeprecatedCall
