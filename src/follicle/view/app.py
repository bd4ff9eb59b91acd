"""``follicle.view``: the live viewer's loop, with a window or offscreen."""

from __future__ import annotations

import os
import time
from collections.abc import Sequence

from ..scene import Scene, load_scene
from ..validate import whole
from .controller import Controller

__all__ = ["view"]


def view(
    scene: Scene | str | os.PathLike[str] | None = None,
    frames: int | None = None,
    screenshot: str | os.PathLike[str] | None = None,
    size: Sequence[int] = (960, 540),
    fps: float = 30.0,
    window: bool = True,
    visible: bool = True,
    quality: str = "full",
    source: str | os.PathLike[str] | None = None,
    hold_fps: float | None = None,
) -> Controller:
    """Simulate and render ``scene`` live; returns the Controller when the loop ends.

    ``frames`` None runs until the window closes (Esc), else that many frames. With
    ``window`` False the loop runs offscreen (no display, no panel). ``screenshot``
    writes the last frame's render as PNG. ``fps`` is the simulated frame rate (each
    frame steps 1 / fps s); the overlay shows the rate actually reached. ``quality``
    is the Controller's ("full" or "fast"); ``source``, the scene's file (when
    ``scene`` is a path, that path), is where the panel saves the scene by default;
    ``hold_fps`` the frame rate the Controller holds by level of detail (None: off). A
    recording still on when the loop ends is finished.
    """
    frames = whole(frames, "frames", 1, allow_none=True)
    if not isinstance(scene, Scene):
        source = scene if source is None else source
        scene = load_scene(scene)  # a bad scene fails before a window opens
    if not window:
        ctl = Controller(scene, size, fps, quality, source, hold_fps)
        try:
            _loop(ctl, frames, lambda image, rate: False)
            _finish(ctl, screenshot)
        finally:
            ctl.release()
        return ctl
    from ..render.context import use_context
    from .panel import Panel
    from .window import Window

    win = Window(size, "follicle view", visible)
    try:
        with use_context(win.ctx):
            ctl = Controller(scene, size, fps, quality, source, hold_fps)
            panel = Panel(win, ctl)
            try:

                def show(image, rate: float) -> bool:
                    win.glfw.poll_events()
                    quit_ = panel.frame(ctl, rate)
                    win.show(image)
                    panel.render()
                    win.glfw.swap_buffers(win.handle)
                    if all(win.framebuffer_size()):  # (0, 0) while minimised
                        ctl.resize(*win.framebuffer_size())
                    return quit_ or win.should_close()

                _loop(ctl, frames, show)
                _finish(ctl, screenshot)
            finally:
                panel.close()
                ctl.release()
    finally:
        win.close()
    return ctl


def _finish(ctl: Controller, screenshot: str | os.PathLike[str] | None) -> None:
    """The end of a loop: a recording still on is finished (one begun with no frame
    yet is dropped by ``release``), the screenshot written."""
    if ctl.recording:
        ctl.stop_recording()
    if screenshot is not None:
        ctl.screenshot(screenshot)


def _loop(ctl: Controller, frames: int | None, show) -> None:
    """Step, render and ``show(image, fps)`` (fps smoothed for the overlay) until
    ``frames`` are done or ``show`` says stop; sets ``ctl.loop_fps``, the loop's mean."""
    start = last = time.perf_counter()
    rate, done = 0.0, 0
    while frames is None or done < frames:
        image = ctl.step_frame()
        now = time.perf_counter()
        current = 1.0 / max(now - last, 1e-9)
        rate, last, done = (current if done == 0 else 0.9 * rate + 0.1 * current), now, done + 1
        if show(image, rate):
            break
    ctl.loop_fps = done / max(time.perf_counter() - start, 1e-9)
