"""The viewer's state without a window: scene, simulator, groom, camera and renderer,
and the actions the panel and keys trigger, callable from Python (and tests)."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..curves import HairCurves
from ..errors import InputError
from ..pipeline import framed_camera, groom_scene, scene_camera
from ..render import Camera, Renderer, save_png
from ..scene import Scene, load_scene
from ..sim.motion import head_motion, motion_pivot
from ..sim.simulator import Simulator
from .controls import check_key, updated

__all__ = ["Controller"]

REBUILD_SIM = ("vertices", "skin_collision", "skin_voxel", "colliders", "substep")


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
    through an offscreen :class:`~follicle.render.Renderer` of ``size`` pixels.

    Each :meth:`step_frame` advances the simulation by ``1 / fps`` seconds (when
    playing), poses the head (the scene's ``[sim].motion``, repeated, times the manual
    turn of :meth:`turn_head`), grows the displayed hair from the guides and renders it.
    :meth:`set_param` changes a ``[sim]``, ``[groom]`` or ``[render]`` key live.
    """

    def __init__(
        self, scene: Scene | str | os.PathLike[str] | None = None,
        size: Sequence[int] = (960, 540), fps: float = 30.0,
    ) -> None:  # fmt: skip
        if not isinstance(scene, Scene):
            scene = load_scene(scene)
        if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not 0 < fps < math.inf:
            raise InputError(f"fps: expected a finite number > 0, got {fps!r}")
        self.scene = scene
        self.size = (int(size[0]), int(size[1]))
        self.dt = 1.0 / fps
        self.groom = groom_scene(scene)
        self.mesh = self.groom.mesh
        p = scene.sim
        self.pivot = np.asarray(
            p.motion_pivot if p.motion_pivot is not None else motion_pivot(self.mesh), np.float64
        )
        self.sim = Simulator(self.groom.guides, params=p)
        self.playing = True
        self.time = 0.0
        self.frame = 0
        self.yaw = self.pitch = 0.0
        self.curves: HairCurves | None = None  # None: grow again from the guides
        self.image: np.ndarray | None = None  # None: out of date, render again
        self.timings = {"step": 0.0, "groom": 0.0, "render": 0.0, "frame": 0.0}
        self.loop_fps = 0.0  # frames per second of the last :func:`follicle.view` loop
        self.camera = self._frame_camera()
        self._renderer: Renderer | None = None

    # ------------------------------------------------------------------ parameters
    def set_param(self, section: str, key: str, value: object) -> None:
        """Set scene key ``[section].key``: [sim] applies on the next step (keys that
        shape the model, e.g. ``vertices``, restart the simulation), [groom] regrows the
        displayed hair, [render] the next frame. ConfigError names a bad key or value."""
        current = getattr(self.scene, section, None)
        new = updated(section, current, key, value)
        setattr(self.scene, section, new)
        if section == "sim":
            if key in REBUILD_SIM:
                self.sim = Simulator(self.groom.guides, params=new)
                self.reset()
            else:
                self.sim.params = self.sim.solver.params = new
        elif section == "groom":
            self.groom.params = new
            self.curves = self.image = None
        elif key in ("size", "msaa", "background_top", "background_bottom"):
            self.release()  # a new renderer on the next draw
        elif key in ("eye", "target", "fov"):
            self.camera = self._frame_camera()
        self.image = None

    def get_param(self, section: str, key: str) -> object:
        """The current value of ``[section].key``."""
        check_key(section, key)
        return getattr(getattr(self.scene, section), key)

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
        """Time 0, head upright, hair at rest."""
        self.time, self.frame, self.yaw, self.pitch = 0.0, 0, 0.0, 0.0
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
        self.timings["step"] = time.perf_counter() - start
        self.curves = self.image = None

    def hair(self) -> HairCurves:
        """The displayed hair, grown from the simulated guides on the current pose."""
        if self.curves is None:
            start = time.perf_counter()
            self.curves = self.groom.follow(self.sim, time=self.time)
            self.timings["groom"] = time.perf_counter() - start
        return self.curves

    def draw(self) -> np.ndarray:
        """Render the current state: (H, W, 4) uint8, top row first."""
        r = self.scene.render
        curves = self.hair()
        start = time.perf_counter()
        if self._renderer is None:
            background = (r.background_top, r.background_bottom)
            self._renderer = Renderer(size=self.size, msaa=r.msaa, background=background)
        self.image = self._renderer.draw(
            curves if curves.curve_count else None, self.mesh, camera=self.camera,
            lights=r.light_list(), shading=r.shading, subdivisions=r.subdivisions,
            shading_params=r.shading_params, shadows=r.shadows,
        )  # fmt: skip
        self.timings["render"] = time.perf_counter() - start
        return self.image

    def step_frame(self) -> np.ndarray:
        """One frame of the viewer: a step when playing, then the render."""
        start = time.perf_counter()
        if self.playing:
            self.step()
        image = self.draw()
        self.timings["frame"] = time.perf_counter() - start
        return image

    def screenshot(self, path: str | os.PathLike[str]) -> Path:
        """Write the current frame as a PNG (rendered again if anything changed since)."""
        save_png(self.image if self.image is not None else self.draw(), path)
        return Path(path)

    def stats(self) -> dict[str, float]:
        """The overlay's numbers: frame time split, hairs, and the solver's stats."""
        return {
            "frame": self.frame, "time": self.time,
            "hairs": 0 if self.curves is None else self.curves.curve_count,
            "guides": self.sim.model.strands,
            **{f"{k}_ms": 1000.0 * v for k, v in self.timings.items()},
            **self.sim.stats,
        }  # fmt: skip

    def release(self) -> None:
        """Free the renderer (a new one is made on the next draw)."""
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
        eye = target + r * np.array([math.cos(level) * math.sin(azimuth), math.sin(level),
                                     math.cos(level) * math.cos(azimuth)])  # fmt: skip
        self.camera = Camera(eye=eye, target=target, fov_y=c.fov_y)
        self.image = None

    def zoom(self, factor: float) -> None:
        """Move the camera towards its target (``factor`` < 1) or away (> 1)."""
        if isinstance(factor, bool) or not isinstance(factor, (int, float)) or not (
                0 < factor < math.inf):  # fmt: skip
            raise InputError(f"zoom: expected a finite factor > 0, got {factor!r}")
        c = self.camera
        target = np.asarray(c.target, np.float64)
        eye = target + factor * (np.asarray(c.eye, np.float64) - target)
        self.camera = Camera(eye=eye, target=target, up=c.up, fov_y=c.fov_y)
        self.image = None

    def _frame_camera(self) -> Camera:
        """The scene's eye/target, else framed on the head and the reach of the guides."""
        r = self.scene.render
        fixed = scene_camera(r)
        if fixed is not None:
            return fixed
        lo, hi = (np.asarray(b, np.float64) for b in self.mesh.bounds("rest"))
        x = self.sim.positions.reshape(-1, 3)
        lo, hi = np.minimum(lo, x.min(axis=0)), np.maximum(hi, x.max(axis=0))
        return framed_camera(lo, hi, r.fov, self.size[0] / self.size[1])
