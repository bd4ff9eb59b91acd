"""USD hair as a root layer and one payload per part: the layout a groom of any size
can be written in side by side.

``fox.usdc`` (or ``.usd``, ``.usda``) is the root layer: the stage metadata, ``/Groom``,
``/Groom/Hair`` (for Unreal's groom schema the Xform with ``GroomAPI``), the guides and
the skin, as :func:`follicle.io.usd.save_usd` writes them, and under ``/Groom/Hair`` one
BasisCurves prim per part, ``part_0000``, ``part_0001``, …, each only a payload arc to
``./fox.usdc.payloads/part_NNNN.usdc``. Each part file is a crate layer of its own (upAxis Y,
metersPerUnit 1) whose default prim is one pinned Catmull-Rom BasisCurves prim holding
the part's hairs, written as ``save_usd`` writes a chunk (extent, widths, normals,
primvars, named and typed for the target tool). USD composes the parts into one stage;
an application may open it with the payloads unloaded and load the parts it wants.

Why: a part file depends only on its own hairs, so the parts of a groom can be written
at the same time by different processes (:func:`follicle.distributed.grow.grow` with
``layout="payloads"``: each Dask worker writes the parts it grows and the client only
the small root layer), and one process writes the same bytes one part after another.

Writing is atomic as a whole: the parts go to a hidden folder beside the root (each
part file itself under a temporary name, so a task run twice leaves one whole file),
the root to a temporary name; then the folder is put in place of ``fox.usdc.payloads/`` and
the root renamed onto ``fox.usdc``. A ``fox.usdc.payloads/`` that holds anything but part
files follicle wrote (checked by their contents, not their names), or that is a symbolic
link, is refused before any hair is grown, never replaced; of an older folder only its
part files are removed.
"""

from __future__ import annotations

import contextlib
import os
import re
import uuid
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from pxr import Sdf, Usd, UsdGeom

from ..atomic import _umask, atomic_path, temporary_folder
from ..curves import HairCurves
from ..errors import FileAccessError, FormatError
from ..validate import file_path
from .animation import target_guides, with_groups
from .stream import Curves, as_chunks
from .targets import Target, for_target, get_target
from .usd import HAIR_PATH, SUFFIXES, _define_curves, _finish, _groom_stage, _writing
from .usd_guard import check_container, payloads_folder

if TYPE_CHECKING:
    from ..mesh.skin import SkinMesh

__all__ = [
    "PART_HAIRS",
    "payloads_folder",
    "part_file",
    "check_payloads_target",
    "written_parts",
    "save_usd_part",
    "save_usd_payloads",
    "finish_payloads",
]

PART_HAIRS = 131_072  # hairs per part file by default: 31 files for 4 M hairs
_PART = re.compile(r"part_\d{4,}\.usdc")


def part_file(folder: str | os.PathLike[str], index: int) -> Path:
    """Part ``index``'s file in ``folder``: ``part_0000.usdc``, …"""
    return Path(folder) / f"part_{index:04d}.usdc"


def check_payloads_target(path: str | os.PathLike[str]) -> Path:
    """``path`` as the root of a payloads layout, refused (FormatError) before any work
    when it is not .usd, .usda or .usdc (a .usdz is one package, not a layer with files
    beside it), when its name has a character a USD asset path cannot hold (the root's
    payload arcs name the folder), or when its payloads folder exists and is anything
    but a folder of part files follicle wrote (:func:`written_parts`): a symbolic link,
    a file, or a folder holding anything else is never replaced."""
    out = Path(file_path(path, "payloads layout path"))
    if out.suffix.lower() == ".usdz":
        raise FormatError(
            f"{out}: a .usdz is one package; the payloads layout writes .usd, .usda or"
            " .usdc with its part files beside it (or write .usdz as one file)"
        )
    if out.suffix.lower() not in SUFFIXES:
        raise FormatError(
            f"{out}: the payloads layout (--layout, [output].layout) writes USD: .usd,"
            " .usda or .usdc; write one of those, or the layout file"
        )
    bad = next((c for c in out.name if _NOT_IN_ASSET_PATH.match(c)), None)
    if bad is not None:
        raise FormatError(
            f"{out}: the name has a character that is not allowed ({bad!r}): the root layer"
            " names its payloads folder by it, and a USD asset path holds no control"
            " characters; give a name without it"
        )
    written_parts(payloads_folder(out))
    return out


# what usd-core refuses in an asset path (Sdf: C0 and C1 control characters), and text
# that is not Unicode (a file name's undecodable bytes)
_NOT_IN_ASSET_PATH = re.compile(r"[\x00-\x1f\x7f-\x9f\ud800-\udfff]")


def written_parts(folder: str | os.PathLike[str]) -> list[Path]:
    """The part files in the payloads folder ``folder`` (none when it is not there),
    each checked by its contents to be one follicle wrote: a regular file named
    ``part_NNNN.usdc`` that is a whole crate layer. FormatError naming the folder when it
    is a symbolic link or a file, or holds anything else (a folder, a link, another
    file): follicle replaces only what it wrote."""
    folder = Path(folder)
    if not os.path.lexists(folder):
        return []
    fix = "it is never replaced: move it away or write elsewhere"
    if folder.is_symlink():
        raise FormatError(
            f"{folder}: exists and is a symbolic link, not a payloads folder follicle wrote; {fix}"
        )
    if not folder.is_dir():
        raise FormatError(f"{folder}: exists and is not a folder; {fix}")
    parts = []
    for entry in os.scandir(folder):
        path = Path(entry.path)
        if entry.is_symlink():
            what = "a symbolic link"
        elif entry.is_dir():
            what = "a folder"
        elif not (entry.is_file() and _PART.fullmatch(entry.name)):
            what = "not a part file (part_NNNN.usdc)"
        elif not _is_part(path):
            what = "not a USD crate follicle wrote"
        else:
            parts.append(path)
            continue
        raise FormatError(
            f"{folder}: exists and holds more than the part files of a payloads layout:"
            f" {entry.name} is {what}; {fix}"
        )
    return sorted(parts)


def _is_part(path: Path) -> bool:
    """Whether ``path`` holds what :func:`save_usd_part` writes, judged without opening it
    in usd-core (a folder given by mistake may hold anything): a whole crate layer, its
    table of contents and sections inside the file."""
    try:
        check_container(path)
    except FormatError:  # FileAccessError too
        return False
    return True


def save_usd_part(
    curves: HairCurves,
    path: str | os.PathLike[str],
    normals: bool = True,
    target: Target | str = "generic",
) -> Path:
    """Write ``curves`` as one part file: a crate layer whose default prim is a pinned
    Catmull-Rom BasisCurves prim named for the file (``part_0003``), named and typed as
    ``target`` reads it; atomically, so a task run twice leaves one whole file. The
    folder must exist (a layout's parts folder, which a task that outlives its job must
    not make again)."""
    out = Path(path)
    if not out.parent.is_dir():
        raise FileAccessError(f"{out.parent}: no such folder for the part {out.name}")
    curves = for_target(curves, get_target(target), in_units=False)
    with _writing(out), atomic_path(out) as tmp:
        stage = Usd.Stage.Open(Sdf.Layer.CreateNew(str(tmp), {"format": "usdc"}))
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        _define_curves(stage, f"/{out.stem}", curves, normals)
        stage.SetDefaultPrim(stage.GetPrimAtPath(f"/{out.stem}"))
        stage.GetRootLayer().Save()
    return out


def finish_payloads(
    path: str | os.PathLike[str],
    staged: Path,
    parts: int,
    guides: object | None = None,
    normals: bool = True,
    mesh: SkinMesh | None = None,
    target: Target | str = "generic",
) -> Path:
    """Write the root layer ``path`` over the ``parts`` part files in ``staged``
    (:func:`part_file` 0 … parts − 1, written by :func:`save_usd_part`), with ``guides``
    and the skin ``mesh`` as :func:`follicle.io.usd.save_usd` has them, then put
    ``staged`` in place as ``path``'s payloads folder and the root onto ``path``."""
    out = check_payloads_target(path)
    tool = get_target(target)
    guide_curves = target_guides(guides, tool, in_units=False)
    folder = payloads_folder(out)
    missing = [i for i in range(parts) if not part_file(staged, i).is_file()]
    if missing:
        raise FormatError(f"{out}: part {missing[0]} of {parts} was not written; grow again")

    def write(crate: Path) -> None:
        layer = _groom_stage(crate, guide_curves, normals, mesh, tool.groom_schema).GetRootLayer()
        # the arcs go in as specs, with no stage open on the layer: one would try to load
        # each payload, which is not in place yet
        for i in range(parts):
            name = part_file(folder, i)
            spec = Sdf.CreatePrimInLayer(layer, f"{HAIR_PATH}/{name.stem}")
            spec.specifier = Sdf.SpecifierDef
            spec.typeName = "BasisCurves"
            spec.payloadList.Prepend(Sdf.Payload(f"./{folder.name}/{name.name}"))
        layer.Save()

    with _writing(out), atomic_path(out) as tmp:
        _finish(out, tmp, write)
        _swap(staged, folder)
    return out


def _swap(staged: Path, folder: Path) -> None:
    """Put ``staged`` where ``folder`` is. An older payloads folder is moved aside first
    and then only the part files follicle wrote in it are removed (checked again now,
    :func:`written_parts`), and the folder itself once it is empty: anything else found
    in it stays, never deleted."""
    os.chmod(staged, 0o777 & ~_umask())  # made private, as a temporary folder is
    parts = written_parts(folder)
    old = None
    if os.path.lexists(folder):
        old = folder.with_name(f".{folder.name}.old-{uuid.uuid4().hex[:8]}")
        os.rename(folder, old)
    os.rename(staged, folder)
    if old is not None:
        for part in parts:
            with contextlib.suppress(OSError):
                os.unlink(old / part.name)
        with contextlib.suppress(OSError):  # not empty: something appeared meanwhile
            os.rmdir(old)


def save_usd_payloads(
    curves: Curves | Iterable[HairCurves],
    path: str | os.PathLike[str],
    guides: object | None = None,
    normals: bool = True,
    mesh: SkinMesh | None = None,
    target: Target | str = "generic",
) -> Path:
    """Write ``curves`` (HairCurves or a stream of chunks) in the payloads layout: chunk
    ``i`` of the stream is part file ``i`` (cut the stream into the parts you want;
    ``follicle grow --layout payloads`` cuts :data:`PART_HAIRS`), the root layer
    ``path`` with the ``guides`` and the skin ``mesh`` over them (see the module)."""
    out = check_payloads_target(path)
    with temporary_folder(out, "payloads") as staged:
        parts = 0
        for i, chunk in enumerate(as_chunks(curves)):
            chunk = with_groups(chunk, guides, get_target(target))
            save_usd_part(chunk, part_file(staged, i), normals, target)
            parts = i + 1
        return finish_payloads(out, staged, parts, guides, normals, mesh, target)
