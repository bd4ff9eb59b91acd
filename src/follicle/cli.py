"""The ``follicle`` command: demo, grow, groom, settle, guides, export, check, export-rib,
batch, simulate, render, view, info, warm, docs, cards.

Every command's help ends with example lines (:func:`_examples`), real commands that
tests/test_cli_help.py parses with the command's own parser.

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
from typing import TYPE_CHECKING, NoReturn, get_args

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
from .validate import check_suffix

if TYPE_CHECKING:
    from .pipeline import SimRun
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
    def _fail(ctx: click.Context, message: str) -> NoReturn:
        """One line, whatever the message holds: control characters (a newline in a file
        name) are shown escaped."""
        line = message.translate(_ESCAPES)
        _err.print(f"[bold red]error:[/] {escape(line)}", soft_wrap=True)
        ctx.exit(2)


_ESCAPES = {c: repr(chr(c))[1:-1] for c in [*range(32), 127]}


class _Count(ProgressColumn):
    """``done/total``, ``done`` alone while the total is not known yet, and nothing
    before the first count: a phase that counts nothing (growing, before the first
    chunk) shows its spinner and time, not a literal 0."""

    def render(self, task: Task) -> Text:
        done = f"{task.completed:,.0f}"
        if task.total is None:
            return Text(done if task.completed else "")
        return Text(f"{done}/{task.total:,.0f}")


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


@contextlib.contextmanager
def _stage(label: str) -> Iterator[Callable[[int, int], None]]:
    """One stage of a library job (:class:`follicle.progress.Stage`): a bar labelled
    ``label`` on a terminal, and its time in the log."""
    with _step(label), _progress(label) as progress:
        yield progress


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
    def choices(self) -> tuple[str, ...]:
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


def _examples(*lines: str) -> str:
    """A command's epilog: its example lines, kept as written (click's ``\\b`` block: no
    rewrapping), each with an optional ``# comment`` and at most 74 characters: indented
    by 4, they fit the 78 columns click fills on an 80-column terminal. They run from the
    repository's root (``examples/…``); some read what another writes (wavy.npz, sim.npz)."""
    title = "Examples:" if len(lines) > 1 else "Example:"
    return "\b\n" + title + "\n" + "\n".join(f"  {line}" for line in lines)


_TARGET_OPTION = click.option(
    "--target",
    "target_name",
    type=_LazyChoice(_target_names),
    default=None,
    help="The tool the USD / Alembic file is for: its attribute names, types and units"
    " (default [output].target, else generic; docs: Formats › Targets).",
)
_SKIN_OPTION = click.option(
    "--skin/--no-skin",
    default=True,
    show_default=True,
    help="Write the skin mesh beside the hair (USD and Alembic).",
)


@click.group(
    cls=_Group,
    context_settings={"help_option_names": ["-h", "--help"]},
    epilog="`follicle COMMAND --help` for one command, with examples. `follicle docs` says"
    " where the documentation is: tutorials, how-to guides and a reference of every"
    " command and scene key (with its type, default, range and unit).\n\n"
    + _examples("follicle demo                     # long hair on a bust: follicle-demo/"),
)
@click.option("-v", "--verbose", count=True, help="Log what happens (-vv for debug).")
@click.version_option(package_name="follicle")
def main(verbose: int) -> None:
    """follicle: grow, simulate and render hair and fur."""
    _handle_signals()
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(name)s: %(message)s", stream=sys.stderr)
    logging.getLogger("follicle").setLevel(level)


_DEMO_SETTLE = 2.0  # s: the long hair comes to rest on the shoulders (docs: How-to › Dynamics)


@main.command(
    short_help="Grow and render long hair on the built-in bust.",
    epilog=_examples(
        "follicle demo --out demo",
        "follicle demo --out short --guides builtin:short --size 640 640",
    ),
)
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
    """Grow long hair on the built-in bust, settled onto its shoulders, and render it:
    DIR/demo.png and DIR/demo.npz."""
    from .io.dispatch import save
    from .pipeline import grow, render_scene
    from .scene import parse_scene

    groom: dict[str, object] = {"settle": _DEMO_SETTLE}
    if count is not None:
        groom["count"] = count
    tables = {
        "guides": {"path": guides},
        "groom": groom,
        "render": {"size": list(size)},
    }
    scene = parse_scene(tables, "demo")
    out = Path(out_dir)
    with _step("grow"), _progress("growing hair") as progress:
        mesh, curves = grow(scene, progress)
    with _step("save"), _progress("saving"):
        save(curves, out / "demo.npz")
    with _step("render"), _progress("rendering"):
        render_scene(curves, mesh, scene.render, out=str(out / "demo.png"))
    click.echo(f"{curves.curve_count:,} hairs → {out / 'demo.png'}, {out / 'demo.npz'}")


@main.command(
    short_help="Grow the hair of a scene file and save the curves.",
    epilog=_examples(
        "follicle grow examples/wavy.toml -o wavy.npz --count 5000",
        "follicle grow examples/wavy.toml -o wavy.usdc --target blender",
    ),
)
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
    from .export import plan_grow

    job = plan_grow(
        scene_path,
        out,
        count=count,
        seed=seed,
        target=target_name,
        skin=skin,
        scheduler=scheduler,
        chunk=chunk,
        layout=layout,
    )
    hairs, points = job.run(_stage)
    click.echo(f"{hairs:,} hairs, {points:,} points → {job.path}")


@main.command(
    short_help="Replay a brush stroke log and save the guides.",
    epilog=_examples("follicle groom examples/hand_groomed.strokes.json -o guides.usda"),
)
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
    """Replay a stroke log (brushes on the guides, docs: Grooming by hand) headless
    and save the guides it makes."""
    from .editing.editor import replay_file
    from .export import curve_suffixes
    from .scene import check_outputs

    check_suffix(out, curve_suffixes())
    given = (("the stroke log", strokes_path), ("--guides", guides), ("--mesh", mesh))
    check_outputs([out, *([groups_out] if groups_out else [])], more=given)
    with _step("groom"):
        editor = replay_file(strokes_path, guides, mesh)
    editor.save(out)
    entries = len(editor.log)
    if groups_out is not None:
        editor.save_groups(groups_out)
        click.echo(f"{editor.groups.count} interpolation groups → {groups_out}")
    click.echo(f"{entries:,} strokes, {editor.guides.count:,} guides → {out}")


@main.command(
    short_help="Settle a scene's guides under gravity and save them.",
    epilog=_examples("follicle settle examples/long_straight.toml -o settled.usda --seconds 2"),
)
@click.argument("scene_path", metavar="SCENE", type=click.Path())
@click.option(
    "-o",
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="Guides file to write (.usda, .npz, .abc, …: any curves format).",
)
@click.option(
    "--seconds", type=float, default=None, help="Override [groom].settle: seconds to settle."
)
def settle(scene_path: str, out: str, seconds: float | None) -> None:
    """Settle a scene's guides under its [sim] dynamics, the head still (gravity, the skin
    and [[sim.colliders]]: long hair falls onto the shoulders and rests), and save them as
    new guides, bound to the same mesh."""
    from .export import plan_settle

    job = plan_settle(scene_path, out, seconds=seconds)
    done = job.run(_stage)
    guides = done.guides
    click.echo(
        f"{guides.count:,} guides × {guides.vertex_count} vertices settled for"
        f" {done.seconds:g} s: max stretch {done.stats['max_stretch']:.2e}, max penetration"
        f" {done.stats['max_penetration'] * 1000:.2f} mm → {out}"
    )


@main.command(
    "guides",
    short_help="Write a scene's guides (read or generated) to a file.",
    epilog=_examples(
        "follicle guides examples/wavy.toml -o guides.usda  # to edit, then read",
        "follicle guides examples/wavy.toml -o guides.npz",
    ),
)
@click.argument("scene_path", metavar="SCENE", type=click.Path())
@click.option(
    "-o",
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="Guides file to write (.usda, .npz, .abc, …: any curves format); it loads back"
    " as [guides] path.",
)
def guides_command(scene_path: str, out: str) -> None:
    """Write the guides a scene grows its hair from ([guides] path, or generated on its
    mesh by [guides] generate) to a curves file, to edit in the viewer or Blender and
    read back as [guides] path = OUT."""
    from .export import plan_guides

    job = plan_guides(scene_path, out)
    with _step("guides"):
        guides = job.run()
    click.echo(f"{guides.count:,} guides × {guides.vertex_count} vertices → {out}")


@main.command(
    short_help="Convert curves or a mesh to another format.",
    epilog=_examples(
        "follicle export wavy.npz -o wavy.abc --target houdini",
        "follicle export builtin:bust -o bust.obj            # the skin mesh alone",
    ),
)
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
    that `follicle grow -o` writes; the docs' Formats page says what each format keeps. A
    simulation cache exports alone, to animated USD or Alembic.

    Several IN are converted one after another, or one Dask task each with --scheduler,
    and each output is renamed into place whole, in the order given, once it and those
    before it are converted: when a file fails, the files before it stay, and it and
    those after it are not written.
    """
    from .export import plan_export

    job = plan_export(
        sources, out, suffix=suffix, target=target_name, skin=skin, scheduler=scheduler
    )
    _keeping(_finished(list(job.targets)))
    done = job.run(_stage)
    if done.mesh is not None:
        mesh = done.mesh
        click.echo(
            f"mesh '{mesh.name}': {len(mesh.rest_vertices):,} vertices,"
            f" {len(mesh.faces):,} triangles → {out}"
        )
    elif done.cache is not None:
        moving = f" with the {done.cache.skin} skin" if done.cache.skin else ""
        click.echo(
            f"{done.cache.frames} frames of {done.cache.strands:,} guides ×"
            f" {done.cache.vertices} vertices at {done.cache.fps:g} fps{moving} → {out}"
        )
    for path, (hairs, points) in zip(job.targets, done.counts, strict=False):
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


@main.command(
    "export-rib",
    short_help="Write a RenderMan RIB that grows hair at render time.",
    epilog=_examples("follicle export-rib examples/wavy.toml -o wavy.rib --voxels 8"),
)
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
    `Procedural "RunProgram"` per voxel, run by follicle-procedural (docs: Formats ›
    Render-time procedural)."""
    from .apps.procedural import export_rib as export
    from .scene import check_outputs, load_scene, scene_with

    scene = scene_with(load_scene(scene_path), "groom", {"count": count, "seed": seed})
    check_suffix(out, (".rib",))
    check_outputs([out, str(Path(out).with_suffix(".follicle.z"))], scene_path, scene)
    with _step("grow and bound"), _progress("bounding voxels") as progress:
        done = export(scene, out, voxels, progress=progress)
    sizes = [p.stat().st_size for p in (done.rib, done.frame)]
    click.echo(
        f"{sum(done.roots):,} hairs in {len(done.voxels)} voxels"
        f" ({'×'.join(map(str, done.grid.dims))} grid) → {done.rib} ({sizes[0]:,} bytes)"
        f" + {done.frame} ({sizes[1]:,} bytes)"
    )


@main.command(
    short_help="Grow, export and render many variants of scenes.",
    epilog=_examples(
        "follicle batch examples/wavy.toml -o out --vary groom.frizz_tip=0:0.004:3",
        "follicle batch -o seeds --seeds 0:4 --count 2000 --size 320 320",
    ),
)
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
    from .distributed.batch import plan_batch

    job = plan_batch(
        scene_paths,
        out,
        vary=vary,
        seeds=seeds,
        count=count,
        curves=curves,
        image=image,
        size=size,
        engine=engine,
        target=target_name,
        skin=skin,
        scheduler=scheduler,
        manifest=manifest_format,
    )
    total = len(job.variants)
    done = [0]
    _keeping(
        lambda: (
            f"the variants finished, {done[0]:,} of {total:,}, in {out} (run the batch again"
            " to make the rest; the manifest is written last)"
            if done[0]
            else None
        )
    )

    @contextlib.contextmanager
    def counted(label: str) -> Iterator[Callable[[int, int], None]]:
        with _stage(label) as progress:

            def report(finished: int, total: int) -> None:
                done[0] = finished
                progress(finished, total)

            yield report

    manifest = job.run(counted)
    click.echo(f"{total:,} variants → {Path(out) / manifest.name}")  # as OUT was given


@main.command(
    short_help="Simulate a scene's guides under a head animation.",
    epilog=_examples("follicle simulate examples/long_straight.toml --motion turn -o sim.npz"),
)
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
    from .simulate_job import plan_simulate

    job = plan_simulate(
        scene_paths,
        out,
        frames=frames,
        fps=fps,
        motion=motion,
        skin_animation=skin_animation,
        count=count,
        scheduler=scheduler,
    )
    if len(job.targets) > 1:
        _keeping(_finished(list(job.targets), "caches"))
    for scene, run, target in job.run(_stage):
        click.echo(_simulated(scene, run, target))


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


@main.command(
    short_help="Render a scene, curves file or cache to PNG or MP4.",
    epilog=_examples(
        "follicle render examples/wavy.toml -o wavy.png --size 640 640",
        "follicle render sim.npz -o frames/ --frames 0:24      # a PNG per frame",
    ),
)
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
    from .render_job import plan_render

    job = plan_render(
        source,
        out,
        mesh=mesh_path,
        size=size,
        engine=engine,
        shading=shading,
        msaa=None if msaa is None else int(msaa),
        spp=spp,
        count=count,
        frames=frame_range,
        scheduler=scheduler,
        frames_per_task=frames_per_task,
    )
    if job.kind == "cache" and not job.video:
        _keeping(_finished(job.outputs, "frames"))
    done = job.run(_stage)
    if done.frames is None:
        click.echo(f"→ {job.target}")
        return
    frames, paths, wall = done.frames, done.paths, done.seconds
    written = (
        paths[0] if job.video else f"{paths[0]}{f' … {paths[-1].name}' if len(paths) > 1 else ''}"
    )
    click.echo(
        f"{len(frames)} frames ({frames.start}–{frames.stop - 1}) of {done.hairs:,} hairs,"
        f" {done.size[0]}×{done.size[1]}, {wall:.2f} s ({len(frames) / wall:.1f} frames/s)"
        f" → {written}"
    )


@main.command(
    short_help="Live viewer with a parameter panel (view extra).",
    epilog=_examples(
        "follicle view examples/long_straight.toml",
        "follicle view examples/wavy.toml --offscreen --frames 9 --screenshot v.png",
    ),
)
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
    panel (docs: The viewer). Needs the view extra: pip install 'follicle[view]'."""
    from .errors import InputError
    from .scene import load_scene, scene_with
    from .view import view as run_viewer

    if offscreen and frames is None:
        raise InputError("--offscreen: give --frames N (there is no window to close)")
    if screenshot is not None:
        check_suffix(screenshot, (".png",))
    scene = scene_with(load_scene(scene_path), "groom", {"count": count})
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


@main.command(
    short_help="Print a scene with its defaults, or describe a file.",
    epilog=_examples(
        "follicle info examples/wavy.toml   # every key: value, [unit], meaning",
        "follicle info wavy.npz",
    ),
)
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


@main.command(
    short_help="Compile follicle's kernels for this machine now.",
    epilog=_examples("follicle warm --jobs 2"),
)
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


@main.command(
    short_help="List what a tool would drop or refuse in a hair file.",
    epilog=_examples(
        "follicle check wavy.abc --target houdini   # exit 0: Houdini reads it all",
        "follicle check wavy.usdc --target unreal   # exit 1: what Unreal drops",
    ),
)
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
    """List, one line each, what TARGET would drop or refuse in a hair file, and its fix.

    Exit 0 when it opens as it is, 1 when problems were found, 2 when FILE cannot be
    read. `follicle export FILE -o OUT --target TARGET` writes what it reads.
    """
    from .io.check import check_file, nothing_dropped
    from .io.targets import TARGETS

    target = TARGETS[target_name]
    curves, found = check_file(source, target)
    for line in found:
        click.echo(f"{source}: {line}".translate(_ESCAPES))
    if found:
        sys.exit(1)
    click.echo(f"{source}: {nothing_dropped(source, target, curves)}".translate(_ESCAPES))


@main.command(short_help="Say where the documentation is.", epilog=_examples("follicle docs"))
def docs() -> None:
    """Say where follicle's documentation is, one fact a line: its site, the Markdown
    source of a source checkout and the mkdocs command that serves it as the site, and
    the help that comes with the commands."""
    from .docs_location import checkout, site_url, where_lines

    for line in where_lines(site_url(), checkout()):
        click.echo(line.translate(_ESCAPES))


def _card_counts(ctx: click.Context, param: click.Parameter, value: str | None) -> tuple | None:
    """``--counts 2000,600,150`` as whole numbers."""
    if value is None:
        return None
    try:
        return tuple(int(v) for v in value.split(","))
    except ValueError:
        raise click.BadParameter(
            f"{value!r}: give whole numbers separated by commas, e.g. 2000,600,150"
        ) from None


@main.command(
    short_help="Turn a scene's hair into hair cards with LODs (glTF, USD).",
    epilog=_examples(
        "follicle cards examples/long_straight.toml -o hair_cards.glb",
        "follicle cards examples/wavy.toml -o cards.usda --counts 600,150",
    ),
)
@click.argument("scene_path", metavar="SCENE", type=click.Path())
@click.option(
    "-o",
    "--out",
    default="hair_cards.glb",
    show_default=True,
    type=click.Path(dir_okay=False),
    help="File to write: glTF binary (.glb), or USD (.usd, .usda, .usdc) with the atlas's"
    " PNGs beside it.",
)
@click.option("--lods", type=int, default=None, help="Levels of detail (default 3).")
@click.option(
    "--counts",
    callback=_card_counts,
    default=None,
    help="Cards per level, finest first (default 2000,600,150).",
)
@click.option("--atlas", type=int, default=None, help="Atlas side, texels (default 2048).")
@click.option(
    "--target",
    type=_choices("CardParams", "target"),
    default=None,
    help="The textures' layout: generic (the glTF material and maps) or unreal (also"
    " PNGs for the groom cards' texture slots beside the file); default generic.",
)
@click.option("--count", type=int, default=None, help="Override [groom].count.")
@click.option("--seed", type=int, default=None, help="Seed of the clustering (default 0).")
def cards(
    scene_path: str,
    out: str,
    lods: int | None,
    counts: tuple | None,
    atlas: int | None,
    target: str | None,
    count: int | None,
    seed: int | None,
) -> None:
    """Grow a scene's hair and turn it into hair cards for game engines: textured strips
    per level of detail and their atlas (colour and coverage, depth, tangent,
    root-to-tip, seed), written as glTF binary or USD. The scene's [cards] section sets
    what the options do not."""
    from .cards import card_path
    from .cards import cards as make
    from .pipeline import grow
    from .scene import load_scene, scene_with

    card_path(out)  # before the hair is grown
    scene = scene_with(load_scene(scene_path), "groom", {"count": count})
    if lods is None and counts is not None:
        lods = len(counts)
    options = {"lods": lods, "counts": counts, "atlas": atlas, "target": target, "seed": seed}
    scene = scene_with(scene, "cards", options)
    with _step("grow"), _progress("growing hair") as progress:
        mesh, curves = grow(scene, progress)
    with _step("cards"):
        made = make(curves, mesh, out=out, params=scene.cards)
    per_lod = " / ".join(f"{len(r):,}" for r in made.rects)
    atlas = scene.cards.atlas
    click.echo(f"{curves.curve_count:,} hairs → {per_lod} cards, {atlas}² atlas → {out}")


if __name__ == "__main__":  # pragma: no cover
    main()
