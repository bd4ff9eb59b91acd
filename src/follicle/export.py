"""``follicle grow``, ``settle``, ``guides`` and ``export`` as library calls.

:func:`plan_grow`, :func:`plan_settle`, :func:`plan_guides` and :func:`plan_export`
take a command's options as keywords, check everything before any work (formats,
targets, that no output replaces an input) and return a job (:class:`GrowJob`,
:class:`SettleJob`, :class:`GuidesJob`, :class:`ExportJob`) whose ``run`` writes and
returns what the command prints. Beneath
them: :func:`grow_file` (one process or a Dask cluster, one file or a payloads
layout), :func:`export_targets` (where each input goes), :func:`export_skin` (a mesh
alone) and :func:`export_cache` (a simulation cache as animated USD or Alembic).
Curves files themselves convert through :func:`follicle.distributed.export.convert`
(one file) and :func:`follicle.distributed.export.export_files` (many, here or on Dask).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from .curves import HairCurves
from .errors import FormatError, InputError
from .io.dispatch import CACHE_WRITERS, MESH_WRITERS, WRITERS
from .io.suffixes import MESH_FILE_SUFFIXES, SCENE_SUFFIXES, USD_SUFFIXES
from .mesh.skin import SkinMesh
from .progress import Progress, Stage, quietly
from .validate import check_suffix

if TYPE_CHECKING:
    from .groom.generator import Groom
    from .groom.guides import Guides
    from .scene import Scene
    from .sim.settle import Settled

__all__ = [
    "plan_grow",
    "GrowJob",
    "plan_settle",
    "SettleJob",
    "plan_guides",
    "GuidesJob",
    "grow_file",
    "grown_chunks",
    "curve_suffixes",
    "mesh_only",
    "plan_export",
    "ExportJob",
    "Exported",
    "export_targets",
    "files_in_folder",
    "export_skin",
    "export_cache",
    "CacheExport",
]


def grown_chunks(
    groom: Groom,
    tally: list[int],
    target: str = "generic",
    size: int | None = None,
    progress: Progress | None = None,
) -> Iterator[HairCurves]:
    """The groom's hairs in chunks of ``size`` (default the writers' CHUNK), reporting
    progress and adding up (hairs, points) in ``tally``; one empty chunk for a count
    of 0, so the file is still written. For a tool that reads the binding (Unreal) each
    hair also carries the three guides it blends most and their weights."""
    from .distributed.grow import part_ranges, target_chunk
    from .groom.generator import CHUNK

    total = groom.params.count
    for start, count in part_ranges(total, size or CHUNK):
        chunk = target_chunk(groom, groom.generate(count, start), target)
        tally[0] += chunk.curve_count
        tally[1] += chunk.point_count
        yield chunk
        if progress is not None:
            progress(start + count, total)


def grow_file(
    scene: Scene,
    path: str | os.PathLike[str],
    target: str = "generic",
    skin: bool = True,
    scheduler: str | None = None,
    chunk: int | None = None,
    layout: str = "file",
    progress: Progress | None = None,
) -> tuple[int, int]:
    """Grow ``scene``'s hair into ``path`` as ``follicle grow`` does; returns (hairs,
    points). On the Dask cluster ``scheduler`` in tasks of ``chunk`` hairs
    (:func:`follicle.distributed.grow.grow`), else here: a .npz whole, any other format
    streamed chunk by chunk (memory bounded whatever the count), USD and Alembic with the
    guides and, with ``skin``, the skin, named and typed for ``target``; ``layout``
    ``"payloads"`` writes a USD root and part files of ``chunk`` hairs
    (:func:`follicle.io.usd_payloads.save_usd_payloads`)."""
    from .io.dispatch import save
    from .io.targets import writer_extras
    from .pipeline import groom_scene
    from .pipeline import grow as grow_scene

    if scheduler is not None:
        from .distributed.grow import grow as grow_distributed

        return grow_distributed(scene, path, scheduler, chunk, target, skin, progress, layout)
    if Path(path).suffix.lower() == ".npz":
        _, curves = grow_scene(scene, progress)
        save(curves, path)
        return curves.curve_count, curves.point_count
    tally = [0, 0]
    groom = groom_scene(scene)
    extras = writer_extras(path, target, groom.guides, groom.mesh if skin else None)
    if layout == "payloads":
        from .io.usd_payloads import PART_HAIRS, save_usd_payloads

        chunks = grown_chunks(groom, tally, target, chunk or PART_HAIRS, progress)
        save_usd_payloads(chunks, path, **extras)
    else:
        save(grown_chunks(groom, tally, target, progress=progress), path, **extras)
    return tally[0], tally[1]


@dataclass(frozen=True)
class GrowJob:
    """A checked grow of ``scene`` into ``path`` (see :func:`grow_file` for the rest).
    Made by :func:`plan_grow`."""

    scene: Scene
    path: str
    target: str = "generic"
    skin: bool = True
    scheduler: str | None = None
    chunk: int | None = None
    layout: str = "file"

    def run(self, stage: Stage = quietly) -> tuple[int, int]:
        """:func:`grow_file` under ``stage("growing hair")``; returns (hairs, points)."""
        where = " on Dask" if self.scheduler is not None else ""
        with stage(f"growing hair{where}") as progress:
            return grow_file(
                self.scene,
                self.path,
                self.target,
                self.skin,
                self.scheduler,
                self.chunk,
                self.layout,
                progress,
            )


def plan_grow(
    scene_path: str | None,
    out: str | os.PathLike[str] | None = None,
    *,
    count: int | None = None,
    seed: int | None = None,
    target: str | None = None,
    skin: bool = True,
    scheduler: str | None = None,
    chunk: int | None = None,
    layout: str | None = None,
) -> GrowJob:
    """A checked :class:`GrowJob`, as ``follicle grow SCENE -o OUT`` runs it; each keyword
    is the command's option of that name (None: not given). ``out`` defaults to the
    scene's [output].curves, ``target`` to its [output].target, ``layout`` to its
    [output].layout; ``count`` and ``seed`` override [groom]. FormatError or
    InputError, before any hair is grown, for an output format, target, chunk or
    layout that does not fit, or an output that would replace an input."""
    from .io.targets import check_named
    from .scene import check_outputs, load_scene, scene_with

    scene = scene_with(load_scene(scene_path), "groom", {"count": count, "seed": seed})
    path = os.fspath(out or scene.output_path(scene.output.curves))
    check_suffix(path, curve_suffixes())
    tool = target or scene.output.target
    check_named(path, Path(path).suffix, tool, "--target")
    layout = layout or scene.output.layout
    if chunk is not None and chunk < 1:
        raise InputError(f"--chunk {chunk}: give a whole number of hairs ≥ 1")
    if chunk is not None and scheduler is None and layout == "file":
        raise InputError(
            "--chunk: sizes the Dask tasks of --scheduler, or the part files of --layout"
            " payloads; give one of them"
        )
    folders = []
    if layout == "payloads":
        from .io.usd_payloads import check_payloads_target, payloads_folder

        check_payloads_target(path)  # before any hair is grown
        folders.append(payloads_folder(path))
    check_outputs(path, scene_path, scene, folders=folders)
    return GrowJob(scene, path, tool, skin, scheduler, chunk, layout)


@dataclass(frozen=True)
class SettleJob:
    """A checked settle of ``scene``'s guides, saved as new guides at ``path``. Made by
    :func:`plan_settle`."""

    scene: Scene
    path: str

    def run(self, stage: Stage = quietly) -> Settled:
        """:func:`follicle.pipeline.settle_guides` under ``stage("settling guides")``,
        then the guides written; returns how they ended."""
        from .io.dispatch import save
        from .pipeline import settle_guides

        with stage("settling guides") as progress:
            done = settle_guides(self.scene, progress=progress)
        save(done.guides.curves, self.path)
        return done


def plan_settle(
    scene_path: str | None, out: str | os.PathLike[str], *, seconds: float | None = None
) -> SettleJob:
    """A checked :class:`SettleJob`, as ``follicle settle SCENE -o OUT`` runs it:
    ``seconds`` overrides [groom].settle, which must then be > 0; ``out`` is any curves
    format. InputError, FormatError or ConfigError before any simulation."""
    from .scene import check_outputs, load_scene, scene_with

    path = os.fspath(out)
    check_suffix(path, curve_suffixes())
    scene = scene_with(load_scene(scene_path), "groom", {"settle": seconds})
    if scene.groom.settle <= 0:
        raise InputError(
            "[groom].settle: 0 s leaves the guides as they are; set it (e.g. 2) or give"
            " the seconds to settle (`follicle settle --seconds 2`)"
        )
    check_outputs([path], scene_path, scene)
    return SettleJob(scene, path)


@dataclass(frozen=True)
class GuidesJob:
    """A checked write of ``scene``'s guides (read or generated, not settled) to ``path``,
    a curves file that loads back as ``[guides] path``. Made by :func:`plan_guides`."""

    scene: Scene
    path: str

    def run(self) -> Guides:
        """The scene's guides on its mesh (:func:`follicle.pipeline.skin_and_guides`), written
        (atomically, as every writer does); returns them."""
        from .io.dispatch import save
        from .pipeline import skin_and_guides

        guides = skin_and_guides(self.scene)[2]
        save(guides.curves, self.path)
        return guides


def plan_guides(scene_path: str | None, out: str | os.PathLike[str]) -> GuidesJob:
    """A checked :class:`GuidesJob`, as ``follicle guides SCENE -o OUT`` runs it: ``out``
    is any curves format and replaces none of the scene's inputs (FormatError or
    InputError before anything is read)."""
    from .scene import check_outputs, load_scene

    path = os.fspath(out)
    check_suffix(path, curve_suffixes())
    scene = load_scene(scene_path)
    check_outputs([path], scene_path, scene)
    return GuidesJob(scene, path)


def curve_suffixes() -> tuple[str, ...]:
    """The extensions curves can be written to: .npz first, then the others sorted."""
    return (".npz", *sorted(set(WRITERS) - {".npz"}))


def mesh_only(path: str | os.PathLike[str]) -> bool:
    """True when ``path``'s extension is written only as a mesh (.ply, .glb, …; .obj is a
    curves format too)."""
    return Path(path).suffix.lower() in set(MESH_WRITERS) - set(WRITERS)


@dataclass(frozen=True)
class Exported:
    """What :meth:`ExportJob.run` wrote, by its kind: (hairs, points) per curves file
    (``counts``, in the order of the targets), the ``mesh`` of a mesh export, or the
    ``cache`` export's summary."""

    counts: tuple[tuple[int, int], ...] = ()
    mesh: SkinMesh | None = None
    cache: CacheExport | None = None


@dataclass(frozen=True)
class ExportJob:
    """A checked export of ``sources`` to ``targets`` (one each) for the ``tool``: as
    curves files (``kind`` ``"curves"``, converted here or on the Dask cluster
    ``scheduler``), a mesh alone (``"mesh"``) or a simulation cache as animated USD or
    Alembic (``"cache"``, with the ``skin`` or not). Made by :func:`plan_export`."""

    kind: Literal["curves", "mesh", "cache"]
    sources: tuple[str, ...]
    targets: tuple[str, ...]
    tool: str = "generic"
    skin: bool = True
    scheduler: str | None = None

    def run(self, stage: Stage = quietly) -> Exported:
        """Write every target: ``stage("writing frames")`` for a cache,
        ``stage("converting files")`` for several curves files."""
        if self.kind == "mesh":
            return Exported(mesh=export_skin(self.sources[0], self.targets[0], self.tool))
        if self.kind == "cache":
            with stage("writing frames") as progress:
                done = export_cache(
                    self.sources[0], self.targets[0], self.skin, self.tool, progress
                )
            return Exported(cache=done)
        from .distributed.export import convert, export_files

        if len(self.sources) == 1 and self.scheduler is None:
            return Exported(counts=(convert(self.sources[0], self.targets[0], self.tool),))
        where = " on Dask" if self.scheduler else ""
        with stage(f"converting files{where}") as progress:
            counts = export_files(self.sources, self.targets, self.scheduler, self.tool, progress)
        return Exported(counts=tuple(counts))


def plan_export(
    sources: Sequence[str],
    out: str | os.PathLike[str],
    *,
    suffix: str | None = None,
    target: str | None = None,
    skin: bool = True,
    scheduler: str | None = None,
) -> ExportJob:
    """A checked :class:`ExportJob`, as ``follicle export IN... -o OUT`` runs it; each
    keyword is the command's option of that name (``suffix``: ``--to``; None: not
    given). Several ``sources``, a ``suffix``, a ``scheduler`` or ``out`` a folder
    convert curves files into the folder ``out`` (:func:`export_targets`); one source
    that is a built-in mesh, or an ``out`` that only a mesh is written to, exports a
    mesh (:func:`export_skin`); a simulation cache exports as animated USD or Alembic
    (:func:`export_cache`); else one curves file converts to ``out``. FormatError or
    InputError, before anything is read, for what does not fit."""
    from .io.mesh_load import BUILTIN_MESHES
    from .io.sim_cache import is_cache
    from .io.targets import check_named
    from .scene import check_outputs

    tool = target or "generic"
    out = os.fspath(out)
    if not sources:
        raise InputError("export: give at least one file to export")
    if len(sources) > 1 or suffix is not None or scheduler is not None or Path(out).is_dir():
        targets = export_targets(sources, out, suffix)
        check_named(targets[0], Path(targets[0]).suffix, tool, "--target")
        return ExportJob("curves", tuple(sources), tuple(targets), tool, skin, scheduler)
    source = sources[0]
    check_outputs(out, more=(("its own input", source),))
    builtin = source.startswith("builtin:") and source[len("builtin:") :] in BUILTIN_MESHES
    if builtin or mesh_only(out):
        return ExportJob("mesh", (source,), (out,), tool)
    check_suffix(out, curve_suffixes())
    check_named(out, Path(out).suffix, tool, "--target")
    kind: Literal["curves", "cache"] = "cache" if is_cache(source) else "curves"
    return ExportJob(kind, (source,), (out,), tool, skin)


def export_targets(
    sources: Sequence[str], out: str | os.PathLike[str], suffix: str | None
) -> list[str]:
    """Where each of ``sources`` is written: ``out`` itself for one source without
    ``suffix``; otherwise ``out`` is a folder and NAME.ext goes to OUT/NAME.SUFFIX.
    InputError for what would be ambiguous: several sources or ``out`` a folder without
    ``suffix``, ``out`` a file for a folder, two sources of one name."""
    out = os.fspath(out)
    if suffix is None:
        if len(sources) == 1 and not Path(out).is_dir():
            check_suffix(out, curve_suffixes())
            return [out]
        what = f"{len(sources)} files convert into a folder" if len(sources) > 1 else "a folder"
        raise InputError(
            f"-o {out}: {what}; give --to SUFFIX for the format of the files in it (e.g."
            " --to .usdc: FOLDER/NAME.usdc for each IN NAME.ext)"
        )
    suffix = suffix.lower() if suffix.startswith(".") else f".{suffix.lower()}"
    check_suffix(f"--to {suffix}", curve_suffixes())
    folder = Path(out)
    if (folder.exists() and not folder.is_dir()) or folder.suffix.lower() in curve_suffixes():
        raise InputError(
            f"-o {out}: --to writes a file for each IN into a folder; give -o a folder"
            f" (FOLDER/NAME{suffix} for each IN NAME.ext)"
        )
    return files_in_folder(
        sources,
        folder,
        suffix,
        lambda a, b, target: (
            f"-o {out}: {a} and {b} would both be converted to {target};"
            " give the files different names, or convert them apart"
        ),
    )


def files_in_folder(
    sources: Sequence[str],
    folder: str | os.PathLike[str],
    suffix: str,
    clash: Callable[[str, str, str], str],
) -> list[str]:
    """FOLDER/NAME.SUFFIX for each source NAME.ext, in order; InputError with
    ``clash(first, second, target)`` when two sources would write one file."""
    targets: dict[str, str] = {}
    for source in sources:
        target = str(Path(folder) / f"{Path(source).stem}{suffix}")
        if target in targets:
            raise InputError(clash(targets[target], source, target))
        targets[target] = source
    return list(targets)


def export_skin(source: str, out: str | os.PathLike[str], target: str = "generic") -> SkinMesh:
    """The mesh ``source`` (a file or ``builtin:head``) alone: as a mesh file (.obj, .ply,
    .glb, …) or as the ``/Groom/Skin`` of a USD or Alembic file with no hair, named and
    scaled for ``target``. Returns the mesh written."""
    from .io.mesh_load import load_mesh

    if Path(out).suffix.lower() not in SCENE_SUFFIXES:  # checked before the mesh is read
        check_suffix(out, MESH_FILE_SUFFIXES)
    write = MESH_WRITERS.for_path(out)
    mesh = load_mesh(source)
    write(mesh, out, target=target)
    return mesh


@dataclass(frozen=True)
class CacheExport:
    """What :func:`export_cache` wrote: frames, guides, vertices a guide, fps, and the
    skin: ``"deforming"``, ``"moving"`` or None."""

    frames: int
    strands: int
    vertices: int
    fps: float
    skin: str | None


def export_cache(
    source: str,
    out: str | os.PathLike[str],
    skin: bool = True,
    target: str = "generic",
    progress: Progress | None = None,
) -> CacheExport:
    """The simulation cache ``source`` as animated USD or Alembic at ``out``: the
    simulated guides of every frame as one curves object (a time sample a frame, at the
    cache's fps) and, with ``skin``, the skin mesh of the cache's scene moving with the
    head (its transform sampled per frame, or its vertices where the skin deforms), named,
    typed and scaled for ``target``. ``progress(done, total)`` counts frames."""
    from .io.sim_cache import load_cache

    if Path(out).suffix.lower() not in CACHE_WRITERS:
        raise FormatError(
            f"{source}: a simulation cache exports to animated USD or Alembic; give -o a"
            f" {' / '.join(USD_SUFFIXES)} or .abc file (`follicle render {source} -o frames/`"
            " draws it)"
        )
    write = CACHE_WRITERS.for_path(out)
    cache = load_cache(source)
    mesh = None
    if skin:
        from .io.mesh_load import load_mesh
        from .pipeline import cache_scene, check_cache_skin

        scene = cache_scene(cache)
        mesh = load_mesh(scene.resolve(scene.mesh.path), units=scene.mesh.units)
        check_cache_skin(cache, mesh)
    deforms = skin and cache.skin_vertices is not None

    def frames() -> Iterator[HairCurves]:
        for f, strands in enumerate(cache.positions):
            yield HairCurves.from_array(strands)
            if progress is not None:
                progress(f + 1, cache.frame_count)

    write(
        frames(),
        out,
        fps=cache.fps,
        mesh=mesh,
        role="guides",
        target=target,
        transforms=cache.transforms if skin and not deforms else None,
        skin_vertices=cache.skin_vertices if deforms else None,
    )
    moving = "deforming" if deforms else "moving" if skin else None
    return CacheExport(cache.frame_count, cache.strand_count, cache.vertex_count, cache.fps, moving)
