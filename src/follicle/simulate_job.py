"""``follicle simulate``'s work as a library call: the guide hairs of one or many scene
files simulated under a head or skin animation, a cache written for each, one after
another here or side by side on a Dask cluster.

:func:`plan_simulate` reads the scenes, applies the command's overrides and decides
each cache's file, refusing what would be ambiguous or replace an input, before any
simulation starts; :meth:`SimulateJob.run` simulates and writes. The command calls the
two and prints a line a scene; Python calls them the same way::

    for scene, run, path in plan_simulate(["a.toml"], "a.npz", frames=24).run():
        print(run.seconds, path)
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from .errors import InputError
from .progress import Stage, quietly
from .validate import check_suffix

if TYPE_CHECKING:
    from .pipeline import SimRun
    from .scene import Scene

__all__ = ["plan_simulate", "SimulateJob"]


@dataclass(frozen=True)
class SimulateJob:
    """Checked ``scenes`` to simulate, ``frames`` frames at ``fps`` each, into the caches
    ``targets`` (one a scene, in order), here or on the Dask cluster ``scheduler``.
    Made by :func:`plan_simulate`."""

    scenes: tuple[Scene, ...]
    targets: tuple[str, ...]
    frames: int = 48
    fps: float = 24.0
    scheduler: str | None = None

    def run(self, stage: Stage = quietly) -> Iterator[tuple[Scene, SimRun, str]]:
        """Simulate and write each cache, yielding (scene, its run, its cache) as each is
        written here (one ``stage("simulating")`` and one ``stage("saving")`` a scene),
        or all at once from the cluster (one ``stage("simulating scenes on Dask")``)."""
        if self.scheduler is not None:
            from .distributed.simulate import simulate_scenes

            with stage("simulating scenes on Dask") as progress:
                runs = simulate_scenes(
                    self.scenes, self.targets, self.scheduler, self.frames, self.fps, progress
                )
            yield from zip(self.scenes, runs, self.targets, strict=True)
            return
        from .io.sim_cache import write_cache
        from .pipeline import timed_simulation

        for scene, target in zip(self.scenes, self.targets, strict=True):
            with stage("simulating") as progress:
                cache, run = timed_simulation(scene, self.frames, self.fps, progress)
            with stage("saving"):
                write_cache(cache, target)
            yield scene, run, target


def plan_simulate(
    scene_paths: Sequence[str],
    out: str | os.PathLike[str] | None = None,
    *,
    frames: int = 48,
    fps: float = 24.0,
    motion: str | None = None,
    skin_animation: str | None = None,
    count: int | None = None,
    scheduler: str | None = None,
) -> SimulateJob:
    """A checked :class:`SimulateJob`, as ``follicle simulate SCENE... -o OUT`` runs it;
    each keyword is the command's option of that name (None: not given).

    ``out`` is the cache of one scene (default sim.npz in the scene's folder); for
    several scenes, a folder: scene NAME.toml goes to OUT/NAME.npz. ``motion``
    overrides [sim].motion; ``skin_animation`` (a USD or Alembic file) replaces the
    scene's motion; ``count`` overrides [groom].count. InputError, before any
    simulation, for several scenes without a folder, two scenes of one name, or a
    cache that would replace an input."""
    from .scene import check_outputs

    if not scene_paths:
        raise InputError("simulate: give at least one scene file")
    scenes = [_sim_scene(path, count, motion, skin_animation) for path in scene_paths]
    targets = _cache_targets(scene_paths, scenes, out)
    for path, scene in zip(scene_paths, scenes, strict=True):
        check_outputs(targets, path, scene)
    return SimulateJob(tuple(scenes), tuple(targets), frames, fps, scheduler)


def _sim_scene(
    path: str, count: int | None, motion: str | None, skin_animation: str | None
) -> Scene:
    """The scene file ``path`` with `follicle simulate`'s overrides."""
    from .inputs import is_url
    from .scene import load_scene, scene_with

    scene = scene_with(load_scene(path), "groom", {"count": count})
    changes: dict[str, object] = {"motion": motion}
    if skin_animation is not None:  # it replaces the scene's motion, not one given here
        given = skin_animation if is_url(skin_animation) else os.path.abspath(skin_animation)
        changes = {"motion": motion or "none", "skin_animation": given}
    return scene_with(scene, "sim", changes)


def _cache_targets(
    paths: Sequence[str], scenes: list[Scene], out: str | os.PathLike[str] | None
) -> list[str]:
    """Where each scene's cache goes: ``out`` (default sim.npz in the scene's folder) for
    one scene; for several, ``out`` must be a folder, and scene NAME.toml goes to
    OUT/NAME.npz. InputError for what would be ambiguous: several scenes without -o,
    or with -o a file, or two scenes of one name."""
    from .export import files_in_folder

    if len(paths) == 1:
        target = os.fspath(out or scenes[0].output_path("sim.npz"))
        check_suffix(target, (".npz",))
        return [target]
    if out is None:
        raise InputError(
            f"{len(paths)} scenes: give -o FOLDER for their caches (FOLDER/NAME.npz for each"
            " scene NAME.toml)"
        )
    folder = Path(out)
    if folder.suffix.lower() == ".npz" or (folder.exists() and not folder.is_dir()):
        raise InputError(
            f"-o {os.fspath(out)}: {len(paths)} scenes write a cache each; give -o a folder"
            " (FOLDER/NAME.npz for each scene NAME.toml)"
        )
    return files_in_folder(
        paths,
        folder,
        ".npz",
        lambda a, b, target: (
            f"-o {os.fspath(out)}: scenes {a} and {b} would both write {target};"
            " give the scene files different names"
        ),
    )
