"""The OpenGL context: one headless (EGL) standalone context per process, cached.

Rendering needs OpenGL 3.3 core or newer (geometry shaders, multisampled
renderbuffers). On a machine without a GPU, Mesa's llvmpipe software rasteriser
provides OpenGL 4.5 through EGL; on Debian/Ubuntu install ``libegl1`` and
``libgl1-mesa-dri`` (and ``libegl-mesa0`` where it is a separate package).
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator
from typing import TYPE_CHECKING

from ..errors import FollicleError

if TYPE_CHECKING:
    import moderngl

__all__ = ["get_context", "use_context", "GL_REQUIRED", "INSTALL_HINT"]

GL_REQUIRED = 330

INSTALL_HINT = (
    "follicle renders headless through EGL and needs OpenGL 3.3 or newer. Install Mesa's EGL and"
    " drivers (Debian/Ubuntu: `apt-get install libegl1 libgl1-mesa-dri`, plus `libegl-mesa0` on"
    " older releases; Fedora: `dnf install mesa-libEGL mesa-dri-drivers`), or a GPU driver that"
    " provides libEGL."
)

_lock = threading.Lock()
_cached: dict[int, moderngl.Context] = {}  # pid -> context (a forked child needs its own)
_borrowed: list[moderngl.Context] = []  # contexts lent by use_context, innermost last


@contextlib.contextmanager
def use_context(ctx: moderngl.Context) -> Iterator[moderngl.Context]:
    """Within the block, :func:`get_context` returns ``ctx`` (e.g. an on-screen window's
    moderngl context), so renderers made there draw on it instead of the headless one."""
    _borrowed.append(ctx)
    try:
        yield ctx
    finally:
        _borrowed.remove(ctx)


def get_context() -> moderngl.Context:
    """The process's cached moderngl standalone context (EGL backend).

    Raises FollicleError, saying what to install, when EGL or OpenGL >= 3.3 is missing.
    """
    if _borrowed:
        return _borrowed[-1]
    pid = os.getpid()
    ctx = _cached.get(pid)
    if ctx is not None:
        return ctx
    with _lock:
        ctx = _cached.get(pid)
        if ctx is None:
            ctx = _create()
            _cached.clear()  # contexts inherited over fork() are unusable
            _cached[pid] = ctx
    return ctx


def _create() -> moderngl.Context:
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - moderngl is a dependency
        raise FollicleError(f"cannot import moderngl ({exc}); `pip install moderngl`") from exc
    try:
        ctx = moderngl.create_standalone_context(
            require=GL_REQUIRED,
            # moderngl's stub types every ``**settings`` value as a dict, wrongly
            backend="egl",  # type: ignore[arg-type]
        )
    except Exception as exc:
        raise FollicleError(
            f"cannot create a headless OpenGL context ({exc}). {INSTALL_HINT}"
        ) from exc
    if ctx.version_code < GL_REQUIRED:
        version = ctx.version_code
        ctx.release()
        raise FollicleError(
            f"the OpenGL driver offers version {version // 100}.{version % 100 // 10}, "
            f"follicle needs 3.3 or newer. {INSTALL_HINT}"
        )
    return ctx
