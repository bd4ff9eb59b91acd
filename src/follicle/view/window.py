"""The on-screen window: GLFW with an OpenGL 3.3 core context that the renderer draws
on (so no second context and no context switching); each frame's image is shown as a
full-window textured triangle, under the ImGui panel."""

from __future__ import annotations

import ctypes
import importlib
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..errors import FollicleError

if TYPE_CHECKING:
    import moderngl

__all__ = ["Window"]

_VS = """#version 330 core
out vec2 uv;
void main() {
    vec2 p = vec2((gl_VertexID & 1) * 4.0 - 1.0, (gl_VertexID >> 1) * 4.0 - 1.0);
    uv = vec2(p.x * 0.5 + 0.5, 0.5 - p.y * 0.5);  // the image's top row first
    gl_Position = vec4(p, 0.0, 1.0);
}
"""
_FS = """#version 330 core
uniform sampler2D image;
in vec2 uv;
out vec4 colour;
void main() { colour = texture(image, uv); }
"""
NO_WINDOW = (
    "cannot open a window: no display (set DISPLAY, or run under `xvfb-run -a`; on"
    " Debian/Ubuntu `apt-get install xvfb`)"
)


def glfw_module():
    """The ``glfw`` package, bound to imgui-bundle's GLFW library (imported first, it
    points the package there, so the panel and the window share one GLFW)."""
    try:
        importlib.import_module("imgui_bundle")
        import glfw

        glfw.ERROR_REPORTING = "log"  # GLFW errors go to logging; failures raise below
    except ImportError as exc:
        raise FollicleError(
            f"the viewer needs the view extra ({exc}): `pip install 'follicle[view]'`"
        ) from exc
    return glfw


class Window:
    """A resizable window, first ``size`` pixels; ``visible`` False keeps it off screen
    (still a real window and context: what tests and ``--frames`` runs use)."""

    def __init__(self, size: Sequence[int], title: str = "follicle", visible: bool = True) -> None:
        import moderngl

        self.glfw = glfw = glfw_module()
        if not glfw.init():
            raise FollicleError(NO_WINDOW)
        for hint, value in (
            (glfw.CONTEXT_VERSION_MAJOR, 3),
            (glfw.CONTEXT_VERSION_MINOR, 3),
            (glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE),
            (glfw.OPENGL_FORWARD_COMPAT, True),
            (glfw.RESIZABLE, True),
            (glfw.VISIBLE, bool(visible)),
        ):
            glfw.window_hint(hint, value)
        self.handle = glfw.create_window(int(size[0]), int(size[1]), title, None, None)
        if not self.handle:
            glfw.terminate()
            raise FollicleError(f"{NO_WINDOW}; or the driver lacks OpenGL 3.3 core")
        glfw.make_context_current(self.handle)
        glfw.swap_interval(0)  # as fast as the simulation goes, not the monitor
        self.ctx = moderngl.create_context(require=330)
        self._vao = self.ctx.vertex_array(
            self.ctx.program(vertex_shader=_VS, fragment_shader=_FS), []
        )
        self._texture: moderngl.Texture | None = None

    @property
    def address(self) -> int:
        """The GLFWwindow pointer, for ImGui's GLFW backend."""
        pointer = ctypes.cast(self.handle, ctypes.c_void_p).value
        if pointer is None:
            raise FollicleError("the window is closed")
        return pointer

    def framebuffer_size(self) -> tuple[int, int]:
        """The window's drawable size in pixels now ((0, 0) while minimised)."""
        w, h = self.glfw.get_framebuffer_size(self.handle)
        return int(w), int(h)

    def should_close(self) -> bool:
        return bool(self.glfw.window_should_close(self.handle))

    def show(self, image: np.ndarray) -> None:
        """Draw ``image`` ((H, W, 4) uint8, top row first) over the whole window."""
        ctx = self.ctx
        h, w = image.shape[:2]
        if self._texture is None or self._texture.size != (w, h):
            if self._texture is not None:
                self._texture.release()
            self._texture = ctx.texture((w, h), 4)
        self._texture.write(np.ascontiguousarray(image))
        ctx.screen.use()
        ctx.viewport = (0, 0, *self.framebuffer_size())
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND)
        self._texture.use(0)
        self._vao.render(vertices=3)

    def close(self) -> None:
        """Destroy the window and its context."""
        if self.handle is not None:
            self.glfw.destroy_window(self.handle)
            self.glfw.terminate()
            self.handle = None
