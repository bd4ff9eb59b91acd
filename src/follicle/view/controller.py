"""The viewer's state without a window: scene, simulator, groom, camera and renderer,
and the actions the panel and keys trigger, callable from Python (and tests)."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from ..curves import HairCurves
from ..editing.editor import GuideEditor
from ..errors import FollicleError, InputError
from ..groom.brushes import BRUSHES
from ..pipeline import framed_camera, groom_inputs, groom_scene
from ..render import Camera, CpuRenderer, Renderer, default_lights, make_renderer, save_png
from ..render.options import parse_size
from ..render.settings import RenderParams, light_table
from ..render.video import Mp4Writer
from ..scene import Scene, load_scene
from ..sim.motion import head_motion, motion_pivot
from ..sim.simulator import MODEL_KEYS
from ..validate import number, positive, whole
from .controls import check_key
from .gust import Gust, GustySimulator
from .overlay import background, drawable, guide_curves, volume_overlay
from .scenefile import save_scene
from .settling import Settling

__all__ = ["Controller", "Show", "QUALITIES"]

QUALITIES = ("full", "fast")  # fast: no MSAA, no shadows, one Catmull-Rom step per segment
DEFAULT_SCENE_FILE = "follicle_view.toml"  # where the scene is saved when not read from a file
HOLD_LEAST = 0.05  # the least share of the hairs drawn to hold a frame rate


@dataclass
class Show:
    """What the viewer draws: the simulated guides (orange), the displayed hairs, the
    head mesh, and the solver's hair density as a heat overlay."""

    guides: bool = False
    hairs: bool = True
    mesh: bool = True
    volume: bool = False


def _turn(yaw: float, pitch: float, pivot: np.ndarray) -> np.ndarray:
    """Rigid 4×4: ``pitch`` about +x, then ``yaw`` about +y (degrees), about ``pivot``."""
    a, b = math.radians(yaw), math.radians(pitch)
    ry = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    rx = np.array([[1, 0, 0], [0, math.cos(b), -math.sin(b)], [0, math.sin(b), math.cos(b)]])
    out = np.eye(4)
    out[:3, :3] = ry @ rx
    out[:3, 3] = pivot - out[:3, :3] @ pivot
    return out


class Controller:
    """A live simulation of ``scene`` (a Scene, a TOML path or None for the default) seen
    through an offscreen renderer of the scene's engine
    (:func:`~follicle.render.make_renderer`) of ``size`` pixels.

    Each :meth:`step_frame` advances the simulation by ``1 / fps`` seconds (when
    playing), poses the head (the scene's ``[sim].motion``, repeated, times the manual
    turn of :meth:`turn_head`), grows the displayed hair from the guides and renders it.
    :meth:`set_param` changes a ``[sim]``, ``[groom]`` or ``[render]`` key live;
    :meth:`save_scene` writes the scene as edited. ``quality`` "fast" renders with the
    renderer's cheapest settings; ``source`` is the scene file (given a path, that
    path), the default of :meth:`save_scene`. ``hold_fps`` (None or 0: off) holds that
    frame rate by drawing fewer hairs, widened (level of detail, :attr:`lod`).
    """

    def __init__(
        self,
        scene: Scene | str | os.PathLike[str] | None = None,
        size: Sequence[int] = (960, 540),
        fps: float = 30.0,
        quality: str = "full",
        source: str | os.PathLike[str] | None = None,
        hold_fps: float | None = None,
    ) -> None:
        if not isinstance(scene, Scene):
            source = scene if source is None else source
            scene = load_scene(scene)
        fps = positive(fps, "fps")
        hold = positive(hold_fps, "hold_fps", allow_zero=True) if hold_fps is not None else 0.0
        self.hold_fps = hold or None
        self._lod = 1.0
        self.scene = scene
        self.source = None if source is None else Path(source)
        self.size = parse_size(size)
        self.dt = 1.0 / fps
        self.show = Show()
        self.gusts: list[Gust] = []  # the sim's wind bursts, dropped once over
        self._video: Mp4Writer | None = None
        self._hair_limit: int | None = None
        self._renderer: Renderer | CpuRenderer | None = None
        self._fast: tuple[RenderParams, RenderParams] | None = None  # [render], fast's copy
        self._quality = "full"
        self.quality = quality
        self._inputs = groom_inputs(scene)  # the guides settled, as `follicle render` has them
        self._settling: Settling | None = None  # the inputs made again after a change
        self.status = ""  # what goes on in the background, for the panel
        self.groom = groom_scene(scene, self._inputs)
        self.mesh = self.groom.mesh
        p = scene.sim
        self.pivot = motion_pivot(self.mesh, p.motion_pivot)
        self.sim = GustySimulator(self.groom.guides, p, self.gusts)
        self.playing = True
        self.time = 0.0
        self.frame = 0
        self.yaw = self.pitch = 0.0
        self.curves: HairCurves | None = None  # None: grow again from the guides
        self.image: np.ndarray | None = None  # None: out of date, render again
        self.timings = {"step": 0.0, "groom": 0.0, "render": 0.0, "frame": 0.0}
        self.loop_fps = 0.0  # frames per second of the last :func:`follicle.view` loop
        self.camera = self._frame_camera()
        self.brush: str | None = None  # None: dragging orbits the camera
        self.brush_radius = 60.0  # pixels
        self.brush_strength = 0.5
        self._editor: GuideEditor | None = None
        self._stroke: tuple[float, float] | None = None  # the drag's last point
        self._first = True  # the drag's first piece is a new stroke, the rest join it
        self._resume = False  # play again when the stroke ends
        self._preview = False  # hairs grown from the editor's guides at rest
        # the preview's hairs as grown (not widened) and the guides changed since: the
        # next regrowth grows only the hairs on those (Groom.regrow)
        self._grown: tuple[object, HairCurves] | None = None  # (the groom, its hairs)
        self._changed: list[np.ndarray] = []

    # ------------------------------------------------------------------ parameters
    def set_param(self, section: str, key: str, value: object) -> None:
        """Set scene key ``[section].key``: [sim] applies on the next step (keys that
        shape the model, e.g. ``vertices``, restart the simulation), [groom] regrows the
        displayed hair, [render] the next frame. ConfigError names a bad key or value.

        A change of a key the groom's inputs come from — with ``[groom].settle`` > 0 the
        settle seconds and the [sim] dynamics that settle the guides, and the density
        and groups — reads and settles them again in the background
        (:mod:`~follicle.view.settling`, as ``follicle render`` would for the scene now):
        meanwhile :attr:`status` says so and the pose before stays; once done the
        groom and the simulation rest on the new guides (hand strokes replayed on
        them), from time 0, on the next :meth:`step_frame` (:meth:`wait_settled`
        waits for it)."""
        check_key(section, key)
        new = getattr(self.scene, section).replace("viewer", **{key: value})
        self.scene = self.scene.replace(**{section: new})
        if section == "sim":
            self.sim.params = new  # the simulator rebuilds what the change needs
            if key in MODEL_KEYS:  # the hair is back at rest: so is the rest of the show
                self.reset()
        elif section == "groom":
            self.groom.params = new
            self.curves = self.image = None
        elif key in ("size", "msaa", "background_top", "background_bottom", "shadow_size"):
            self._drop_renderer()  # a new renderer on the next draw
        elif key in ("eye", "target", "fov"):
            self.camera = self._frame_camera()
        self.image = None
        if section != "render":
            self._resettle()

    # ------------------------------------------------------------------ settling
    def _resettle(self) -> None:
        """Start making the groom's inputs again when the scene's keys no longer give
        those in use (a job under way for an older scene is dropped)."""
        if self._settling is not None:
            self._settling.cancel()
            self._settling = None
        if self._inputs.made_for(self.scene):
            self.status = ""
            return
        self._settling = Settling(self.scene, self._inputs, self._strokes())
        self._status(self._settling)

    def _status(self, job: Settling) -> None:
        seconds = self.scene.groom.settle
        what = f"settling the guides ({seconds:g} s)" if seconds > 0 else "reading the guides"
        self.status = f"{what}: {100 * job.share:.0f} %; the pose before is shown until then"

    def _strokes(self) -> list[dict[str, object]]:
        return [] if self._editor is None else self._editor.log

    @property
    def settling(self) -> bool:
        """Whether the groom's inputs are being made again (:meth:`set_param`)."""
        return self._settling is not None

    def wait_settled(self, timeout: float | None = None) -> bool:
        """Wait (at most ``timeout`` s) until the groom rests on the inputs of the scene
        as it is now (:meth:`set_param`); whether it does."""
        while self._settling is not None:
            if not self._settling.join(timeout):
                return False
            self._poll()
        return True

    def _poll(self) -> None:
        """Take the background job's inputs once it has finished (not in the middle of
        a stroke): the groom, the simulation and the editor rest on them, from time 0.
        A job whose strokes are not the editor's now is run again."""
        job = self._settling
        if job is None or self._stroke is not None:
            return
        if not job.finished:
            self._status(job)
            return
        self._settling = None
        try:
            result = job.result()
        except FollicleError as exc:
            self.status = f"the guides were not settled again: {exc}"
            return
        if result is None:
            return
        if job.log != self._strokes():  # strokes made meanwhile: replay them too
            self._resettle()
            return
        inputs, editor = result
        groom = groom_scene(self.scene, inputs)
        self._inputs, self._editor = inputs, editor
        self.groom = groom if editor is None else groom.with_guides(editor.guides)
        self.sim = GustySimulator(self.groom.guides, self.scene.sim, self.gusts)
        self._preview, self._grown, self._changed = False, None, []
        self.status = ""
        self.reset()

    def get_param(self, section: str, key: str) -> object:
        """The current value of ``[section].key``."""
        check_key(section, key)
        return getattr(getattr(self.scene, section), key)

    def lights(self) -> list[dict[str, object]]:
        """The ``[[render.lights]]`` as tables; the default rig's when the scene has none."""
        r = self.scene.render
        if r.lights:
            return [light.model_dump() for light in r.lights]
        return [light_table(light) for light in default_lights()]

    def set_light(self, index: int, key: str, value: object) -> None:
        """Set ``key`` (intensity, color, direction, ...) of light ``index`` of
        :meth:`lights`; the first change to the default rig makes it the scene's
        ``[[render.lights]]``. ConfigError names a bad key or value."""
        tables = self.lights()
        index = whole(index, "light", 0, len(tables) - 1)
        tables[index] = {**tables[index], key: value}
        self.set_param("render", "lights", tables)

    def save_scene(self, path: str | os.PathLike[str] | None = None) -> Path:
        """Write the scene as edited to the TOML file ``path`` (default: :attr:`source`,
        else ``follicle_view.toml``), atomically, its file paths relative to the new
        file's folder; :func:`~follicle.scene.load_scene` reads it back to this scene.
        Viewer-only state (gusts, what is shown, the hair limit, quality) is not saved."""
        default = self.source if self.source is not None else Path(DEFAULT_SCENE_FILE)
        return save_scene(self.scene, default if path is None else path)

    # ------------------------------------------------------------------ view settings
    def set_show(self, name: str, value: bool) -> None:
        """Show or hide ``name``: guides, hairs, mesh or volume (:class:`Show`)."""
        names = [f.name for f in fields(Show)]
        if name not in names:
            raise InputError(f"show: unknown layer {name!r}; use one of {', '.join(names)}")
        if not isinstance(value, bool):
            raise InputError(f"show.{name}: expected true or false, got {value!r}")
        setattr(self.show, name, value)
        self.image = None

    @property
    def hair_limit(self) -> int | None:
        """Grow and draw only the first N hairs of the groom (None: all [groom].count)."""
        return self._hair_limit

    @hair_limit.setter
    def hair_limit(self, limit: int | None) -> None:
        self._hair_limit = whole(limit, "hair_limit", 0, allow_none=True)
        self.curves = self.image = None

    @property
    def quality(self) -> str:
        """ "full": the scene's [render] settings; "fast": no MSAA, no shadows and one
        Catmull-Rom step per segment, the renderer's cheapest settings, for speed."""
        return self._quality

    @quality.setter
    def quality(self, quality: str) -> None:
        if quality not in QUALITIES:
            raise InputError(f"quality: expected one of {', '.join(QUALITIES)}, got {quality!r}")
        if quality != self._quality:
            self._drop_renderer()  # MSAA is the renderer's own
        self._quality = quality
        self.image = None

    def resize(self, width: int, height: int) -> None:
        """Render at ``width`` × ``height`` pixels from the next draw (a window resized):
        the camera keeps its direction and moves as the automatic framing does for the
        new aspect. An unfinished recording is finished first (a video has one size)."""
        size = parse_size((width, height))
        if size == self.size:
            return
        if self._video is not None:
            self.stop_recording()
        before = self._frame_camera()
        self.size = size
        self._drop_renderer()
        self.zoom(self._frame_camera().distance / before.distance)

    # ------------------------------------------------------------------ actions
    def toggle_play(self) -> None:
        """Play ⇄ pause."""
        self.playing = not self.playing

    def turn_head(self, yaw: float = 0.0, pitch: float = 0.0) -> None:
        """Turn the head by ``yaw`` (about +y) and ``pitch`` (about +x) degrees, on top of
        the built-in motion; it moves there over the next step."""
        self.yaw = (self.yaw + yaw + 180.0) % 360.0 - 180.0
        self.pitch = min(max(self.pitch + pitch, -60.0), 60.0)

    def reset(self) -> None:
        """Time 0, head upright, hair at rest, no gusts."""
        self.time, self.frame, self.yaw, self.pitch = 0.0, 0, 0.0, 0.0
        self.gusts.clear()
        self.sim.set_pose(transform=np.eye(4))
        self.sim.reset()
        self.curves = self.image = None

    def head_transform(self, t: float) -> np.ndarray:
        """World-from-rest transform of the head at time ``t``: the built-in motion
        (played, then held as long again, repeated) and the manual turn."""
        p = self.scene.sim
        cycle = math.fmod(t, 2.0 * p.motion_period)
        motion = head_motion(p.motion, cycle, p.motion_amplitude, p.motion_period, self.pivot)
        return _turn(self.yaw, self.pitch, self.pivot) @ motion

    def step(self) -> None:
        """Advance the simulation one frame (1 / fps s), playing or not."""
        start = time.perf_counter()
        self.time += self.dt
        self.frame += 1
        self.sim.set_pose(transform=self.head_transform(self.time))
        self.sim.step(self.dt)
        now = self.sim.state.time
        self.gusts[:] = [g for g in self.gusts if not g.over(now)]
        self.timings["step"] = time.perf_counter() - start
        self.curves = self.image = None

    def gust(self, strength: float = 10.0, duration: float = 1.0) -> None:
        """A burst of wind from now: ``strength`` m/s² at its peak (like [sim].wind), along
        the [sim] wind, or the camera's view when there is none; it rises and falls
        smoothly over ``duration`` s of simulated time, on top of the [sim] wind, whose
        parameters stay as they are."""
        strength, duration = positive(strength, "strength"), positive(duration, "duration")
        wind = np.asarray(self.scene.sim.wind, np.float64)
        along = wind if wind.any() else self.camera.basis()[2]
        vector = strength * along / np.linalg.norm(along)
        self.gusts.append(Gust(self.sim.state.time, duration, vector))

    def hair(self) -> HairCurves:
        """The displayed hair, grown from the simulated guides on the current pose: the
        first :attr:`hair_limit` hairs when set, and of those the first :attr:`lod`
        share, widened by the share left out so they cover what all of them would (each
        hair's root comes from its own random stream, so the first hairs are an even,
        nested subset: the level of detail Unreal's and TressFX's strand LOD draw)."""
        if self.curves is None:
            start = time.perf_counter()
            count = self.scene.groom.count
            count = count if self._hair_limit is None else min(count, self._hair_limit)
            drawn = self._drawn(count)
            if self._preview:  # a stroke going on: the edited guides at rest
                curves = self._regrown(drawn)
            else:
                curves = self.groom.follow(self.sim, count=drawn, time=self.time)
            if drawn < count and "width" in curves.point_data:
                data = dict(curves.point_data, width=curves.point_data["width"] * (count / drawn))
                curves = HairCurves(curves.points, curves.offsets, data, curves.curve_data)
            self.curves = curves
            self.timings["groom"] = time.perf_counter() - start
        return self.curves

    def _regrown(self, drawn: int) -> HairCurves:
        """The first ``drawn`` hairs from the edited guides at rest: only those on the
        guides changed since the last time regrown, when the same hairs were grown."""
        groom, points = self.groom, self.editor.points
        grown = self._grown[1] if self._grown and self._grown[0] is groom else None
        if grown is not None and int(grown.curve_data["hair_id"][-1]) == drawn - 1:
            changed: np.ndarray | list[int] = np.concatenate(self._changed) if self._changed else []
            curves = groom.regrow(grown, points, changed)  # nothing changed: grown itself
        else:  # the first piece of a drag, or another groom or share of the hairs
            curves = groom.follow(points, count=drawn)
        self._grown, self._changed = (groom, curves), []
        return curves

    # ------------------------------------------------------------ grooming by hand
    @property
    def editor(self) -> GuideEditor:
        """The :class:`~follicle.GuideEditor` the brushes work through (made from the
        groom's guides on first use)."""
        if self._editor is None:
            self._editor = GuideEditor(self.groom.guides)
        return self._editor

    def set_brush(
        self, brush: str | None, radius: float | None = None, strength: float | None = None
    ) -> None:
        """Choose the brush a left drag applies (None: the drag orbits the camera), and
        optionally its radius (pixels) and strength."""
        if brush is not None and brush not in BRUSHES:
            raise InputError(f"brush: {brush!r} is not one of {list(BRUSHES)} or None")
        self.brush = brush
        if radius is not None:
            self.brush_radius = positive(radius, "brush radius", unit="px")
        if strength is not None:
            self.brush_strength = number(strength, "brush strength", lo=-1.0, hi=1.0)

    def begin_stroke(self, x: float, y: float) -> None:
        """A drag with the brush starts at pixel (x, y): the show pauses and goes back to
        the rest pose, where guides are edited."""
        if self.brush is None:
            raise InputError("begin_stroke: choose a brush first (set_brush)")
        if self._stroke is None:
            self._resume, self.playing = self.playing, False
            self.reset()
        self._stroke = (float(x), float(y))
        self._first = True

    def drag_stroke(self, x: float, y: float) -> np.ndarray:
        """The drag moves on to (x, y): the brush applied from the last point (one undo
        step for the whole drag), the hairs regrown from the edited guides. Returns the
        guides changed."""
        if self._stroke is None:
            raise InputError("drag_stroke: no stroke begun (begin_stroke)")
        if self.brush is None:
            raise InputError("drag_stroke: choose a brush first (set_brush)")
        path = [self._stroke, (float(x), float(y))]
        strength = self.brush_strength
        if self.brush != "length":
            strength = min(max(strength, 0.0), 1.0)
        ed = self.editor
        count, groups, attributes = len(ed.points), ed.groups, ed.attributes
        changed = ed.stroke(
            self.brush, path, self.camera, self.brush_radius, strength, self.size,
            join=not self._first,
        )  # fmt: skip
        self._stroke, self._first = path[1], False
        if len(changed):
            inherits = self.groom.params.inherit and ed.attributes is not attributes
            if len(ed.points) != count or ed.groups is not groups or inherits:
                # new roots or groups, or the hairs' inherited values cut or lengthened
                self.groom = self.groom.with_guides(ed.guides)
                self._grown = None  # other guides: every hair grows again
            self._changed.append(changed)
            self._preview = True
            self.curves = self.image = None
        return changed

    def end_stroke(self) -> None:
        """The drag ends: the groom and the simulation take the edited guides as their
        rest shape, and the show plays again if it was playing."""
        if self._stroke is None:
            return
        self._stroke = None
        if self._preview:
            self._adopt()
        self.playing = self._resume

    def undo_groom(self) -> bool:
        """Take back the last brush stroke; False when there is none."""
        done = self.editor.undo()
        if done:
            self._adopt()
        return done

    def redo_groom(self) -> bool:
        """Apply again the last brush stroke taken back; False when there is none."""
        done = self.editor.redo()
        if done:
            self._adopt()
        return done

    def save_guides(self, path: str | os.PathLike[str]) -> Path:
        """Write the edited guides (any curves format) and, beside a part's groups,
        nothing else: :meth:`follicle.GuideEditor.save`."""
        return self.editor.save(path)

    def _adopt(self) -> None:
        """The editor's guides become the groom's and the simulation's rest shape."""
        self.groom = self.groom.with_guides(self.editor.guides)
        self.sim = GustySimulator(self.groom.guides, self.scene.sim, self.gusts)
        self._preview, self._grown, self._changed = False, None, []
        self.reset()

    def _drawn(self, count: int) -> int:
        """How many of ``count`` hairs :attr:`lod` draws."""
        return count if self._lod >= 1.0 else max(1, min(count, round(count * self._lod)))

    @property
    def lod(self) -> float:
        """The share of the hairs drawn to hold :attr:`hold_fps` (1: all of them)."""
        return self._lod

    def drawn_curves(self) -> HairCurves | None:
        """The curves drawn, as :attr:`show` says: the hairs, the guides (wide, orange),
        both, or None."""
        parts = [self.hair()] if self.show.hairs and self.hair().curve_count else []
        if self.show.guides:
            guides = self.editor.points if self._preview else self.sim.positions
            parts.append(guide_curves(guides))
        if len(parts) == 2:
            return HairCurves.concatenate([drawable(part) for part in parts])
        return parts[0] if parts else None

    def draw(self) -> np.ndarray:
        """Render the current state: (H, W, 4) uint8, top row first."""
        r = self.scene.render
        curves = self.drawn_curves()
        mesh = self.sim.pose if self.show.mesh else None  # the skin where the roots are
        start = time.perf_counter()
        if curves is None and mesh is None:
            image = background(self.size, r.background_top, r.background_bottom)
        else:
            image = self._render(curves, mesh)
        if self.show.volume:
            image = volume_overlay(image, self.sim.positions, self.camera, self.scene.sim)
        self.image = image
        self.timings["render"] = time.perf_counter() - start
        return image

    def _render(self, curves: HairCurves | None, mesh: object | None) -> np.ndarray:
        """The renderer's picture, with the [render] settings or :attr:`quality` fast's."""
        settings = self._settings()
        if self._renderer is None:
            self._renderer = make_renderer(settings.replace("viewer", size=self.size))
        return self._renderer.draw(curves, mesh, camera=self.camera, settings=settings)

    def _settings(self) -> RenderParams:
        """The scene's [render] settings, or with :attr:`quality` fast the cheapest ones."""
        r = self.scene.render
        if self._quality != "fast":
            return r
        if self._fast is None or self._fast[0] is not r:  # made again when [render] changes
            self._fast = (r, r.replace("viewer", msaa=0, shadows=False, subdivisions=1))
        return self._fast[1]

    def step_frame(self) -> np.ndarray:
        """One frame of the viewer: a step when playing, then the render, recorded when
        :meth:`start_recording` is on."""
        start = time.perf_counter()
        self._poll()
        if self.playing:
            self.step()
        image = self.draw()
        if self._video is not None:
            try:
                self._video.write(image)
            except FollicleError:
                self._video = None  # the writer has dropped its file
                raise
        self.timings["frame"] = time.perf_counter() - start
        self._hold(self.timings["frame"])
        return image

    def _hold(self, seconds: float) -> None:
        """Level of detail for :attr:`hold_fps`: a frame over its budget draws fewer hairs
        next time (in proportion, at most halving, never below :data:`HOLD_LEAST`); one
        well under it, 10 % more, up to all of them. The hairs drawn are the first ones
        (:meth:`hair`), so they are nested: hairs come and go at the margin, none pop,
        and the ones left out are not grown at all."""
        if self.hold_fps is None or seconds <= 0.0:
            return
        budget = 1.0 / self.hold_fps
        before = self._lod
        if seconds > budget:
            self._lod = max(HOLD_LEAST, self._lod * max(0.5, budget / seconds))
        elif seconds < 0.8 * budget and self._lod < 1.0:
            self._lod = min(1.0, self._lod * 1.1)
        if self._lod != before:
            self.curves = self.image = None  # grown again at the new share

    # ------------------------------------------------------------------ recording
    def start_recording(self, path: str | os.PathLike[str]) -> None:
        """Record every frame :meth:`step_frame` renders from now into the H.264 MP4
        ``path``, at the simulated frame rate, until :meth:`stop_recording`."""
        if self._video is not None:
            raise InputError(f"already recording to {self._video.path}; stop that first")
        self._video = Mp4Writer(path, 1.0 / self.dt)

    def stop_recording(self) -> Path:
        """Finish the recording and return its path. InputError when none is on, or it
        has no frames (then nothing is left at the path)."""
        video, self._video = self._video, None
        if video is None:
            raise InputError("not recording: start_recording(path) first")
        return video.close()

    @property
    def recording(self) -> int | None:
        """Frames recorded so far; None when not recording."""
        return None if self._video is None else self._video.frames

    def screenshot(self, path: str | os.PathLike[str]) -> Path:
        """Write the current frame as a PNG (rendered again if anything changed since)."""
        save_png(self.image if self.image is not None else self.draw(), path)
        return Path(path)

    def stats(self) -> dict[str, float]:
        """The overlay's numbers: frame time split, hairs, and the solver's stats."""
        return {
            "frame": self.frame,
            "time": self.time,
            "hairs": 0 if self.curves is None else self.curves.curve_count,
            "lod": self._lod,
            "guides": self.sim.model.strands,
            **{f"{k}_ms": 1000.0 * v for k, v in self.timings.items()},
            **self.sim.stats,
        }

    def release(self) -> None:
        """Free the renderer (a new one is made on the next draw) and drop an unfinished
        recording (its file removed) and a settle going on: the end of a viewer session."""
        if self._settling is not None:
            self._settling.cancel()
            self._settling = None
        if self._video is not None:
            self._video.abort()
            self._video = None
        self._drop_renderer()

    def _drop_renderer(self) -> None:
        if self._renderer is not None:
            self._renderer.release()
            self._renderer = None

    # ------------------------------------------------------------------ camera
    def orbit(self, yaw: float = 0.0, pitch: float = 0.0) -> None:
        """Swing the camera about its target: ``yaw`` degrees about +y, ``pitch`` up
        (kept within 85° of level, so the view never flips over the pole)."""
        c = self.camera
        target = np.asarray(c.target, np.float64)
        offset = np.asarray(c.eye, np.float64) - target
        r = float(np.linalg.norm(offset))
        azimuth = math.atan2(offset[0], offset[2]) + math.radians(yaw)
        level = math.asin(min(max(offset[1] / r, -1.0), 1.0)) + math.radians(pitch)
        level = min(max(level, -math.radians(85.0)), math.radians(85.0))
        eye = target + r * np.array(
            [
                math.cos(level) * math.sin(azimuth),
                math.sin(level),
                math.cos(level) * math.cos(azimuth),
            ]
        )
        self.camera = Camera(eye=eye, target=target, fov_y=c.fov_y)
        self.image = None

    def zoom(self, factor: float) -> None:
        """Move the camera towards its target (``factor`` < 1) or away (> 1)."""
        factor = positive(factor, "zoom")
        c = self.camera
        target = np.asarray(c.target, np.float64)
        eye = target + factor * (np.asarray(c.eye, np.float64) - target)
        self.camera = Camera(eye=eye, target=target, up=c.up, fov_y=c.fov_y)
        self.image = None

    def _frame_camera(self) -> Camera:
        """The scene's eye/target, else framed on the head and the reach of the guides."""
        r = self.scene.render
        fixed = r.camera()
        if fixed is not None:
            return fixed
        skin = self.mesh.used_vertices("rest")
        x = self.sim.positions.reshape(-1, 3).astype(np.float64)
        return framed_camera(np.concatenate([skin, x]), r.fov, self.size[0] / self.size[1])
