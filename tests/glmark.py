"""The ``gl`` mark shared by the tests that draw: skipped on a developer machine without
EGL, never in CI, where a missing EGL must fail. :func:`skip_without_gl` is the same
skip taken inside a test or fixture (the ``opengl`` parameter of ``each_engine``)."""

from __future__ import annotations

import os

import pytest

from follicle.errors import FollicleError


def _gl_available() -> bool:
    try:
        from follicle.render.context import get_context

        get_context()
    except FollicleError:
        return False
    return True


REASON = "no EGL / OpenGL 3.3 (install Mesa EGL: libegl1 libgl1-mesa-dri)"
MISSING = not os.environ.get("CI") and not _gl_available()

gl = pytest.mark.skipif(MISSING, reason=REASON)


def skip_without_gl() -> None:
    """Skip the running test where ``@gl`` would have skipped it."""
    if MISSING:
        pytest.skip(REASON)
