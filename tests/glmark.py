"""The ``gl`` mark shared by the tests that draw: skipped on a developer machine without
EGL, never in CI, where a missing EGL must fail."""

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


gl = pytest.mark.skipif(
    not os.environ.get("CI") and not _gl_available(),
    reason="no EGL / OpenGL 3.3 (install Mesa EGL: libegl1 libgl1-mesa-dri)",
)
