"""The ImGui parameter panel and keys: a thin layer that reads the Controller and calls
its actions; everything it does is reachable from Python without it."""

from __future__ import annotations

import typing

from ..errors import FollicleError
from .controller import Controller
from .controls import CONTROLS, SECTIONS, Control

__all__ = ["Panel", "KEYS"]

KEYS = (
    ("space", "play / pause"), ("S or .", "one step"), ("R", "reset"),
    ("arrows", "turn / nod the head"), ("drag", "orbit the camera"), ("wheel", "zoom"),
    ("Esc", "quit"),
)  # fmt: skip
TURN_SPEED = 90.0  # degrees per second while an arrow key is held
ORBIT_SPEED = 0.3  # degrees per pixel dragged
ZOOM_STEP = 0.9  # distance factor per wheel notch


def _choices(section: str, key: str) -> list[str]:
    return [str(v) for v in typing.get_args(SECTIONS[section].model_fields[key].annotation)]


class Panel:
    """ImGui on ``window`` (a :class:`~follicle.view.window.Window`), drawn each frame."""

    def __init__(self, window: object) -> None:
        from imgui_bundle import imgui

        self.imgui = imgui
        imgui.create_context()
        imgui.get_io().set_ini_filename("")  # no imgui.ini beside the user's files
        imgui.backends.glfw_init_for_opengl(window.address, True)
        imgui.backends.opengl3_init("#version 330")
        self.message = ""

    def frame(self, ctl: Controller, fps: float) -> bool:
        """Build this frame's panel and act on keys; True when the user asked to quit."""
        imgui = self.imgui
        imgui.backends.opengl3_new_frame()
        imgui.backends.glfw_new_frame()
        imgui.new_frame()
        quit_ = self._keys(ctl, fps)
        imgui.set_next_window_pos((8, 8), imgui.Cond_.first_use_ever)
        imgui.set_next_window_size((340, 0), imgui.Cond_.first_use_ever)
        imgui.begin("follicle")
        self._overlay(ctl, fps)
        if imgui.button("pause" if ctl.playing else "play"):
            ctl.toggle_play()
        imgui.same_line()
        if imgui.button("step"):
            ctl.step()
        imgui.same_line()
        if imgui.button("reset"):
            ctl.reset()
        if self.message:
            imgui.text_colored((1.0, 0.4, 0.3, 1.0), self.message)
        for section, controls in CONTROLS.items():
            if imgui.collapsing_header(f"[{section}]"):
                for control in controls:
                    self._widget(ctl, section, control)
        imgui.text_disabled("  ".join(f"{k}: {what}" for k, what in KEYS))
        imgui.end()
        imgui.render()
        return quit_

    def render(self) -> None:
        """Draw the panel built by :meth:`frame` over the window's framebuffer."""
        self.imgui.backends.opengl3_render_draw_data(self.imgui.get_draw_data())

    def close(self) -> None:
        imgui = self.imgui
        imgui.backends.opengl3_shutdown()
        imgui.backends.glfw_shutdown()
        imgui.destroy_context()

    def _overlay(self, ctl: Controller, fps: float) -> None:
        s = ctl.stats()
        self.imgui.text(
            f"{fps:5.1f} fps  frame {s['frame']}  t {s['time']:.2f} s\n"
            f"{s['guides']:,} guides drive {s['hairs']:,} hairs\n"
            f"step {s['step_ms']:.1f} ms  groom {s['groom_ms']:.1f} ms"
            f"  render {s['render_ms']:.1f} ms\n"
            f"stretch max {s['max_stretch']:.2e}  mean {s['mean_stretch']:.2e}\n"
            f"penetration {1000 * s['max_penetration']:.2f} mm"
        )

    def _keys(self, ctl: Controller, fps: float) -> bool:
        imgui = self.imgui
        io = imgui.get_io()
        if not io.want_capture_mouse:  # the mouse is over the picture, not the panel
            if imgui.is_mouse_dragging(imgui.MouseButton_.left):
                dx, dy = io.mouse_delta.x, io.mouse_delta.y
                ctl.orbit(-ORBIT_SPEED * dx, ORBIT_SPEED * dy)
            if io.mouse_wheel:
                ctl.zoom(ZOOM_STEP ** io.mouse_wheel)
        if io.want_capture_keyboard:
            return False
        key = imgui.Key
        if imgui.is_key_pressed(key.space, False):
            ctl.toggle_play()
        if imgui.is_key_pressed(key.s) or imgui.is_key_pressed(key.period):
            ctl.step()
        if imgui.is_key_pressed(key.r, False):
            ctl.reset()
        turn = TURN_SPEED / max(fps, 1.0)
        yaw = imgui.is_key_down(key.left_arrow) - imgui.is_key_down(key.right_arrow)
        pitch = imgui.is_key_down(key.down_arrow) - imgui.is_key_down(key.up_arrow)
        if yaw or pitch:
            ctl.turn_head(yaw * turn, pitch * turn)
        return imgui.is_key_pressed(key.escape, False)

    def _widget(self, ctl: Controller, section: str, c: Control) -> None:
        imgui = self.imgui
        value = ctl.get_param(section, c.key)
        label = f"{c.key}##{section}"
        if c.kind == "choice":
            items = _choices(section, c.key)
            changed, i = imgui.combo(label, items.index(str(value)), items)
            new = items[i]
        elif c.kind == "bool":
            changed, new = imgui.checkbox(label, bool(value))
        elif isinstance(value, (str, dict)):  # a texture-mapped groom property
            imgui.text_disabled(f"{c.key}: {value} (map)")
            return
        elif c.kind == "int":
            changed, new = imgui.slider_int(label, int(value), int(c.lo), int(c.hi))
        elif c.kind == "float":
            fmt = "%.2e" if c.hi < 0.1 else "%.3f"
            changed, new = imgui.slider_float(label, float(value), c.lo, c.hi, fmt)
        elif c.kind == "vec3":
            changed, new = imgui.slider_float3(label, list(value), c.lo, c.hi)
        else:  # colour
            changed, new = imgui.color_edit3(label, list(value), imgui.ColorEditFlags_.float)
        if changed:
            try:
                ctl.set_param(section, c.key, tuple(new) if isinstance(new, list) else new)
                self.message = ""
            except FollicleError as exc:
                self.message = str(exc)
