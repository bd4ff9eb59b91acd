"""Scene-level stages: what `follicle grow`, `simulate` and `render` run, callable from Python."""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .curves import HairCurves
from .errors import ConfigError, FormatError, InputError, ResourceError
from .groom.generator import Groom, load_texture, resolve_density
from .groom.groups import InterpolationGroups, mesh_groups
from .groom.guides import Guides, load_guides
from .groom.starter import default_length, generate_guides, shown_length
from .inputs import base_folder
from .io.mesh_load import load_mesh
from .mesh.property import PropertyMap
from .mesh.skin import SkinMesh
from .mesh.texture import Texture
from .progress import Progress
from .render import Camera, fit_camera, make_renderer, render_image, save_png
from .scene import RenderParams, Scene, scene_from_toml, scene_to_toml
from .validate import file_path, positive, whole

if TYPE_CHECKING:
    from .io.sim_cache import SimCache
    from .sim.settle import Settled

log = logging.getLogger("follicle")

__all__ = [
    "GroomInputs",
    "groom_inputs",
    "scene_guides",
    "skin_and_guides",
    "groom_scene",
    "settle_guides",
    "grow",
    "render_scene",
    "simulate_scene",
    "SimRun",
    "timed_simulation",
    "cache_scene",
    "describe_cache",
    "render_frames",
    "render_cache",
    "check_frames",
    "cache_frame",
    "sequence_camera",
    "draw_frames",
    "frame_name",
]


@dataclass(frozen=True)
class GroomInputs:
    """What a scene's groom grows on, read from its files: the skin ``mesh``, the
    ``guides`` (settled when ``[groom].settle`` > 0: ``settled`` says how), the
    ``density`` and ``displacement`` textures. ``key`` names the scene keys they come
    from (:func:`groom_inputs`), so scenes that differ elsewhere (a batch's variants of
    curl or seed) share them instead of reading, and settling, them again."""

    key: tuple
    mesh: SkinMesh
    guides: Guides
    density: Texture | float | None
    displacement: Texture | None
    settled: Settled | None = None

    def made_for(self, scene: Scene) -> bool:
        """Whether these are ``scene``'s inputs: its keys that they come from are those
        they were made for (:func:`groom_inputs` would give them back)."""
        return self.key == _inputs_key(scene)


# [sim] keys a settle does not read: it holds the head still and pulls towards no pose
_UNSETTLING = {
    "motion",
    "motion_amplitude",
    "motion_period",
    "motion_pivot",
    "skin_animation",
    "shape_global",
}


def _inputs_key(scene: Scene) -> tuple:
    """The scene keys a groom's inputs come from: [mesh], [guides], the [groom] keys that
    pick the density and interpolation groups, and the folder paths start in; with
    [groom].settle > 0, it and the [sim] keys of the dynamics that settle the guides."""
    groom = scene.groom.model_dump(include={"density", "groups", "group_vertices"})
    key: tuple = (
        str(scene.base_dir),
        scene.mesh.model_dump_json(),
        scene.guides.model_dump_json(),
        repr(sorted(groom.items())),
    )
    if scene.groom.settle > 0:
        key += (scene.groom.settle, scene.sim.model_dump_json(exclude=_UNSETTLING))
    return key


def groom_inputs(
    scene: Scene, reuse: GroomInputs | None = None, progress: Progress | None = None
) -> GroomInputs:
    """The mesh, guides and textures of ``scene``, read from its files, the guides settled
    for ``[groom].settle`` s (:func:`follicle.sim.settle.settle`; ``progress(done,
    total)`` hears it); ``reuse`` itself when it was made for the same keys (see
    :class:`GroomInputs`)."""
    if reuse is not None and reuse.made_for(scene):
        return reuse
    key = _inputs_key(scene)
    mesh, density, guides = skin_and_guides(scene)
    settled = None
    if scene.groom.settle > 0:
        from .sim.settle import settle

        settled = settle(guides, scene.sim, scene.groom.settle, progress)
        guides = settled.guides
    displacement = scene.mesh.displacement
    texture = load_texture(displacement, scene.resolve) if displacement else None
    return GroomInputs(key, mesh, guides, density, texture, settled)


def skin_and_guides(scene: Scene) -> tuple[SkinMesh, Texture | float | None, Guides]:
    """The scene's mesh, its root density ([groom].density) and its guides on it
    (:func:`scene_guides`), before any settling."""
    mesh = load_mesh(scene.resolve(scene.mesh.path), units=scene.mesh.units)
    density = resolve_density(mesh, scene.groom.density, scene.resolve)
    return mesh, density, scene_guides(scene, mesh, density)


def scene_guides(scene: Scene, mesh: SkinMesh, density: Texture | float | None = None) -> Guides:
    """The guides of ``scene`` on its ``mesh``, before any settling: read from
    [guides].path, or generated on the mesh ([guides].generate, over the root
    ``density``), in the interpolation groups [groom].groups gives. Guides a scene gets
    for having no [guides] table (:meth:`GuidesParams.implied`) are announced in one
    line: how many, how long, and that [guides] chooses."""
    spec, vertices = scene.groom.groups, scene.groom.group_vertices
    g = scene.guides
    if spec is None and g.generate is None and g.path.startswith("builtin:"):
        groups = mesh_groups(mesh, vertices)  # as load_guides gives built-in guides
    else:
        texture = None if spec in (None, "none") else load_texture(spec, scene.resolve, mesh)
        groups = InterpolationGroups(texture, vertices)
    if g.generate is None:
        return load_guides(scene.resolve(g.path), mesh, groups=groups, units=g.units)
    length = None
    if g.length is not None:
        length = PropertyMap.from_spec(g.length, "scalar", "[guides].length", scene.resolve)
    guides = generate_guides(
        mesh,
        g.generate,
        **g.model_dump(include={"count", "vertices", "comb", "lift", "gravity", "seed"}),
        length=length,
        density=density,
        groups=groups,
    )
    if g.is_implied:
        log.warning(
            "[mesh] has no [guides]: %d guides generated along the normals, %s long; set"
            " [guides] to choose",
            guides.count,
            shown_length(default_length(mesh)),
        )
    return guides


def settle_guides(
    scene: Scene, seconds: float | None = None, progress: Progress | None = None
) -> Settled:
    """`follicle settle`: the guides of ``scene`` settled for ``seconds`` (None: its
    ``[groom].settle``, which must then be > 0) under its [sim] dynamics with the head
    still, and how they ended (:class:`~follicle.sim.settle.Settled`); save them with
    ``follicle.save(settled.guides.curves, path)``."""
    if seconds is not None:
        scene = scene.replace(groom=scene.groom.replace("settle_guides seconds", settle=seconds))
    if scene.groom.settle <= 0:
        raise InputError(
            "[groom].settle: 0 s leaves the guides as they are; set it (e.g. 2) or give"
            " the seconds to settle (`follicle settle --seconds 2`)"
        )
    settled = groom_inputs(scene, progress=progress).settled
    assert settled is not None  # settle > 0
    return settled


def groom_scene(scene: Scene, inputs: GroomInputs | None = None) -> Groom:
    """The mesh, guides and groom parameters of ``scene``, ready to grow; its files'
    contents from ``inputs`` when they were read for the same keys
    (:func:`groom_inputs`)."""
    inputs = groom_inputs(scene, inputs)
    return Groom(
        inputs.mesh,
        inputs.guides,
        scene.groom,
        density=inputs.density,
        displacement=inputs.displacement,
        displacement_scale=scene.mesh.displacement_scale,
        resolve_path=scene.resolve,
    )


def grow(
    scene: Scene | None = None, progress: Progress | None = None
) -> tuple[SkinMesh, HairCurves]:
    """Grow the hair of ``scene`` (the default scene when None): (mesh, curves)."""
    if scene is not None and not isinstance(scene, Scene):
        raise InputError(
            f"scene: expected a follicle.Scene (load_scene), got {type(scene).__name__}"
        )
    groom = groom_scene(scene if scene is not None else Scene())
    return groom.mesh, groom.generate(progress=progress)


def framed_camera(points: np.ndarray, fov: float, aspect: float) -> Camera:
    """:func:`~follicle.render.fit_camera` on ``points`` (N, 3), without its near/far, so
    a camera kept over many frames has them fitted to each frame by the renderer."""
    framed = fit_camera(points, fov_y=fov, aspect=aspect)
    return Camera(eye=framed.eye, target=framed.target, up=framed.up, fov_y=fov)


def render_scene(
    curves: HairCurves | None,
    mesh: SkinMesh | None,
    params: RenderParams,
    out: str | None = None,
    progress: Progress | None = None,
) -> np.ndarray:
    """Render hair and mesh with a scene's [render] settings, by its engine (a raster
    engine, or Mitsuba's path tracer: ``spp``); writes PNG when ``out``;
    ``progress(done, total)`` hears the engine's progress."""
    return render_image(curves, mesh, settings=params, out=out, progress=progress)


def simulate_scene(
    scene: Scene, frames: int = 48, fps: float = 24.0, progress: Progress | None = None
) -> tuple[SimCache, dict[str, float]]:
    """Simulate the guides of ``scene`` under its [sim].motion head animation, or its
    [sim].skin_animation (:func:`follicle.io.skin_animation.load_skin_animation`).

    Frame 0 is the rest state (with a skin animation: the groom carried rigidly, root
    frame by root frame, onto the skin's first sample); frame f poses the head (or the
    skin) at time f / fps and steps 1 / fps. Returns the cache (not yet written:
    :func:`follicle.io.sim_cache.save_cache`) and the last frame's ``Simulator.stats``.
    """
    from .io.sim_cache import SimCache
    from .sim.motion import head_motion, motion_pivot
    from .sim.simulator import MAX_SUBSTEPS_PER_CALL, Simulator, substeps_per_step

    frames = whole(frames, "frames", 1)
    fps = positive(fps, "fps")
    p = scene.sim
    per_frame = substeps_per_step(1.0 / fps, p.substep)
    if per_frame > MAX_SUBSTEPS_PER_CALL:  # refused now, not after growing the groom
        raise ResourceError(
            f"[sim].substep {p.substep:g} needs {per_frame:,} substeps per frame at {fps:g}"
            f" fps; the cap is {MAX_SUBSTEPS_PER_CALL:,}: raise [sim].substep above"
            f" {1.0 / (fps * MAX_SUBSTEPS_PER_CALL):.2g} s (or the frame rate)"
        )
    text = scene_to_toml(scene, comments=False)  # fails now, not after the simulation
    groom = groom_scene(scene)
    pivot = motion_pivot(groom.mesh, p.motion_pivot)
    skin = None
    if p.skin_animation is not None:
        from .io.skin_animation import load_skin_animation

        skin = load_skin_animation(
            scene.resolve(p.skin_animation), groom.mesh, units=scene.mesh.units
        )
    sim = Simulator(groom.guides, params=p)
    positions = np.empty((int(frames), *sim.positions.shape), dtype=np.float32)
    transforms = np.repeat(np.eye(4)[None], int(frames), axis=0)
    skin_vertices: np.ndarray | None = None
    if skin is not None:
        sim.teleport(vertices=skin.at(0.0))
        skin_vertices = np.empty((int(frames), *skin.vertices.shape[1:]), dtype=np.float32)
        assert sim.pose is not None  # posed by the skin just now
        skin_vertices[0] = sim.pose.vertices
    positions[0] = sim.positions
    if progress is not None:
        progress(1, int(frames))  # frame 0, the rest state: set-up is done
    for f in range(1, int(frames)):
        if skin is None:
            transforms[f] = head_motion(
                p.motion, f / fps, p.motion_amplitude, p.motion_period, pivot
            )
            sim.set_pose(transform=transforms[f])
        else:
            sim.set_pose(vertices=skin.at(f / fps))
            assert skin_vertices is not None and sim.pose is not None  # a skin poses the sim
            skin_vertices[f] = sim.pose.vertices
        sim.step(1.0 / fps)
        positions[f] = sim.positions
        if progress is not None:
            progress(f + 1, int(frames))
    cache = SimCache(
        positions, transforms, float(fps), text, str(scene.base_dir), skin_vertices=skin_vertices
    )
    return cache, sim.stats


@dataclass(frozen=True)
class SimRun:
    """What one simulation made and took, for the line `follicle simulate` prints: the
    cache's ``frames``, ``fps``, ``strands`` × ``vertices``; ``seconds`` in all, of which
    ``setup`` before the first step (groom, skin field, simulator); the last frame's
    ``Simulator.stats``. Small, so a Dask task returns it instead of the cache."""

    frames: int
    fps: float
    strands: int
    vertices: int
    seconds: float
    setup: float
    stats: dict[str, float]


def timed_simulation(
    scene: Scene, frames: int = 48, fps: float = 24.0, progress: Progress | None = None
) -> tuple[SimCache, SimRun]:
    """:func:`simulate_scene`, timed: the cache and its :class:`SimRun`."""
    start = time.perf_counter()
    stepping = [start]  # when frame 0 was ready: the set-up is done

    def report(done: int, total: int) -> None:
        if done == 1:
            stepping[0] = time.perf_counter()
        if progress is not None:
            progress(done, total)

    cache, stats = simulate_scene(scene, frames, fps, report)
    run = SimRun(
        cache.frame_count,
        cache.fps,
        cache.strand_count,
        cache.vertex_count,
        time.perf_counter() - start,
        stepping[0] - start,
        stats,
    )
    return cache, run


def cache_scene(cache: SimCache) -> Scene:
    """The scene a simulation cache stores, validated, with relative paths resolved
    against its ``base_dir``; FormatError (the cache is damaged) if it does not parse."""
    try:
        return scene_from_toml(
            cache.scene_toml, f"{cache.source}: stored scene", base_folder(cache.base_dir)
        )
    except ConfigError as exc:
        raise FormatError(f"{exc}; the cache is damaged: run `follicle simulate` again") from None


def describe_cache(path: str | os.PathLike[str]) -> str:
    """One paragraph on the cache at ``path`` for `follicle info`: frames, fps and length,
    guides and vertices, the head motion and the hairs `follicle render` grows. Reading the
    stored scene checks it too, so a damaged one is refused here as in `follicle render`."""
    path = file_path(path, "describe_cache path")
    from .io.sim_cache import load_cache

    cache = load_cache(path)
    scene = cache_scene(cache)
    sim, f = scene.sim, cache.frame_count
    if cache.skin_vertices is not None:
        motion = f"the skin animated ({cache.skin_vertices.shape[1]:,} vertices a frame)"
    elif sim.motion == "none":
        motion = "a still head"
    else:
        motion = (
            f"head motion {sim.motion!r} ({sim.motion_amplitude:g}° over {sim.motion_period:g} s)"
        )
    return (
        f"{cache.source}: simulation cache, {f:,} frame{'s' * (f != 1)} at {cache.fps:g} fps"
        f" ({(f - 1) / cache.fps:.3g} s after the rest frame), {cache.strand_count:,} guides ×"
        f" {cache.vertex_count} vertices, {motion}; `follicle render` grows"
        f" {scene.groom.count:,} hairs on every frame"
    )


def check_cache_skin(cache: SimCache, mesh: SkinMesh) -> None:
    """FormatError unless the cache's animated skin (if any) fits ``mesh`` (the scene's
    skin): one vertex per vertex of it."""
    if cache.skin_vertices is not None and cache.skin_vertices.shape[1] != len(mesh.rest_vertices):
        raise FormatError(
            f"{cache.source}: its skin has {cache.skin_vertices.shape[1]:,} vertices a frame,"
            f" the scene's mesh '{mesh.name}' {len(mesh.rest_vertices):,}: the mesh file"
            " changed since the simulation; run `follicle simulate` again"
        )


def cache_pose(cache: SimCache, mesh: SkinMesh, f: int) -> SkinMesh:
    """The skin ``mesh`` in the pose of the cache's frame ``f``: its animated vertices, or
    the rest moved by the head transform (:func:`check_cache_skin` first)."""
    if cache.skin_vertices is not None:
        return mesh.posed(vertices=cache.skin_vertices[f])
    return mesh.posed(transform=cache.transforms[f])


def cache_frame(cache: SimCache, groom: Groom, f: int) -> tuple[HairCurves, SkinMesh]:
    """Frame ``f`` of ``cache``: the hair ``groom`` grows on its guides, and the skin in
    its pose (:func:`check_cache_skin` first)."""
    skin = cache_pose(cache, groom.mesh, f)
    return groom.follow(cache.positions[f], time=f / cache.fps, pose=skin), skin


def sequence_camera(cache: SimCache, groom: Groom, params: RenderParams) -> Camera:
    """One camera for every frame of ``cache``: the scene's eye/target, else framed on
    frame 0's hair and the head and guides of all frames (no jumps, nothing leaves view).
    It depends on the whole cache, never on the frames rendered, so any range of frames,
    rendered anywhere, is seen as the whole sequence is."""
    fixed = params.camera()
    if fixed is not None:
        return fixed
    first = cache_frame(cache, groom, 0)[0]
    parts = [first.points] if first.point_count else []
    parts.append(cache.positions.reshape(-1, 3))
    if cache.skin_vertices is not None:  # the used vertices of every frame
        used = np.unique(groom.mesh.faces)
        parts.append(cache.skin_vertices[:, used].reshape(-1, 3))
    else:
        hull = _hull(groom.mesh.used_vertices("rest"))  # a rigid motion moves the hull along
        for transform in cache.transforms:
            parts.append((hull @ transform[:3, :3].T + transform[:3, 3]).astype(np.float32))
    w, h = params.size
    return framed_camera(np.concatenate(parts), params.fov, w / h)


def _hull(points: np.ndarray) -> np.ndarray:
    """The points on the convex hull of ``points`` (all of them for a flat set)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return points[ConvexHull(points).vertices]
    except (QhullError, ValueError):
        return points


def check_frames(cache: SimCache, frames: range | None) -> range:
    """``frames`` (None: all) checked to be a non-empty run of the cache's frames."""
    count = cache.frame_count
    frames = range(count) if frames is None else frames
    if (
        not isinstance(frames, range)
        or frames.step != 1
        or len(frames) == 0
        or frames.start < 0
        or frames.stop > count
    ):
        raise InputError(
            f"frames: expected a non-empty range within 0..{count - 1} (the cache has"
            f" {count} frames), got {frames!r}"
        )
    return frames


def render_frames(
    cache: SimCache,
    scene: Scene | None = None,
    frames: range | None = None,
    progress: Progress | None = None,
) -> Iterator[tuple[int, np.ndarray]]:
    """Render frames of a simulation cache one by one: yields (cache frame, (H, W, 4)
    uint8 sRGB image), all seen through one camera. ``scene`` (default: the cache's own)
    sets the hair and [render]; ``frames`` (default all) picks cache frames. Nothing is
    set up before the first frame is asked for."""
    frames = check_frames(cache, frames)
    scene = cache_scene(cache) if scene is None else scene
    groom = groom_scene(scene)
    check_cache_skin(cache, groom.mesh)
    camera = sequence_camera(cache, groom, scene.render)
    yield from draw_frames(cache, groom, scene.render, frames, camera, progress)


def draw_frames(
    cache: SimCache,
    groom: Groom,
    params: RenderParams,
    frames: range,
    camera: Camera,
    progress: Progress | None = None,
) -> Iterator[tuple[int, np.ndarray]]:
    """:func:`render_frames`' drawing: yields (cache frame, image) for ``frames`` of
    ``cache``, the hair grown by ``groom`` (:func:`check_cache_skin` first), drawn
    with ``params`` through ``camera`` (:func:`sequence_camera`). A frame's image
    depends on nothing but the frame, so a run of frames drawn alone (a Dask task's)
    is the same bytes as in the whole sequence."""
    with make_renderer(params) as renderer:
        for done, f in enumerate(frames, 1):
            yield f, renderer.draw(*cache_frame(cache, groom, f), camera=camera, settings=params)
            if progress is not None:
                progress(done, len(frames))


def frame_name(cache: SimCache, f: int) -> str:
    """The file of cache frame ``f`` in a rendered sequence: ``frame_0000.png``, … with as
    many digits as the cache's last frame needs (at least four)."""
    digits = max(4, len(str(cache.frame_count - 1)))
    return f"frame_{f:0{digits}d}.png"


def render_cache(
    cache: SimCache,
    out_dir: str | os.PathLike[str],
    scene: Scene | None = None,
    frames: range | None = None,
    progress: Progress | None = None,
) -> list[Path]:
    """Render frames of a simulation cache to ``out_dir/frame_0000.png``, … (atomically).

    ``scene`` (default: the cache's own) sets the hair and [render]; ``frames`` (default
    all) picks cache frames; files are named by cache frame, so ranges add up to one
    sequence seen through one camera (:func:`render_frames`).
    """
    out_dir = file_path(out_dir, "render_cache out_dir")
    frames = check_frames(cache, frames)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for f, image in render_frames(cache, scene, frames, progress):
        path = out / frame_name(cache, f)
        save_png(image, path)
        written.append(path)
    return written
