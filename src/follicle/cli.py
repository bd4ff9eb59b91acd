"""The ``follicle`` command: demo, grow, groom, export, check, export-rib, simulate, render,
view, info, warm.

Bad input (a FollicleError) prints one line naming the file/key and exits 2, with no
traceback and no output file. Progress bars show on a terminal only; ``-v`` logs.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, get_args

import click
from rich.console import Console
from rich.markup import escape
from rich.progress import (
    BarColumn,
    Progress,
    ProgressColumn,
    SpinnerColumn,
    Task,
    TextColumn,
    TimeElapsedColumn,
)
from rich.text import Text

from .errors import FollicleError

if TYPE_CHECKING:
    from .io.sim_cache import SimCache
    from .pipeline import SimRun
    from .render.backends import Engine
    from .scene import Scene

log = logging.getLogger("follicle")
_err = Console(stderr=True, highlight=False)


class _Group(click.Group):
    """Turns FollicleError, and an operating-system refusal (a folder where a file should
    go, no permission, a full disk), into one clear line and exit code 2."""

    def invoke(self, ctx: click.Context) -> object:
        try:
            return super().invoke(ctx)
        except FollicleError as exc:
            self._fail(ctx, str(exc))
        except click.UsageError as exc:  # a subcommand's options or arguments
            hint = f" (see {exc.ctx.command_path} --help)" if exc.ctx else ""
            self._fail(ctx, f"{exc.format_message()}{hint}")
        except OSError as exc:
            where = f"{exc.filename}: " if exc.filename else ""
            self._fail(ctx, f"{where}{exc.strerror or exc}")

    @staticmethod
    def _fail(ctx: click.Context, message: str) -> None:
        """One line, whatever the message holds: control characters (a newline in a file
        name) are shown escaped."""
        line = message.translate(_ESCAPES)
        _err.print(f"[bold red]error:[/] {escape(line)}", soft_wrap=True)
        ctx.exit(2)


_ESCAPES = {c: repr(chr(c))[1:-1] for c in [*range(32), 127]}


class _Count(ProgressColumn):
    """``done/total``, or ``done`` alone while the total is not known yet."""

    def render(self, task: Task) -> Text:
        done = f"{task.completed:,.0f}"
        return Text(done if task.total is None else f"{done}/{task.total:,.0f}")


@contextlib.contextmanager
def _progress(label: str) -> Iterator[Callable[[int, int], None]]:
    """A progress callback (done, total): a rich bar on a terminal, silence when piped.

    Before the first report the bar spins with the time elapsed; while numba compiles a
    kernel (a source install's first run, :mod:`follicle.kernels`) it says which, so the
    wait is never a silent one."""
    if not _err.is_terminal:
        yield lambda done, total: None
        return
    from .kernels import compile_listener

    columns = (
        SpinnerColumn(),
        TextColumn("{task.description}"),
        BarColumn(),
        _Count(),
        TimeElapsedColumn(),
    )
    with Progress(*columns, console=_err, transient=True) as bar:
        task = bar.add_task(label, total=None)

        def report(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total, description=label)

        def compiling(name: str, count: int) -> None:
            what = name.rsplit(".", 1)[-1]
            bar.update(task, description=f"{label} (compiling kernel {count}, {what}, once)")

        with compile_listener(compiling):
            yield report


@contextlib.contextmanager
def _step(what: str) -> Iterator[None]:
    start = time.perf_counter()
    yield
    log.info("%s in %.2f s", what, time.perf_counter() - start)


# what the running command has finished and keeps when a signal stops it: a function
# that says so in a few words ("3 of 10 variants in out/"), or says None for nothing yet
_kept: list[Callable[[], str | None]] = []


def _keeping(note: Callable[[], str | None]) -> None:
    """From now on, a signal's line says ``note()``: the outputs finished and kept."""
    _kept[:] = [note]


def _interrupted(signum: int, frame: object) -> None:
    """Ctrl-C or SIGTERM: remove the outputs being written and end at once, exit 128 + the
    signal's number, saying what was kept (the outputs a command finished before it,
    :func:`_keeping`) or that no output was written. Exiting here, rather than raising
    KeyboardInterrupt, works also when the signal lands inside numba's compiled code,
    where an exception cannot unwind."""
    import multiprocessing
    import signal

    from .atomic import remove_pending

    logging.disable(logging.CRITICAL)  # what a local scheduler logs of its dying workers
    nanny = sys.modules.get("distributed.nanny")  # a local Dask cluster's, if one runs:
    for each in list(nanny.Nanny._instances) if nanny is not None else []:
        each.status = sys.modules["distributed.core"].Status.closing  # no worker restarted
    for _ in range(2):  # its workers, and one its nanny may have started meanwhile, …
        children = multiprocessing.active_children()
        for child in children:
            child.kill()
        for child in children:  # … gone before their parts' folder goes
            child.join(timeout=5)
    remove_pending()
    name = signal.Signals(signum).name
    try:
        note = _kept[0]() if _kept else None
    except Exception:  # noqa: BLE001 - the line must come out whatever the note does
        note = "some outputs finished before it (see the output folder)"
    what = f"kept {note}, the output being written removed" if note else "no output was written"
    sys.stderr.write(f"\nerror: stopped by {name}; {what.translate(_ESCAPES)}\n")
    sys.stderr.flush()
    os._exit(128 + signum)


def _handle_signals() -> None:
    """SIGINT and SIGTERM end a command alike (temporary outputs removed, exit 130 / 143),
    and a file-size limit (SIGXFSZ) no longer kills the process: the write fails with
    EFBIG, which ends in one line naming the file and exit 2, like a full disk."""
    import signal

    signal.signal(signal.SIGINT, _interrupted)
    signal.signal(signal.SIGTERM, _interrupted)
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)


class _LazyChoice(click.Choice):
    """A :class:`click.Choice` whose values are made when first needed (a command's
    ``--help``, or checking a value), so that ``follicle --help`` imports none of the
    settings models and formats they come from."""

    def __init__(self, make: Callable[[], tuple[str, ...]]) -> None:
        self._make = make
        self._values: tuple[str, ...] | None = None
        self.case_sensitive = True

    @property
    def choices(self) -> tuple[str, ...]:  # type: ignore[override]
        if self._values is None:
            self._values = self._make()
        return self._values

    @choices.setter
    def choices(self, values: tuple[str, ...]) -> None:
        self._values = tuple(values)


def _choices(model: str, key: str, *more: str) -> _LazyChoice:
    """The values a scene key of Literal type takes (``model``: RenderParams or
    SimParams), and ``more``, as the CLI offers them."""

    def make() -> tuple[str, ...]:
        from . import scene

        field = getattr(scene, model).model_fields[key]
        return (*(str(v) for v in get_args(field.annotation)), *more)

    return _LazyChoice(make)


def _target_names() -> tuple[str, ...]:
    from .io.targets import TARGET_NAMES

    return TARGET_NAMES


def _scheduler_option(what: str, per: str, same: str, reach: str = "") -> Callable:
    """A command's ``--scheduler`` option: ``what`` it does on a Dask cluster (``per``:
    how the work splits into tasks), that ``same`` byte for byte, and what every worker
    must ``reach``."""
    must = f" Every worker must reach {reach}." if reach else ""
    return click.option(
        "--scheduler",
        default=None,
        metavar="ADDRESS|local:N",
        help=f"{what} on a Dask cluster{per}: a scheduler's address, or local:N for N worker"
        f" processes here; {same}, byte for byte (needs follicle[dist]).{must}",
    )


_TARGET_OPTION = click.option(
    "--target",
    "target_name",
    type=_LazyChoice(_target_names),
    default=None,
    help="The tool the USD / Alembic file is for: its attribute names, types and units"
    " (default [output].target, else generic; README: Formats, Targets).",
)
_SKIN_OPTION = click.option(
    "--skin/--no-skin",
    default=True,
    show_default=True,
    help="Write the skin mesh beside the hair (USD and Alembic).",
)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("-v", "--verbose", count=True, help="Log what happens (-vv for debug).")
@click.version_option(package_name="follicle")
def main(verbose: int) -> None:
    """follicle: grow, simulate and render hair and fur."""
    _handle_signals()
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(name)s: %(message)s", stream=sys.stderr)
    logging.getLogger("follicle").setLevel(level)


@main.command()
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False),
    default="follicle-demo",
    show_default=True,
    help="Folder for demo.png and demo.npz.",
)
@click.option("--count", type=int, default=None, help="Number of hairs (default 20,000).")
@click.option(
    "--guides",
    default="builtin:long",
    show_default=True,
    help="Guide set: builtin:long, builtin:short or builtin:curly.",
)
@click.option(
    "--size", type=(int, int), default=(960, 960), show_default=True, help="Image width and height."
)
def demo(out_dir: str, count: int | None, guides: str, size: tuple[int, int]) -> None:
    """Grow hair on the built-in head and render it: DIR/demo.png and DIR/demo.npz."""
    from .io.dispatch import save
    from .pipeline import grow, render_scene
    from .scene import parse_scene

    groom: dict[str, object] = {}
    if count is not None:
        groom["count"] = count
    scene = parse_scene(
        {"guides": {"path": guides}, "groom": groom, "render": {"size": list(size)}}, "demo"
    )
    out = Path(out_dir)
    with _step("grow"), _progress("growing hair") as progress:
        mesh, curves = grow(scene, progress)
    with _step("save"), _progress("saving"):
        save(curves, out / "demo.npz")
    with _step("render"), _progress("rendering"):
        render_scene(curves, mesh, scene.render, out=str(out / "demo.png"))
    click.echo(f"{curves.curve_count:,} hairs → {out / 'demo.png'}, {out / 'demo.npz'}")


@main.command()
@click.argument("scene_path", metavar="SCENE", type=click.Path())
@click.option(
    "-o",
    "--out",
    type=click.Path(dir_okay=False),
    default=None,
    help="Output curves file: .npz, or .hair, .tfx, .obj, .pbrt, .txt (Mitsuba), …"
    " written chunk by chunk as the hair grows; default [output].curves of the"
    " scene.",
)
@click.option("--count", type=int, default=None, help="Override [groom].count.")
@click.option("--seed", type=int, default=None, help="Override [groom].seed.")
@_TARGET_OPTION
@_SKIN_OPTION
@_scheduler_option("Grow", "", "the file is the same")
@click.option(
    "--chunk",
    type=int,
    default=None,
    help="Hairs per Dask task with --scheduler (default 32768); with --layout payloads,"
    " hairs per part file (default 131072), one task each.",
)
@click.option(
    "--layout",
    type=click.Choice(["file", "payloads"]),
    default=None,
    help="USD as one file, or as a root layer with one payload per part file in"
    " OUT.payloads/ beside it (written side by side by the workers of --scheduler);"
    " default [output].layout of the scene, file.",
)
def grow(
    scene_path: str,
    out: str | None,
    count: int | None,
    seed: int | None,
    target_name: str | None,
    skin: bool,
    scheduler: str | None,
    chunk: int | None,
    layout: str | None,
) -> None:
    """Grow the hair of a scene file and save the curves.

    Formats other than .npz are streamed: the hair is grown and written in chunks, so
    memory stays bounded whatever the count. USD and Alembic files also get the guides
    and the skin mesh, named and typed for the --target tool.
    """
    from .scene import load_scene

    scene = _with_overrides(load_scene(scene_path), count=count, seed=seed)
    path = out or scene.output_path(scene.output.curves)
    from .export import check_suffix, curve_suffixes

    check_suffix(path, curve_suffixes())
    tool = target_name or scene.output.target
    _check_target(path, tool)
    layout = layout or scene.output.layout
    if chunk is not None and chunk < 1:
        raise FollicleError(f"--chunk {chunk}: give a whole number of hairs ≥ 1")
    if chunk is not None and scheduler is None and layout == "file":
        raise FollicleError(
            "--chunk: sizes the Dask tasks of --scheduler, or the part files of --layout"
            " payloads; give one of them"
        )
    if layout == "payloads":
        from .io.usd_payloads import check_payloads_target, payloads_folder

        check_payloads_target(path)  # before any hair is grown
        _check_apart(path, scene_path, scene, folders=[payloads_folder(path)])
    else:
        _check_apart(path, scene_path, scene)
    from .export import grow_file

    where = " on Dask" if scheduler is not None else ""
    with _step(f"grow{where}"), _progress(f"growing hair{where}") as progress:
        hairs, points = grow_file(scene, path, tool, skin, scheduler, chunk, layout, progress)
    click.echo(f"{hairs:,} hairs, {points:,} points → {path}")


@main.command()
@click.argument("strokes_path", metavar="STROKES", type=click.Path())
@click.option("--guides", default=None, help="Guides to start from (default: the log's).")
@click.option(
    "--mesh", default=None, help="Skin mesh of the guides (default: the log's, else builtin:head)."
)
@click.option(
    "-o", "--out", required=True, type=click.Path(), help="Guides file to write (.usda, .npz, …)."
)
@click.option(
    "--groups",
    "groups_out",
    default=None,
    type=click.Path(),
    help="Also write the interpolation groups (a part brush paints them) as a PNG.",
)
def groom(
    strokes_path: str, guides: str | None, mesh: str | None, out: str, groups_out: str | None
) -> None:
    """Replay a stroke log (brushes on the guides, README: Grooming by hand) headless
    and save the guides it makes."""
    from .editing.editor import replay_file
    from .export import check_suffix, curve_suffixes

    check_suffix(out, curve_suffixes())
    given = (("the stroke log", strokes_path), ("--guides", guides), ("--mesh", mesh))
    _check_apart([out, *([groups_out] if groups_out else [])], None, more=given)
    with _step("groom"):
        editor = replay_file(strokes_path, guides, mesh)
    editor.save(out)
    entries = len(editor.log)
    if groups_out is not None:
        editor.save_groups(groups_out)
        click.echo(f"{editor.groups.count} interpolation groups → {groups_out}")
    click.echo(f"{entries:,} strokes, {editor.guides.count:,} guides → {out}")


def _check_target(path: str, target: str) -> None:
    """``--target`` only for the formats that carry names (:func:`check_named`)."""
    from .io.targets import check_named

    check_named(path, Path(path).suffix, target, "--target")


def _check_apart(
    outputs: str | os.PathLike[str] | list,
    source: str | None,
    scene: Scene | None = None,
    more: tuple[tuple[str, str | None], ...] = (),
    folders: list | tuple = (),
) -> None:
    """Before anything is read: InputError when an output would replace an input of the
    same run, the scene file ``source`` or a file the ``scene`` reads (its mesh, guides,
    textures, skin animation), or one of ``more`` ((label, path or None) pairs; see
    :func:`follicle.inputs.check_apart`)."""
    from .inputs import check_apart
    from .scene import scene_files

    inputs = [("the scene", source)] if source else []
    inputs += scene_files(scene) if scene is not None else []
    inputs += [(label, path) for label, path in more if path]
    outs = [outputs] if isinstance(outputs, (str, os.PathLike)) else outputs
    check_apart(outs, inputs, folders)


@main.command()
@click.argument("sources", metavar="IN...", nargs=-1, required=True, type=click.Path())
@click.option(
    "-o",
    "--out",
    required=True,
    type=click.Path(),
    help="Output file; its extension picks the format (.npz, .hair, .tfx, .obj,"
    " .pbrt, .txt, .usd*, .abc, …; for a mesh .obj, .ply, .glb, .stl, .off). For several"
    " IN, or with --to, a folder (made if need be): NAME.SUFFIX in it for each IN NAME.ext.",
)
@click.option(
    "--to",
    "suffix",
    default=None,
    metavar="SUFFIX",
    help="The format of the files written into the folder -o: .usdc, .abc, .hair, … (any"
    " that `follicle grow -o` writes); needed for several IN.",
)
@_TARGET_OPTION
@_SKIN_OPTION
@_scheduler_option(
    "Convert the curves files",
    ", one task per file",
    "the files are the same",
    "the IN files and the folder",
)
def export(
    sources: tuple[str, ...],
    out: str,
    suffix: str | None,
    target_name: str | None,
    skin: bool,
    scheduler: str | None,
) -> None:
    """Convert a curves file to another format, e.g. hair.npz -o hair.hair, or a mesh,
    e.g. builtin:head -o head.obj; or many curves files into a folder, e.g.
    a.abc b.abc -o usd/ --to .usdc.

    Any extension `follicle info` reads (.npz, .hair, .tfx, .obj, .usd, .abc, …) to any
    that `follicle grow -o` writes; README § Formats says what each format keeps. A
    simulation cache exports alone, to animated USD or Alembic.

    Several IN are converted one after another, or one Dask task each with --scheduler,
    and each output is renamed into place whole, in the order given, once it and those
    before it are converted: when a file fails, the files before it stay, and it and
    those after it are not written.
    """
    from .distributed.export import convert
    from .export import check_suffix, curve_suffixes, export_cache, export_skin, mesh_only
    from .io.mesh_load import BUILTIN_MESHES
    from .io.sim_cache import is_cache

    tool = target_name or "generic"
    if len(sources) > 1 or suffix is not None or scheduler is not None or Path(out).is_dir():
        _export_files(sources, out, suffix, tool, scheduler)
        return
    source = sources[0]
    _check_apart(out, None, more=(("its own input", source),))
    if (
        source.startswith("builtin:")
        and source[len("builtin:") :] in BUILTIN_MESHES
        or mesh_only(out)
    ):
        mesh = export_skin(source, out, tool)
        click.echo(
            f"mesh '{mesh.name}': {len(mesh.rest_vertices):,} vertices,"
            f" {len(mesh.faces):,} triangles → {out}"
        )
        return

    check_suffix(out, curve_suffixes())
    _check_target(out, tool)
    if is_cache(source):
        with _step("export"), _progress("writing frames") as progress:
            done = export_cache(source, out, skin, tool, progress)
        moving = f" with the {done.skin} skin" if done.skin else ""
        click.echo(
            f"{done.frames} frames of {done.strands:,} guides × {done.vertices} vertices"
            f" at {done.fps:g} fps{moving} → {out}"
        )
        return
    hairs, points = convert(source, out, tool)
    click.echo(f"{hairs:,} hairs, {points:,} points → {out}")


def _export_files(
    sources: tuple[str, ...], out: str, suffix: str | None, target: str, scheduler: str | None
) -> None:
    """`follicle export IN... -o FOLDER --to SUFFIX`: the curves files converted, here or
    on the Dask cluster ``scheduler``, with a line for each."""
    from .distributed.export import export_files
    from .export import export_targets

    targets = export_targets(sources, out, suffix)
    _check_target(targets[0], target)
    where = " on Dask" if scheduler else ""
    with _step(f"export{where}"), _progress(f"converting files{where}") as progress:
        _keeping(_finished(targets))
        done = export_files(sources, targets, scheduler, target, progress)
    for path, (hairs, points) in zip(targets, done, strict=True):
        click.echo(f"{hairs:,} hairs, {points:,} points → {path}")


def _finished(paths: list, noun: str = "files") -> Callable[[], str | None]:
    """A note for :func:`_keeping`: those of ``paths`` this run has put in place since
    now (new, or replaced: another file than now), in a few words, or None."""

    def stamp(path: str) -> tuple[int, int] | None:
        try:
            st = os.stat(path)
        except (OSError, ValueError):
            return None
        return st.st_ino, st.st_mtime_ns

    names = [str(p) for p in paths]
    before = {name: stamp(name) for name in names}

    def note() -> str | None:
        new = [n for n in names if (now := stamp(n)) is not None and now != before[n]]
        if not new:
            return None
        first = f"{new[0]} … {Path(new[-1]).name}" if len(new) > 1 else new[0]
        return f"the {len(new):,} of {len(names):,} {noun} finished ({first})"

    return note


@main.command("export-rib")
@click.argument("scene_path", metavar="SCENE", type=click.Path())
@click.option(
    "-o",
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="Output .rib; the frame file is written beside it (.follicle.z).",
)
@click.option(
    "--voxels",
    type=int,
    default=8,
    show_default=True,
    help="Voxel cells along the rest mesh's longest side (cubic cells, 1–256).",
)
@click.option("--count", type=int, default=None, help="Override [groom].count.")
@click.option("--seed", type=int, default=None, help="Override [groom].seed.")
def export_rib(scene_path: str, out: str, voxels: int, count: int | None, seed: int | None) -> None:
    """Write a RenderMan RIB that grows the scene's hair at render time: one
    `Procedural "RunProgram"` per voxel, run by follicle-procedural (README § Formats)."""
    from .apps.procedural import export_rib as export
    from .scene import load_scene

    scene = _with_overrides(load_scene(scene_path), count=count, seed=seed)
    from .export import check_suffix

    check_suffix(out, (".rib",))
    _check_apart([out, str(Path(out).with_suffix(".follicle.z"))], scene_path, scene)
    with _step("grow and bound"), _progress("bounding voxels") as progress:
        done = export(scene, out, voxels, progress=progress)
    sizes = [p.stat().st_size for p in (done.rib, done.frame)]
    click.echo(
        f"{sum(done.roots):,} hairs in {len(done.voxels)} voxels"
        f" ({'×'.join(map(str, done.grid.dims))} grid) → {done.rib} ({sizes[0]:,} bytes)"
        f" + {done.frame} ({sizes[1]:,} bytes)"
    )


@main.command()
@click.argument("scene_paths", metavar="[SCENE]...", nargs=-1, type=click.Path())
@click.option(
    "-o",
    "--out",
    required=True,
    type=click.Path(file_okay=False),
    help="The batch's folder: a folder per variant (v00000, …) and manifest.csv.",
)
@click.option(
    "--vary",
    multiple=True,
    metavar="KEY=START:STOP:N|a,b,c",
    help="Sweep a scene key: N values from START to STOP (ends included), or a list;"
    " repeat for a grid (--vary groom.curl_radius=0.002:0.01:5).",
)
@click.option("--seeds", default=None, metavar="A:B", help="Seeds A … B-1 for [groom].seed.")
@click.option("--count", type=int, default=None, help="Override [groom].count.")
@click.option(
    "--curves",
    default=None,
    metavar="SUFFIX|none",
    help="Hair file of each variant: .npz, .usdc, .abc, .hair, … (default each scene's"
    " [output].curves), or none.",
)
@click.option("--image/--no-image", default=True, show_default=True, help="Render hair.png.")
@click.option("--size", type=(int, int), default=None, help="Image width and height.")
@click.option(
    "--engine",
    type=_choices("RenderParams", "engine"),
    default=None,
    help="Render engine (default [render].engine).",
)
@_TARGET_OPTION
@_SKIN_OPTION
@_scheduler_option(
    "Make the variants",
    ", one task each",
    "the files are the same",
    "the scenes' files and the batch's folder",
)
@click.option(
    "--manifest",
    "manifest_format",
    type=click.Choice(["csv", "parquet"]),
    default="csv",
    show_default=True,
    help="manifest.csv, or manifest.parquet with typed columns (needs pyarrow).",
)
def batch(
    scene_paths: tuple[str, ...],
    out: str,
    vary: tuple[str, ...],
    seeds: str | None,
    count: int | None,
    curves: str | None,
    image: bool,
    size: tuple[int, int] | None,
    engine: str | None,
    target_name: str | None,
    skin: bool,
    scheduler: str | None,
    manifest_format: str,
) -> None:
    """Grow, export and render many variants of scenes (the default scene if none): each
    scene × every combination of --vary values × each of --seeds, each into a folder of
    its own, with a manifest of parameters, files and SHA-256s. Run it again after a stop
    and it keeps the variants already made."""
    from .distributed.batch import (
        SCENE_SUFFIX,
        Outputs,
        parse_seeds,
        parse_vary,
        run_batch,
        variants,
    )
    from .scene import load_scene

    render = {k: v for k, v in {"size": size, "engine": engine}.items() if v is not None}
    scenes = []
    for path in scene_paths or (None,):
        scene = _with_overrides(load_scene(path), count=count)
        if render:
            scene = scene.replace(render=scene.render.replace("command line", **render))
        scenes.append((path or "default", scene))
    sweeps = [parse_vary(v) for v in vary]
    batch_ = variants(scenes, sweeps, None if seeds is None else parse_seeds(seeds))
    suffix = SCENE_SUFFIX if curves is None else curves.lower()
    if suffix not in ("none", SCENE_SUFFIX) and not suffix.startswith("."):
        suffix = f".{suffix}"  # --curves usdc as well as .usdc
    outputs = Outputs(None if suffix == "none" else suffix, image, target_name, skin)
    where = " on Dask" if scheduler else ""
    with _step(f"batch{where}"), _progress(f"making {len(batch_):,} variants{where}") as progress:
        done = [0]
        _keeping(
            lambda: (
                f"the variants finished, {done[0]:,} of {len(batch_):,}, in {out} (run the"
                " batch again to make the rest; the manifest is written last)"
                if done[0]
                else None
            )
        )

        def counted(finished: int, total: int) -> None:
            done[0] = finished
            progress(finished, total)

        manifest = run_batch(batch_, out, outputs, scheduler, counted, manifest_format)
    click.echo(f"{len(batch_):,} variants → {manifest}")


@main.command()
@click.argument("scene_paths", metavar="SCENE...", nargs=-1, required=True, type=click.Path())
@click.option(
    "-o",
    "--out",
    type=click.Path(),
    default=None,
    help="Output cache (.npz); default sim.npz in the scene's folder. For several scenes,"
    " a folder: NAME.npz in it for each scene NAME.toml.",
)
@click.option(
    "--frames",
    type=int,
    default=48,
    show_default=True,
    help="Frames to store; frame 0 is the rest state.",
)
@click.option("--fps", type=float, default=24.0, show_default=True, help="Frames per second.")
@click.option(
    "--motion",
    type=_choices("SimParams", "motion"),
    default=None,
    help="Head animation, overrides [sim].motion: turn (look left and back), nod,"
    ' shake (a fading "no"); each takes [sim].motion_period, then holds still.',
)
@click.option(
    "--skin-animation",
    type=click.Path(dir_okay=False),
    default=None,
    help="USD or Alembic file animating the skin mesh (time-sampled points), overrides"
    " [sim].skin_animation and the scene's motion: the roots follow the deforming skin.",
)
@click.option(
    "--count",
    type=int,
    default=None,
    help="Override [groom].count: the hairs `follicle render` grows from the cache.",
)
@_scheduler_option("Simulate", ", one task per scene", "each cache is the same")
def simulate(
    scene_paths: tuple[str, ...],
    out: str | None,
    frames: int,
    fps: float,
    motion: str | None,
    skin_animation: str | None,
    count: int | None,
    scheduler: str | None,
) -> None:
    """Simulate the guide hairs of scenes under a head or skin animation; save a cache each.

    Writes the guides of every frame, the head transforms (or the animated skin's
    vertices) and the scene itself (.npz); `follicle render CACHE.npz -o FOLDER` grows
    and renders the hair of each frame. Several scenes are simulated one after another,
    or side by side on a Dask cluster with --scheduler.
    """
    from .io.sim_cache import write_cache
    from .pipeline import timed_simulation

    scenes = [_sim_scene(path, count, motion, skin_animation) for path in scene_paths]
    targets = _cache_targets(scene_paths, scenes, out)
    for path, scene in zip(scene_paths, scenes, strict=True):
        _check_apart(targets, path, scene)
    if len(targets) > 1:
        _keeping(_finished(targets, "caches"))
    if scheduler is not None:
        from .distributed.simulate import simulate_scenes

        with _step("simulate on Dask"), _progress("simulating scenes on Dask") as progress:
            runs = simulate_scenes(scenes, targets, scheduler, frames, fps, progress)
        for scene, run, target in zip(scenes, runs, targets, strict=True):
            click.echo(_simulated(scene, run, target))
        return
    for scene, target in zip(scenes, targets, strict=True):
        with _step("simulate"), _progress("simulating") as progress:
            cache, run = timed_simulation(scene, frames, fps, progress)
        with _step("save"):
            write_cache(cache, target)
        click.echo(_simulated(scene, run, target))


def _sim_scene(
    path: str, count: int | None, motion: str | None, skin_animation: str | None
) -> Scene:
    """The scene file ``path`` with `follicle simulate`'s overrides."""
    from .scene import load_scene

    scene = _with_overrides(load_scene(path), count=count)
    changes: dict[str, object] = {} if motion is None else {"motion": motion}
    if skin_animation is not None:  # it replaces the scene's motion, not one given here
        from .inputs import is_url

        given = skin_animation if is_url(skin_animation) else os.path.abspath(skin_animation)
        changes = {"motion": "none", **changes, "skin_animation": given}
    if changes:
        scene = scene.replace(sim=scene.sim.replace("command line", **changes))
    return scene


def _cache_targets(paths: tuple[str, ...], scenes: list[Scene], out: str | None) -> list[str]:
    """Where `follicle simulate` writes each scene's cache: ``out`` (default sim.npz in the
    scene's folder) for one scene; for several, ``out`` must be a folder, and scene
    NAME.toml goes to OUT/NAME.npz. InputError for what would be ambiguous: several
    scenes without -o, or with -o a file, or two scenes of one name."""
    from .errors import InputError

    if len(paths) == 1:
        target = out or scenes[0].output_path("sim.npz")
        from .export import check_suffix

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
            f"-o {out}: {len(paths)} scenes write a cache each; give -o a folder"
            " (FOLDER/NAME.npz for each scene NAME.toml)"
        )
    targets: dict[str, str] = {}
    for path in paths:
        target = str(folder / f"{Path(path).stem}.npz")
        if target in targets:
            raise InputError(
                f"-o {out}: scenes {targets[target]} and {path} would both write {target};"
                " give the scene files different names"
            )
        targets[target] = path
    return list(targets)


def _simulated(scene: Scene, run: SimRun, target: str) -> str:
    """The line `follicle simulate` prints for a scene simulated into ``target``."""
    steps = run.frames - 1
    stepping = run.seconds - run.setup
    rate = f"{steps / stepping:.1f} frames/s" if steps else "no steps"
    moved = scene.sim.motion if scene.sim.skin_animation is None else "skin animation"
    return (
        f"{run.frames} frames at {run.fps:g} fps ({moved}),"
        f" {run.strands} guides × {run.vertices} vertices,"
        f" {run.seconds:.2f} s ({rate} after {run.setup:.2f} s of set-up);"
        f" max stretch {run.stats['max_stretch']:.2%},"
        f" max penetration {run.stats['max_penetration'] * 1000:.2f} mm → {target}"
    )


@main.command()
@click.argument("source", metavar="SCENE|CURVES|CACHE", type=click.Path())
@click.option(
    "-o",
    "--out",
    type=click.Path(),
    default=None,
    help="Output PNG; default [output].image of the scene, or CURVES with .png. For a"
    " CACHE, a folder of frame_0000.png, … or an .mp4 video; default CACHE's name +"
    " _frames.",
)
@click.option(
    "--mesh",
    "mesh_path",
    default=None,
    help="Mesh to draw under a curves file (e.g. builtin:head).",
)
@click.option("--size", type=(int, int), default=None, help="Image width and height.")
@click.option(
    "--engine",
    type=_choices("RenderParams", "engine"),
    default=None,
    help="auto (default: opengl on a GPU, else cpu), opengl, cpu (follicle's strand"
    " rasterizer) or mitsuba: a path-traced reference still (pbr extra)"
    " [default: [render].engine].",
)
@click.option(
    "--shading",
    type=_choices("RenderParams", "shading"),
    default=None,
    help="Hair shading (opengl).",
)
@click.option(
    "--msaa",
    type=_choices("RenderParams", "msaa"),
    default=None,
    help="Multisample anti-aliasing samples (opengl).",
)
@click.option(
    "--spp", type=int, default=None, help="Samples per pixel (mitsuba; default [render].spp, 64)."
)
@click.option(
    "--count", type=int, default=None, help="Override [groom].count (a scene or a cache)."
)
@click.option(
    "--frames",
    "frame_range",
    default=None,
    metavar="START:STOP",
    help="A cache's frames to render, STOP excluded (0:24, 10:, or one frame: 5); default all.",
)
@_scheduler_option(
    "Render a cache's frames",
    "",
    "the PNGs (or the MP4) are the same",
    "CACHE and the output's folder",
)
@click.option(
    "--frames-per-task",
    type=int,
    default=None,
    help="Consecutive frames per Dask task with --scheduler (default: the frames shared"
    " into 4 tasks per worker).",
)
def render(
    source: str,
    out: str | None,
    mesh_path: str | None,
    size: tuple[int, int] | None,
    engine: str | None,
    shading: str | None,
    msaa: str | None,
    spp: int | None,
    count: int | None,
    frame_range: str | None,
    scheduler: str | None,
    frames_per_task: int | None,
) -> None:
    """Render a scene (grown on the fly) or a saved curves file to PNG, or each frame of a
    simulation cache (`follicle simulate`) to a PNG sequence or an MP4, seen through one
    camera. `--engine mitsuba` path-traces a still with Mitsuba 3 instead."""
    from .inputs import default_output
    from .io.dispatch import load_curves
    from .io.mesh_load import load_mesh
    from .io.sim_cache import is_cache
    from .pipeline import grow as grow_scene
    from .pipeline import render_scene
    from .scene import Scene, load_scene

    overrides = {
        k: v
        for k, v in {
            "size": size,
            "shading": shading,
            "msaa": None if msaa is None else int(msaa),
            "spp": spp,
            "engine": engine,
        }.items()
        if v is not None
    }
    if frames_per_task is not None:
        from .validate import whole

        if scheduler is None:
            raise FollicleError(
                "--frames-per-task: sizes the Dask tasks of --scheduler; give --scheduler"
            )
        whole(frames_per_task, "--frames-per-task", 1)
    if is_cache(source):
        _not_for(source, "a simulation cache", mesh=mesh_path)
        _engine_takes(source, engine or "auto", shading, msaa, spp, cache=True)
        _render_cache(source, out, overrides, count, frame_range, scheduler, frames_per_task)
        return
    from .export import check_suffix

    scene = Scene()
    if Path(source).suffix.lower() == ".toml":
        scene = _with_overrides(load_scene(source), count=count)
    params = scene.render.replace("command line", **overrides)
    chosen = _engine_takes(source, params.engine, shading, msaa, spp)
    if Path(source).suffix.lower() == ".toml":
        target = out or scene.output_path(scene.output.image)
        check_suffix(target, (".png",))
        _check_apart(target, source, scene, more=(("--mesh", mesh_path),))
        _not_for(source, "a scene", frames=frame_range, scheduler=scheduler)
        with _step("grow"), _progress("growing hair") as progress:
            mesh, curves = grow_scene(scene, progress)
        if mesh_path is not None:
            mesh = load_mesh(mesh_path)
    else:
        target = out or default_output(source, ".png")
        check_suffix(target, (".png",))
        _check_apart(target, None, more=(("the curves file", source), ("--mesh", mesh_path)))
        _not_for(source, "a curves file", count=count, frames=frame_range, scheduler=scheduler)
        curves = load_curves(source)
        mesh = load_mesh(mesh_path) if mesh_path else None
    with _step("render"), _progress("path tracing (%)" if chosen.spp else "rendering") as progress:
        render_scene(curves, mesh, params, out=target, progress=progress)
    click.echo(f"→ {target}")


def _engine_takes(
    source: str,
    name: str,
    shading: str | None,
    msaa: str | None,
    spp: int | None,
    cache: bool = False,
) -> Engine:
    """The engine ``name``, after an InputError for an option it does not take, or for a
    simulation cache (``cache``) when it draws stills only: its capability flags in the
    engine registry (:mod:`follicle.render.backends`)."""
    from .errors import InputError
    from .render.backends import ENGINES, get_engine

    engine = get_engine(name)
    given = {"shading": shading, "msaa": msaa, "spp": spp}
    takes = {"shading": engine.shading, "msaa": engine.msaa, "spp": engine.spp}
    for option, value in given.items():
        if value is not None and not takes[option]:
            raise InputError(f"{source}: --{option} does not apply to --engine {engine.name}")
    if cache and not engine.sequences:
        raster = ", ".join(e.name for e in ENGINES.values() if e.sequences)
        raise InputError(
            f"{source}: --engine {engine.name} renders stills; render a simulation cache"
            f" with --engine {raster}"
        )
    return engine


def _render_cache(
    source: str,
    out: str | None,
    overrides: dict[str, object],
    count: int | None,
    frame_range: str | None,
    scheduler: str | None,
    frames_per_task: int | None,
) -> None:
    """`follicle render CACHE`: every (or --frames) frame to OUT/frame_0000.png, …, or to
    the video OUT.mp4 (frames encoded as they are rendered), here or on the Dask cluster
    ``scheduler`` in tasks of ``frames_per_task`` frames."""
    from .errors import InputError
    from .inputs import default_output
    from .io.sim_cache import load_cache
    from .pipeline import cache_scene, frame_name, render_cache

    cache = load_cache(source)
    frames = _frame_range(frame_range, cache.frame_count)
    scene = _with_overrides(cache_scene(cache), count=count)
    scene = scene.replace(render=scene.render.replace("command line", **overrides))
    target = Path(out or default_output(source, "_frames"))
    video = target.suffix.lower() == ".mp4"
    if not video and (target.suffix.lower() == ".png" or target.is_file()):
        raise InputError(
            f"{target}: a simulation cache renders to a folder of frame_0000.png, … or to an"
            " .mp4 video; give -o a folder or a .mp4 file"
        )
    written = [target] if video else [target / frame_name(cache, f) for f in frames]
    _check_apart(written, None, scene, more=(("the cache", source),))
    if not video:
        _keeping(_finished(written, "frames"))
    start = time.perf_counter()
    if scheduler is not None:
        from .distributed import render as distributed_render

        on_dask = distributed_render.render_video if video else distributed_render.render_cache
        with _step("render on Dask"), _progress("rendering frames on Dask") as progress:
            paths = on_dask(cache, target, scheduler, scene, frames, frames_per_task, progress)
    else:
        with _step("render"), _progress("rendering frames") as progress:
            if video:
                _cache_video(cache, target, scene, frames, progress)
            else:
                paths = render_cache(cache, target, scene, frames, progress)
    wall = time.perf_counter() - start
    w, h = scene.render.size
    written = target if video else f"{paths[0]}{f' … {paths[-1].name}' if len(paths) > 1 else ''}"
    click.echo(
        f"{len(frames)} frames ({frames.start}–{frames.stop - 1}) of {scene.groom.count:,} hairs,"
        f" {w}×{h}, {wall:.2f} s ({len(frames) / wall:.1f} frames/s) → {written}"
    )


def _cache_video(
    cache: SimCache, target: Path, scene: Scene, frames: range, progress: Callable[[int, int], None]
) -> None:
    """Frames of ``cache`` as an H.264 MP4 at the cache's fps, handed to the encoder as
    they are rendered. The rendering starts when the encoder asks for the first frame,
    after it has checked the path, the fps and that ffmpeg is there."""
    from .pipeline import render_frames
    from .render.video import write_mp4

    images = (image for _, image in render_frames(cache, scene, frames, progress))
    write_mp4(images, target, cache.fps)


def _frame_range(text: str | None, count: int) -> range:
    """``--frames`` START:STOP (STOP excluded; either may be left out) or N, within a cache
    of ``count`` frames."""
    from .errors import InputError

    if text is None:
        return range(count)
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
    """InputError when a command-line option that does not apply to ``what`` was given."""
    from .errors import InputError

    given = [name for name, value in options.items() if value is not None]
    if given:
        raise InputError(f"{source}: --{given[0]} does not apply to {what}")


@main.command()
@click.argument("scene_path", metavar="[SCENE]", type=click.Path(), required=False)
@click.option(
    "--frames",
    type=int,
    default=None,
    help="Run this many frames, then exit (default: until the window closes).",
)
@click.option(
    "--screenshot",
    type=click.Path(dir_okay=False),
    default=None,
    help="Write the last frame's render to this PNG.",
)
@click.option(
    "--size",
    type=(int, int),
    default=(960, 540),
    show_default=True,
    help="Render width and height.",
)
@click.option(
    "--fps",
    type=float,
    default=30.0,
    show_default=True,
    help="Simulated frames per second (each frame steps 1/fps s).",
)
@click.option("--count", type=int, default=None, help="Override [groom].count (displayed hairs).")
@click.option(
    "--offscreen", is_flag=True, help="No window or panel: run the loop headless (needs --frames)."
)
@click.option(
    "--quality",
    type=click.Choice(["full", "fast"]),
    default="full",
    show_default=True,
    help="fast: no MSAA, no shadows, one curve step per segment.",
)
@click.option(
    "--hold-fps",
    type=float,
    default=None,
    help="Hold this frame rate by drawing fewer, wider hairs when a frame is slow (0: off;"
    " default 15 in an open-ended session, off with --frames, whose frames are then"
    " the same every run).",
)
def view(
    scene_path: str | None,
    frames: int | None,
    screenshot: str | None,
    size: tuple[int, int],
    fps: float,
    count: int | None,
    offscreen: bool,
    quality: str,
    hold_fps: float | None,
) -> None:
    """Live viewer: the scene's hair simulated and rendered in a window, with a parameter
    panel (README § Viewer). Needs the view extra: pip install 'follicle[view]'."""
    from .errors import InputError
    from .scene import load_scene
    from .view import view as run_viewer

    if offscreen and frames is None:
        raise InputError("--offscreen: give --frames N (there is no window to close)")
    if screenshot is not None:
        from .export import check_suffix

        check_suffix(screenshot, (".png",))
    scene = _with_overrides(load_scene(scene_path), count=count)
    ctl = run_viewer(
        scene,
        frames,
        screenshot,
        size,
        fps,
        window=not offscreen,
        quality=quality,
        source=scene_path,
        hold_fps=(15.0 if frames is None else 0.0) if hold_fps is None else hold_fps,
    )
    w, h = size
    s = ctl.stats()
    click.echo(
        f"{ctl.frame} frames of {s['hairs']:,} hairs from {s['guides']:,} guides,"
        f" {w}×{h}: {ctl.loop_fps:.2f} frames/s (last frame: step {s['step_ms']:.0f} ms,"
        f" groom {s['groom_ms']:.0f} ms, render {s['render_ms']:.0f} ms,"
        f" {s['lod']:.0%} of the hairs drawn)" + (f" → {screenshot}" if screenshot else "")
    )


@main.command()
@click.argument("source", metavar="SCENE|CURVES", type=click.Path(), required=False)
def info(source: str | None) -> None:
    """Print a scene with every default filled in, or describe a curves file."""
    from .io.dispatch import load_curves
    from .io.sim_cache import is_cache
    from .pipeline import describe_cache
    from .scene import load_scene, scene_to_toml

    if source is not None and is_cache(source):
        click.echo(describe_cache(source))
        return
    if source is not None and Path(source).suffix.lower() != ".toml":
        curves = load_curves(source)
        click.echo(repr(curves))
        return
    click.echo(scene_to_toml(load_scene(source)), nl=False)


@main.command()
@click.option(
    "--jobs", type=int, default=None, help="Processes compiling at once (default: the CPUs)."
)
@click.option(
    "--force",
    is_flag=True,
    help="Compile for this machine even where this install's prebuilt kernels run.",
)
def warm(jobs: int | None, force: bool) -> None:
    """Compile follicle's kernels for this machine now, all of them, on every core, so
    that no later command waits for numba. A wheel ships them prebuilt; this is for a
    source install, another numba, or a CPU the prebuilt ones do not cover."""
    import subprocess
    import tempfile

    from .errors import FollicleError
    from .kernels.cache import shipped_level
    from .validate import whole

    if jobs is not None:
        whole(jobs, "--jobs", 1)
    level = shipped_level()
    if level is not None and not force:
        click.echo(f"nothing to compile: this install's prebuilt kernels ({level}) run here")
        return
    start = time.perf_counter()
    command = [sys.executable, "-m", "follicle.prebuild", "warm"]
    # the tasks' messages go to a file, not a pipe that nobody reads while they run
    with tempfile.TemporaryFile("w+") as log:
        proc = subprocess.Popen(
            [*command, *([] if jobs is None else ["--jobs", str(jobs)])],
            stdout=subprocess.PIPE,
            stderr=log,
            text=True,
        )
        assert proc.stdout is not None
        with _progress("compiling follicle's kernels for this machine") as progress:
            total = 0
            for line in proc.stdout:
                word, _, rest = line.strip().partition(" ")
                if word == "tasks":
                    total = int(rest)
                    progress(0, total)
                elif "/" in word:
                    progress(int(word.split("/")[0]), total)
        proc.wait()
        log.seek(0)
        errors = log.read()
    if proc.returncode != 0:
        last = [line for line in errors.splitlines() if line.strip()][-1:] or ["no message"]
        raise FollicleError(f"follicle warm: a task of the workload failed: {last[0]}")
    click.echo(
        f"compiled follicle's kernels for this machine in {time.perf_counter() - start:.0f} s;"
        " later commands load them"
    )


@main.command()
@click.argument("source", metavar="FILE", type=click.Path())
@click.option(
    "--target",
    "target_name",
    type=_LazyChoice(_target_names),
    default="generic",
    show_default=True,
    help="The tool that will open FILE.",
)
def check(source: str, target_name: str) -> None:
    """List, one line each, what TARGET would drop or refuse in a hair file.

    Exit 0 when it opens as it is, 1 when problems were found, 2 when FILE cannot be
    read. `follicle export FILE -o OUT --target TARGET` writes what it reads.
    """
    from .io.check import check_file
    from .io.targets import TARGETS

    target = TARGETS[target_name]
    curves, found = check_file(source, target)
    for line in found:
        click.echo(f"{source}: {line}".translate(_ESCAPES))
    if found:
        sys.exit(1)
    click.echo(
        f"{source}: {target.tool} reads all of it ({curves.curve_count:,} curves,"
        f" {curves.point_count:,} points)".translate(_ESCAPES)
    )


def _with_overrides(scene: Scene, **groom: object) -> Scene:
    """``scene`` with the non-None [groom] values from the command line applied."""
    changes = {k: v for k, v in groom.items() if v is not None}
    if changes:
        scene = scene.replace(groom=scene.groom.replace("command line", **changes))
    return scene


if __name__ == "__main__":  # pragma: no cover
    main()
