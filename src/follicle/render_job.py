"""``follicle render``'s work as a library call: a scene (its hair grown on the fly) or a
saved curves file drawn to a PNG, or the frames of a simulation cache drawn to a PNG
sequence or an MP4, here or on a Dask cluster.

:func:`plan_render` checks everything a run needs before any hair is grown or drawn
(the source's kind, the options that apply to it and to the engine, the outputs'
names, that no output replaces an input) and says where the run will write;
:meth:`RenderJob.run` does the work. The command calls the two and prints the result;
Python calls them the same way::

    job = plan_render("scene.toml", "hair.png", engine="cpu")
    done = job.run()
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from .errors import InputError
from .progress import Stage, quietly
from .validate import check_suffix, whole

if TYPE_CHECKING:
    from .io.sim_cache import SimCache
    from .mesh.skin import SkinMesh
    from .render.backends import Engine
    from .scene import Scene

__all__ = ["plan_render", "RenderJob", "Rendered"]

SourceKind = Literal["scene", "curves", "cache"]


@dataclass(frozen=True)
class Rendered:
    """What :meth:`RenderJob.run` wrote: ``paths`` (the PNG, the MP4, or a cache's
    frames in order), the cache ``frames`` drawn (None for a still), the ``hairs`` a
    frame holds (a cache's, as grown from it), the image ``size`` and the wall
    ``seconds``."""

    paths: tuple[Path, ...]
    frames: range | None
    hairs: int | None
    size: tuple[int, int]
    seconds: float


@dataclass(frozen=True)
class RenderJob:
    """A checked render of ``source`` (a ``kind`` of input) to ``target``: a PNG, or for
    a cache a folder of PNGs or an .mp4. Made by :func:`plan_render`."""

    source: str
    kind: SourceKind
    target: Path
    scene: Scene
    engine: Engine
    mesh: str | None = None
    cache: SimCache | None = None
    frames: range | None = None
    scheduler: str | None = None
    frames_per_task: int | None = None

    @property
    def video(self) -> bool:
        """True when a cache is encoded as an MP4 rather than written as PNGs."""
        return self.kind == "cache" and self.target.suffix.lower() == ".mp4"

    @property
    def outputs(self) -> list[Path]:
        """The files the run writes (a cache's frames, one by one), known before it."""
        if self.kind != "cache" or self.video:
            return [self.target]
        from .pipeline import frame_name

        assert self.cache is not None and self.frames is not None
        return [self.target / frame_name(self.cache, f) for f in self.frames]

    def run(self, stage: Stage = quietly) -> Rendered:
        """Render: grow the scene's hair (``stage("growing hair")``) or read the curves,
        then draw (``stage("rendering")``, or ``"path tracing (%)"`` for an engine
        that samples); a cache's frames under ``stage("rendering frames")``."""
        start = time.perf_counter()
        paths = self._frames(stage) if self.kind == "cache" else self._still(stage)
        seconds = time.perf_counter() - start
        hairs = self.scene.groom.count if self.kind == "cache" else None
        return Rendered(tuple(paths), self.frames, hairs, self.scene.render.size, seconds)

    def _still(self, stage: Stage) -> list[Path]:
        from .io.mesh_load import load_mesh
        from .pipeline import render_scene

        mesh: SkinMesh | None
        if self.kind == "scene":
            from .pipeline import grow

            with stage("growing hair") as progress:
                mesh, curves = grow(self.scene, progress)
            if self.mesh is not None:
                mesh = load_mesh(self.mesh)
        else:
            from .io.dispatch import load_curves

            curves = load_curves(self.source)
            mesh = load_mesh(self.mesh) if self.mesh else None
        label = "path tracing (%)" if self.engine.spp else "rendering"
        with stage(label) as progress:
            render_scene(curves, mesh, self.scene.render, out=str(self.target), progress=progress)
        return [self.target]

    def _frames(self, stage: Stage) -> list[Path]:
        cache, target, scene, frames = self.cache, self.target, self.scene, self.frames
        assert cache is not None and frames is not None
        if self.scheduler is not None:
            from .distributed import render as on_dask

            with stage("rendering frames on Dask") as progress:
                if self.video:
                    call = (cache, target, self.scheduler, scene, frames, self.frames_per_task)
                    return [on_dask.render_video(*call, progress)]
                return on_dask.render_cache(
                    cache, target, self.scheduler, scene, frames, self.frames_per_task, progress
                )
        from .pipeline import render_cache, render_frames

        with stage("rendering frames") as progress:
            if not self.video:
                return render_cache(cache, target, scene, frames, progress)
            from .render.video import write_mp4

            # frames handed to the encoder as they are rendered; the rendering starts
            # when it asks for the first, after it has checked the path, fps and ffmpeg
            images = (image for _, image in render_frames(cache, scene, frames, progress))
            return [write_mp4(images, target, cache.fps)]


def plan_render(
    source: str,
    out: str | os.PathLike[str] | None = None,
    *,
    mesh: str | None = None,
    size: tuple[int, int] | None = None,
    engine: str | None = None,
    shading: str | None = None,
    msaa: int | None = None,
    spp: int | None = None,
    count: int | None = None,
    frames: str | range | None = None,
    scheduler: str | None = None,
    frames_per_task: int | None = None,
) -> RenderJob:
    """A checked :class:`RenderJob`, as ``follicle render SOURCE -o OUT`` runs it; each
    keyword is the command's option of that name (None: not given), and the errors
    name the options as the command spells them.

    ``source`` is a scene (.toml, grown on the fly), a curves file, or a simulation
    cache (its frames to the folder ``out`` or the MP4 ``out``; default the cache's
    name + ``_frames``). ``mesh`` draws under a curves file or replaces a scene's;
    ``size``, ``engine``, ``shading``, ``msaa`` and ``spp`` override [render], each
    only where the engine takes it (:data:`follicle.render.backends.ENGINES`);
    ``count`` overrides [groom].count of a scene or cache; ``frames`` picks a cache's
    frames (``"START:STOP"``, ``"N"`` or a range); ``scheduler`` and
    ``frames_per_task`` render a cache on a Dask cluster. InputError, FormatError or
    ConfigError, before any work, for what does not fit."""
    from .inputs import default_output
    from .io.sim_cache import is_cache
    from .scene import Scene, check_outputs, load_scene, scene_with

    render: dict[str, object] = {
        "size": size,
        "shading": shading,
        "msaa": msaa,
        "spp": spp,
        "engine": engine,
    }
    if frames_per_task is not None:
        if scheduler is None:
            raise InputError(
                "--frames-per-task: sizes the Dask tasks of --scheduler; give --scheduler"
            )
        whole(frames_per_task, "--frames-per-task", 1)
    if is_cache(source):
        _not_for(source, "a simulation cache", mesh=mesh)
        chosen = _engine_takes(source, engine or "auto", shading, msaa, spp, cache=True)
        return _plan_cache(source, out, render, count, frames, scheduler, frames_per_task, chosen)
    kind: SourceKind = "scene" if Path(source).suffix.lower() == ".toml" else "curves"
    scene = (
        scene_with(load_scene(source), "groom", {"count": count}) if kind == "scene" else Scene()
    )
    scene = scene_with(scene, "render", render)
    chosen = _engine_takes(source, scene.render.engine, shading, msaa, spp)
    if kind == "scene":
        target = os.fspath(out or scene.output_path(scene.output.image))
        check_suffix(target, (".png",))
        check_outputs(target, source, scene, more=(("--mesh", mesh),))
        _not_for(source, "a scene", frames=frames, scheduler=scheduler)
    else:
        target = os.fspath(out or default_output(source, ".png"))
        check_suffix(target, (".png",))
        check_outputs(target, more=(("the curves file", source), ("--mesh", mesh)))
        _not_for(source, "a curves file", count=count, frames=frames, scheduler=scheduler)
    return RenderJob(source, kind, Path(target), scene, chosen, mesh)


def _plan_cache(
    source: str,
    out: str | os.PathLike[str] | None,
    render: dict[str, object],
    count: int | None,
    frames: str | range | None,
    scheduler: str | None,
    frames_per_task: int | None,
    engine: Engine,
) -> RenderJob:
    """:func:`plan_render` of the simulation cache ``source``: read it, check the frames
    and the output (a folder of frame_0000.png, … or an .mp4)."""
    from .inputs import default_output
    from .io.sim_cache import load_cache
    from .pipeline import cache_scene, check_frames
    from .scene import check_outputs, scene_with

    cache = load_cache(source)
    picked = _parse_frames(frames, cache.frame_count) if isinstance(frames, str) else frames
    picked = check_frames(cache, picked)
    scene = scene_with(cache_scene(cache), "groom", {"count": count})
    scene = scene_with(scene, "render", render)
    target = Path(out or default_output(source, "_frames"))
    if target.suffix.lower() != ".mp4" and (target.suffix.lower() == ".png" or target.is_file()):
        raise InputError(
            f"{target}: a simulation cache renders to a folder of frame_0000.png, … or to an"
            " .mp4 video; give -o a folder or a .mp4 file"
        )
    job = RenderJob(
        source, "cache", target, scene, engine, None, cache, picked, scheduler, frames_per_task
    )
    check_outputs(job.outputs, None, scene, more=(("the cache", source),))
    return job


def _engine_takes(
    source: str,
    name: str,
    shading: str | None,
    msaa: int | None,
    spp: int | None,
    cache: bool = False,
) -> Engine:
    """The engine ``name``, after an InputError for an option it does not take, or for a
    simulation cache (``cache``) when it draws stills only: its capability flags in the
    engine registry (:mod:`follicle.render.backends`)."""
    from .render.backends import ENGINES, get_engine

    chosen = get_engine(name)
    given = {"shading": shading, "msaa": msaa, "spp": spp}
    takes = {"shading": chosen.shading, "msaa": chosen.msaa, "spp": chosen.spp}
    for option, value in given.items():
        if value is not None and not takes[option]:
            raise InputError(f"{source}: --{option} does not apply to --engine {chosen.name}")
    if cache and not chosen.sequences:
        raster = ", ".join(e.name for e in ENGINES.values() if e.sequences)
        raise InputError(
            f"{source}: --engine {chosen.name} renders stills; render a simulation cache"
            f" with --engine {raster}"
        )
    return chosen


def _parse_frames(text: str, count: int) -> range:
    """``--frames`` START:STOP (STOP excluded; either may be left out) or N, within a cache
    of ``count`` frames."""
    first, colon, last = text.partition(":")
    try:
        a = int(first) if first.strip() else 0
        b = (int(last) if last.strip() else count) if colon else a + 1
    except ValueError:
        raise InputError(
            f"--frames {text!r}: expected START:STOP (e.g. 0:24, 10:, :12) or one frame number"
        ) from None
    if not 0 <= a < b <= count:
        raise InputError(
            f"--frames {text}: the cache has {count} frames (0..{count - 1}); give"
            f" 0 ≤ START < STOP ≤ {count}"
        )
    return range(a, b)


def _not_for(source: str, what: str, **options: object) -> None:
    """InputError when an option that does not apply to ``what`` was given."""
    given = [name for name, value in options.items() if value is not None]
    if given:
        raise InputError(f"{source}: --{given[0]} does not apply to {what}")
