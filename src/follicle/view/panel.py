"""The ImGui parameter panel and keys: a thin layer that reads the Controller and calls
its actions; everything it does is reachable from Python without it."""

from __future__ import annotations

import typing
from collections.abc import Callable, Iterable
from dataclasses import fields
from typing import TYPE_CHECKING, SupportsFloat, SupportsInt

from ..errors import FollicleError
from ..groom.brushes import BRUSHES
from .controller import DEFAULT_SCENE_FILE, QUALITIES, Controller, Show
from .controls import CONTROLS, SECTIONS, Control

if TYPE_CHECKING:
    from .window import Window

__all__ = ["Panel", "KEYS"]

KEYS = (
    ("space", "play / pause"),
    ("S or .", "one step"),
    ("R", "reset"),
    ("G", "gust"),
    ("V", "record / stop"),
    ("arrows", "turn / nod the head"),
    ("drag", "orbit the camera, or brush"),
    ("wheel", "zoom; Ctrl: brush radius; Shift: strength"),
    ("1-8 / 0", "a brush / orbit"),
    ("Ctrl+Z / Ctrl+Y", "undo / redo a stroke"),
    ("Esc", "quit"),
)
TURN_SPEED = 90.0  # degrees per second while an arrow key is held
ORBIT_SPEED = 0.3  # degrees per pixel dragged
ZOOM_STEP = 0.9  # distance factor per wheel notch
DEFAULT_VIDEO_FILE = "follicle_view.mp4"
DEFAULT_GUIDES_FILE = "follicle_guides.npz"
RADIUS_STEP = 1.1  # brush radius factor per Ctrl + wheel notch
STRENGTH_STEP = 0.05  # brush strength per Shift + wheel notch


def _int(value: object) -> int:
    if not isinstance(value, SupportsInt):
        raise TypeError(f"expected a whole number, got {value!r}")
    return int(value)


def _float(value: object) -> float:
    if not isinstance(value, SupportsFloat):
        raise TypeError(f"expected a number, got {value!r}")
    return float(value)


def _list(value: object) -> list[float]:
    """A vector or colour setting as the list an ImGui widget edits."""
    if not isinstance(value, Iterable):
        raise TypeError(f"expected numbers, got {value!r}")
    return list(value)


def _choices(section: str, key: str) -> list[str]:
    return [str(v) for v in typing.get_args(SECTIONS[section].model_fields[key].annotation)]


class Panel:
    """ImGui on ``window`` (a :class:`~follicle.view.window.Window`), drawn each frame."""

    def __init__(self, window: Window, ctl: Controller) -> None:
        from imgui_bundle import imgui

        self.imgui = imgui
        imgui.create_context()
        imgui.get_io().set_ini_filename("")  # no imgui.ini beside the user's files
        imgui.backends.glfw_init_for_opengl(window.address, True)
        imgui.backends.opengl3_init("#version 330")
        self.message = ""  # the last action's error, in red
        self.note = ""  # the last file written
        self.scene_path = str(ctl.source if ctl.source is not None else DEFAULT_SCENE_FILE)
        self.video_path = DEFAULT_VIDEO_FILE
        self.guides_path = DEFAULT_GUIDES_FILE
        self._last_mouse: tuple[float, float] | None = None

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
        imgui.same_line()
        if imgui.button("gust"):
            self._act(ctl.gust)
        if self.message:
            imgui.text_colored((1.0, 0.4, 0.3, 1.0), self.message)
        if ctl.status:  # a settle going on in the background
            imgui.text_colored((1.0, 0.8, 0.3, 1.0), ctl.status)
        if self.note:
            imgui.text_disabled(self.note)
        self._files(ctl)
        if imgui.collapsing_header("view"):
            self._view(ctl)
        if imgui.collapsing_header("groom by hand"):
            self._brushes(ctl)
        for section, controls in CONTROLS.items():
            if imgui.collapsing_header(f"[{section}]"):
                for control in controls:
                    self._widget(ctl, section, control)
        if imgui.collapsing_header("[[render.lights]]"):
            self._lights(ctl)
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
            self._mouse(ctl)
        elif ctl.brush is not None and not imgui.is_mouse_down(imgui.MouseButton_.left):
            self._act(ctl.end_stroke)
        if io.want_capture_keyboard:
            return False
        key = imgui.Key
        ctrl = io.key_ctrl
        if ctrl and imgui.is_key_pressed(key.z, False):
            self._act(ctl.redo_groom if io.key_shift else ctl.undo_groom)
        if ctrl and imgui.is_key_pressed(key.y, False):
            self._act(ctl.redo_groom)
        for n, name in enumerate((None, *BRUSHES)):
            if not ctrl and imgui.is_key_pressed(getattr(key, f"_{n}"), False):
                ctl.set_brush(name)
        if imgui.is_key_pressed(key.space, False):
            ctl.toggle_play()
        if imgui.is_key_pressed(key.s) or imgui.is_key_pressed(key.period):
            ctl.step()
        if imgui.is_key_pressed(key.r, False):
            ctl.reset()
        if imgui.is_key_pressed(key.g, False):
            self._act(ctl.gust)
        if imgui.is_key_pressed(key.v, False):
            self._act(self._toggle_recording, ctl)
        turn = TURN_SPEED / max(fps, 1.0)
        yaw = imgui.is_key_down(key.left_arrow) - imgui.is_key_down(key.right_arrow)
        pitch = imgui.is_key_down(key.down_arrow) - imgui.is_key_down(key.up_arrow)
        if yaw or pitch:
            ctl.turn_head(yaw * turn, pitch * turn)
        return imgui.is_key_pressed(key.escape, False)

    def _mouse(self, ctl: Controller) -> None:
        """Over the picture: a left drag brushes (a brush chosen) or orbits, the wheel
        zooms, or with Ctrl sizes the brush and with Shift sets its strength; a brush
        shows as a circle of its radius."""
        imgui = self.imgui
        io = imgui.get_io()
        left = imgui.MouseButton_.left
        scale = io.display_framebuffer_scale.x or 1.0  # window points → render pixels
        x, y = io.mouse_pos.x * scale, io.mouse_pos.y * scale
        if ctl.brush is None:
            if imgui.is_mouse_dragging(left):
                ctl.orbit(-ORBIT_SPEED * io.mouse_delta.x, ORBIT_SPEED * io.mouse_delta.y)
        else:
            if imgui.is_mouse_clicked(left):
                self._act(ctl.begin_stroke, x, y)
                self._last_mouse = (x, y)
            elif imgui.is_mouse_down(left) and self._last_mouse not in (None, (x, y)):
                self._act(ctl.drag_stroke, x, y)
                self._last_mouse = (x, y)
            elif imgui.is_mouse_released(left):
                self._act(ctl.end_stroke)
                self._last_mouse = None
            colour = imgui.get_color_u32((1.0, 0.75, 0.3, 0.9))
            centre = imgui.ImVec2(io.mouse_pos.x, io.mouse_pos.y)
            imgui.get_foreground_draw_list().add_circle(centre, ctl.brush_radius / scale, colour)
        if io.mouse_wheel:
            if io.key_ctrl:
                ctl.set_brush(ctl.brush, radius=ctl.brush_radius * RADIUS_STEP**io.mouse_wheel)
            elif io.key_shift:
                step = STRENGTH_STEP * io.mouse_wheel
                ctl.set_brush(ctl.brush, strength=min(max(ctl.brush_strength + step, -1.0), 1.0))
            else:
                ctl.zoom(ZOOM_STEP**io.mouse_wheel)

    def _brushes(self, ctl: Controller) -> None:
        """The brush palette, its radius and strength, undo / redo, saving the guides."""
        imgui = self.imgui
        names = ["orbit", *BRUSHES]
        current = 0 if ctl.brush is None else names.index(ctl.brush)
        for i, name in enumerate(names):
            if i % 5:
                imgui.same_line()
            if imgui.radio_button(f"{i} {name}", current == i):
                ctl.set_brush(None if i == 0 else name)
        changed, radius = imgui.slider_float("radius (px)", ctl.brush_radius, 2.0, 400.0)
        if changed:
            self._act(ctl.set_brush, ctl.brush, radius)
        changed, strength = imgui.slider_float("strength", ctl.brush_strength, -1.0, 1.0)
        if changed:
            self._act(ctl.set_brush, ctl.brush, None, strength)
        if imgui.button("undo"):
            self._act(ctl.undo_groom)
        imgui.same_line()
        if imgui.button("redo"):
            self._act(ctl.redo_groom)
        _, self.guides_path = imgui.input_text("##guides path", self.guides_path)
        imgui.same_line()
        if imgui.button("save guides"):
            self._act(self._save_guides, ctl)

    def _save_guides(self, ctl: Controller) -> None:
        self.note = f"saved {ctl.save_guides(self.guides_path)}"

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
            changed, new = imgui.slider_int(label, _int(value), int(c.lo), int(c.hi))
        elif c.kind == "float":
            fmt = "%.2e" if c.hi < 0.1 else "%.3f"
            changed, new = imgui.slider_float(label, _float(value), c.lo, c.hi, fmt)
        elif c.kind == "vec3":
            changed, new = imgui.slider_float3(label, _list(value), c.lo, c.hi)
        else:  # colour
            changed, new = imgui.color_edit3(label, _list(value), imgui.ColorEditFlags_.float)
        if changed:
            self._act(ctl.set_param, section, c.key, tuple(new) if isinstance(new, list) else new)

    def _act(self, action: Callable[..., object], *args: object) -> None:
        """Run a Controller action; its error (a bad value, an unwritable file) shows in
        the panel instead of ending the viewer."""
        try:
            action(*args)
            self.message = ""
        except (FollicleError, OSError) as exc:
            self.message = str(exc)

    def _toggle_recording(self, ctl: Controller) -> None:
        if ctl.recording is None:
            ctl.start_recording(self.video_path)
        else:
            self.note = f"recorded {ctl.stop_recording()}"

    def _save(self, ctl: Controller) -> None:
        self.note = f"saved {ctl.save_scene(self.scene_path)}"

    def _files(self, ctl: Controller) -> None:
        """The scene file to save to and the clip to record, each with its button."""
        imgui = self.imgui
        _, self.scene_path = imgui.input_text("##scene path", self.scene_path)
        imgui.same_line()
        if imgui.button("save scene"):
            self._act(self._save, ctl)
        _, self.video_path = imgui.input_text("##video path", self.video_path)
        imgui.same_line()
        frames = ctl.recording
        if imgui.button("record" if frames is None else f"stop ({frames} frames)"):
            self._act(self._toggle_recording, ctl)

    def _view(self, ctl: Controller) -> None:
        """What is shown, the displayed-hair limit and the render quality."""
        imgui = self.imgui
        for i, f in enumerate(fields(Show)):
            if i:
                imgui.same_line()
            changed, on = imgui.checkbox(f.name, getattr(ctl.show, f.name))
            if changed:
                ctl.set_show(f.name, on)
        count = ctl.scene.groom.count
        limit = count if ctl.hair_limit is None else min(ctl.hair_limit, count)
        changed, limit = imgui.slider_int("hair limit", limit, 0, count)
        if changed:
            ctl.hair_limit = None if limit >= count else limit
        changed, i = imgui.combo("quality", QUALITIES.index(ctl.quality), list(QUALITIES))
        if changed:
            ctl.quality = QUALITIES[i]

    def _lights(self, ctl: Controller) -> None:
        """Intensity, colour and (directional) direction of each light."""
        imgui = self.imgui
        for i, light in enumerate(ctl.lights()):
            imgui.text(f"light {i}: {light['type']}, {light['space']} space")
            changed, v = imgui.slider_float(f"intensity##light{i}", light["intensity"], 0.0, 5.0)
            if changed:
                self._act(ctl.set_light, i, "intensity", v)
            changed, v = imgui.color_edit3(
                f"colour##light{i}", _list(light["color"]), imgui.ColorEditFlags_.float
            )
            if changed:
                self._act(ctl.set_light, i, "color", tuple(v))
            if light["type"] == "directional":
                changed, v = imgui.slider_float3(
                    f"direction##light{i}", _list(light["direction"]), -1.0, 1.0
                )
                if changed:
                    self._act(ctl.set_light, i, "direction", tuple(v))
