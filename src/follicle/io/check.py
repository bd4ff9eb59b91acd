"""`follicle check`: a hair file read as a target's tool would read it, and what that
tool would drop or refuse, one line each.

USD and Alembic are read with their attributes as the file names and types them
(:func:`follicle.io.usd.usd_parts`, :func:`follicle.io.alembic.abc_parts` with
``stored``), Alembic in the target's units (it declares none); other formats through
:func:`follicle.io.dispatch.load_curves`. What the reader had to leave out or fix (its
warnings) is part of the list, then :func:`follicle.io.targets.problems`, then, for a
target with a container schema (Unreal), the curves that lack it; then what the
target's importer does with the file's layout (:func:`_layout`): a format its hair
importer does not read (Unity's hair package: Alembic only), guides it would take for
hair (Unity), a mesh that makes it refuse the file (Unreal's groom translator).
Every line ends with its fix (``; fix: …``), mostly the ``follicle export`` that writes
the file for the target.
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Iterator
from pathlib import Path

from ..curves import HairCurves
from ..units import scale_curves
from ..validate import file_path
from .attributes import plausible_widths
from .guard import curves_from_parts
from .targets import Target, export_fix, get_target, problems

__all__ = ["check_file", "nothing_dropped", "warnings_heard"]

log = logging.getLogger("follicle")

_SHOWN = 3  # curves objects named in a line about several


@contextlib.contextmanager
def warnings_heard() -> Iterator[list[str]]:
    """The follicle logger's warnings while the block runs, kept instead of printed."""
    heard: list[str] = []

    class _Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            heard.append(record.getMessage())

    keep = _Keep(logging.WARNING)
    log.addHandler(keep)
    log.propagate = False
    try:
        yield heard
    finally:
        log.removeHandler(keep)
        log.propagate = True


def _without_schema(parts: list[dict], source: Path, target: Target, alembic: bool) -> list[str]:
    """One line for the curves objects that lack ``target``'s container schema."""
    lacking = [p["where"].removeprefix(f"{source}: ") for p in parts if not p["groom_schema"]]
    if not target.groom_schema or not lacking:
        return []
    named = ", ".join(lacking[:_SHOWN]) + (", …" if len(lacking) > _SHOWN else "")
    where = f"{len(lacking)} of {len(parts)} curves objects ({named})"
    if alembic:
        return [
            f"{where}: no groom_version_major / groom_version_minor where {target.tool}"
            " reads them (user properties of the curves or an Xform above): it imports"
            f" their curves without any groom_* attribute; {export_fix(target)} writes them"
        ]
    return [
        f"{where}: no GroomAPI on them or a prim above: {target.tool}'s USD importer does"
        f" not read them as a groom; {export_fix(target)} applies it"
    ]


def _layout(path: Path, suffix: str, parts: list[dict], target: Target) -> list[str]:
    """What ``target``'s importer makes of the file's layout (see the module), one line
    each; ``parts``: its hair curves objects (Alembic and USD)."""
    from ..errors import FollicleError

    t = target
    if t.formats is not None and suffix not in t.formats:
        return [
            f"{t.tool} builds hair from {', '.join(t.formats)} files only ({t.reads}):"
            f" it does not read this one; {export_fix(t, t.formats[0])}"
        ]
    if suffix != ".abc":
        return []
    from .alembic import abc_parts, load_abc_mesh

    out = []
    if not t.guides:
        with contextlib.suppress(FollicleError):
            _, guides = abc_parts(path, guides=True, stored=True)
            if guides and guides[0]["where"] not in {p["where"] for p in parts}:
                out.append(
                    f"guides ({guides[0]['where'].rsplit(': ', 1)[-1]}): {t.tool} takes every"
                    " curves object for hair, so they would become a strand group of their"
                    f" own; {export_fix(t)} leaves them out"
                )
    if not t.alembic_mesh:
        with contextlib.suppress(FollicleError):
            mesh = load_abc_mesh(path)
            out.append(
                f"a mesh ({mesh.name}): {t.tool}'s groom importer refuses an Alembic file"
                f" with any PolyMesh in it; {export_fix(t)} leaves the skin out"
            )
    return out


def _with_fix(warning: str, target: Target) -> str:
    """A reader's warning as a `follicle check` line: ending with its fix, the export
    that writes what follicle read (what the warning says it left out or filled) unless
    the warning names one."""
    return (
        warning
        if "; fix: " in warning
        else f"{warning}; {export_fix(target)} writes what follicle reads"
    )


def check_file(path: str | os.PathLike[str], target: Target | str) -> tuple[HairCurves, list[str]]:
    """(the curves of ``path`` as ``target`` reads them, what it would drop or refuse, one
    line each, without the file's name, each ending with its fix; FollicleError when the
    file cannot be read."""
    from .alembic import abc_parts
    from .dispatch import load_curves
    from .suffixes import USD_SUFFIXES
    from .usd import usd_parts

    path = file_path(path, "check_file path")
    t = get_target(target)
    suffix = Path(path).suffix.lower()
    alembic = suffix == ".abc"
    schema: list[str] = []
    parts: list[dict] = []
    with warnings_heard() as heard:  # what the reader had to leave out or fix
        if suffix in USD_SUFFIXES or alembic:
            source, parts = (abc_parts if alembic else usd_parts)(path, stored=True)
            curves = curves_from_parts(parts, source, stored=True)
            if alembic:  # no unit of its own: the target's (Unreal: centimetres)
                widths = t.width_meters_per_unit or t.meters_per_unit  # Unity's: centimetres
                curves = scale_curves(curves, t.meters_per_unit, widths)
            schema = _without_schema(parts, source, t, alembic)
        else:
            curves = load_curves(path, units=t.meters_per_unit)
        plausible_widths(curves, path)
        layout = _layout(Path(path), suffix, parts, t)
    found = [_with_fix(line.removeprefix(f"{path}: "), t) for line in heard]
    return curves, found + problems(curves, t, alembic=alembic) + schema + layout


def nothing_dropped(path: str | os.PathLike[str], target: Target | str, curves: HairCurves) -> str:
    """The line `follicle check` prints when it found nothing ``target``'s importer
    would drop in ``path`` (``curves``: as it read them): which reader that is. The
    generic target promises no tool's importer: for Alembic it says that Blender's keeps
    points and radius only (Blender's table, :data:`follicle.io.targets.TARGETS`)."""
    from .targets import TARGETS

    t = get_target(target)
    size = f"({curves.curve_count:,} curves, {curves.point_count:,} points)"
    if t.name != "generic":
        return f"{t.tool} reads all of it {size}"
    line = f"a USD or Alembic reader reads all of it {size}"
    blender = TARGETS["blender"]
    if Path(path).suffix.lower() == ".abc" and blender.alembic_reads is not None:
        line += (
            f"; {blender.alembic_importer} keeps only points and"
            f" {', '.join(sorted(blender.alembic_reads))} (`--target blender`)"
        )
    return line
