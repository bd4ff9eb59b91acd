"""Batches of grooms: many variants of scenes grown, exported and rendered, each into a
folder of its own, and a manifest of their parameters and files — the shape of a
synthetic hair dataset (`follicle batch`).

**Variants.** Every scene given, times every combination of the swept values
(:func:`parse_vary`: ``groom.curl_radius=0.002:0.01:5`` is five values, ends included;
``render.shading=kajiya,marschner`` two), times every seed (:func:`parse_seeds`:
``0:100``, the end excluded, sets ``[groom].seed``), in that order: the scene's loop
outermost, the seed's innermost. Variant ``i`` is the folder ``vNNNNN`` (five digits,
more for a larger batch). Each value goes through its section's ``replace``, so a bad
key or value is a ConfigError naming it before anything is grown.

**A variant's folder** holds ``scene.toml`` (the variant's whole scene; its relative
paths start in the source scene's folder, which its first line names), the hair
(``hair.npz``, ``.usdc``, … as the scene's [output].curves or ``--curves`` say; USD
and Alembic with the guides and skin for the target tool), its render ``hair.png``
(the scene's [render] settings, as `follicle render SCENE` draws it) and
``outputs.json``: its hair and point counts and each file's SHA-256. The folder is
written under a temporary name and renamed whole, so a variant is all there or absent;
a retried or speculative twin of a variant's task finds it there and drops its copy.

**The manifest** (``manifest.csv``, or ``manifest.parquet`` for
``manifest="parquet"``, in the batch folder, written last and atomically) has a row per
variant, in variant order: ``variant, source, seed``, one column per swept key,
``hairs, points``, then ``scene``, ``curves`` and ``image`` with each file's path from
the manifest's folder and its ``…_sha256``. The Parquet file (through pyarrow) keeps
each column's type: integers, floats (a swept number exactly as the scene holds it) and
text. It is the same bytes whichever way the batch ran.

**Again after a stop.** Variants already in the folder with the same scene and the
outputs asked for are kept, not made again (their rows read from ``outputs.json``); a
folder holding anything else is an error naming it, never overwritten.

**On a cluster** (``scheduler``, see :func:`follicle.distributed.cluster.connect`) each variant
is one Dask task: a worker grows, writes and renders it into the batch folder, which
every worker must reach; the files are the same bytes as one process writes.
"""

from __future__ import annotations

import csv
import hashlib
import io
import itertools
import json
import math
import os
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel

from ..atomic import atomic_path, deliver, pending_folders
from ..errors import ConfigError, FollicleError
from ..inputs import base_folder, check_apart
from ..progress import Progress, Stage, quietly
from ..scene import Scene, holds_paths, scene_files, scene_from_toml, scene_to_toml
from ..settings import unknown_name

if TYPE_CHECKING:
    from ..pipeline import GroomInputs

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

__all__ = [
    "MANIFESTS",
    "Sweep",
    "Variant",
    "Outputs",
    "parse_vary",
    "parse_seeds",
    "variants",
    "run_batch",
    "plan_batch",
    "BatchJob",
]

MANIFESTS = {"csv": "manifest.csv", "parquet": "manifest.parquet"}
# variants a batch: each holds its scene (about 10 kB) while the batch runs, so 100,000
# take about 1 GB; a dataset beyond is several batches (docs/scale.md)
_MAX_VARIANTS = 100_000
# per process: the groom inputs (mesh, guides, textures) last read, by batch run (its
# pending folder), so variants that differ in other keys share them, within one run only
_INPUTS: dict[str, GroomInputs] = {}


@dataclass(frozen=True)
class Sweep:
    """One swept scene key (``section.key``) and the values it takes, in order."""

    key: str
    values: tuple[object, ...]


@dataclass(frozen=True)
class Variant:
    """One groom of a batch: its folder's ``name``, the ``source`` scene it varies (the
    path as given, or ``default``), its ``seed``, the swept keys' ``values`` and the
    whole ``scene``."""

    name: str
    source: str
    seed: int
    values: tuple[tuple[str, object], ...]
    scene: Scene


@dataclass(frozen=True)
class Outputs:
    """What every variant makes beside its scene.toml: the hair file's ``curves``
    suffix (None for none; :data:`SCENE_SUFFIX` for each scene's [output].curves), a
    PNG ``image`` or not, and for USD / Alembic the ``target`` tool (None: each scene's
    [output].target) and the ``skin`` mesh or not."""

    curves: str | None = "scene"
    image: bool = True
    target: str | None = None
    skin: bool = True


SCENE_SUFFIX = "scene"  # Outputs.curves: each scene's own [output].curves suffix


def parse_vary(text: str) -> Sweep:
    """``KEY=SPEC`` as a :class:`Sweep`: ``KEY`` is ``section.key`` of a scene file;
    ``SPEC`` is ``START:STOP:N`` (N evenly spaced numbers, both ends included; whole
    numbers when START and STOP are and the steps fall on them), ``a,b,c`` (TOML
    values, or bare words as strings) or one value; a SPEC with ``://`` (a URL) is
    never a range. ConfigError naming ``--vary``."""
    key, sep, spec = text.partition("=")
    key, spec = key.strip(), spec.strip()
    if not sep or not key or not spec:
        raise ConfigError(
            f"--vary {text}: expected KEY=START:STOP:N or KEY=a,b,c"
            " (groom.curl_radius=0.002:0.01:5)"
        )
    _field(key)
    parts = spec.split(":")
    if len(parts) == 3 and "://" not in spec:  # a URL's colons make no range
        return Sweep(key, _spaced(text, *parts))
    return Sweep(key, tuple(_value(v.strip()) for v in spec.split(",")))


def parse_seeds(text: str) -> range:
    """``A:B`` (seeds A … B − 1) or one seed ``N``; ConfigError naming ``--seeds``."""
    parts = text.split(":")
    try:
        ends = [int(p) for p in parts if len(p.strip()) <= 20]  # 2^63 has 19 digits
    except ValueError:
        ends = []
    if len(ends) == 1 and len(parts) == 1:
        ends.append(ends[0] + 1)
    if len(ends) != 2 or ends[0] < 0 or ends[1] <= ends[0] or ends[1] > 1 << 63:
        raise ConfigError(
            f"--seeds {_short(text)}: expected A:B with 0 <= A < B <= 2^63 (0:100), or one seed"
        )
    if ends[1] - ends[0] > _MAX_VARIANTS:
        raise ConfigError(
            f"--seeds {text}: {ends[1] - ends[0]:,} seeds, more than {_MAX_VARIANTS:,} variants"
            " a batch; split it into batches of seed ranges"
        )
    return range(*ends)


def variants(
    scenes: Sequence[tuple[str, Scene]],
    sweeps: Sequence[Sweep] = (),
    seeds: Sequence[int] | None = None,
) -> list[Variant]:
    """The variants of a batch (see the module): each ``(source, scene)`` of ``scenes``
    × each combination of the ``sweeps``' values × each of ``seeds`` (None: each
    scene's own seed), every value checked as its section checks it."""
    keys = [s.key for s in sweeps]
    if len(set(keys)) != len(keys):
        raise ConfigError(f"--vary: a key is swept twice ({', '.join(keys)}); sweep each once")
    if seeds is not None and "groom.seed" in keys:
        raise ConfigError("--vary groom.seed and --seeds both set the seed; give one")
    # counted from the sizes before any combination is made
    combos = math.prod(len(s.values) for s in sweeps)
    total = len(scenes) * combos * (1 if seeds is None else len(seeds))
    if total > _MAX_VARIANTS:
        raise ConfigError(
            f"--vary/--seeds: {total:,} variants, more than {_MAX_VARIANTS:,} a batch (each"
            " holds its whole scene while the batch runs); split the batch"
        )
    width = max(5, len(str(total - 1)))
    out: list[Variant] = []
    for source, scene in scenes:
        for combo in itertools.product(*(s.values for s in sweeps)):
            varied = scene
            for key, value in zip(keys, combo, strict=True):
                varied = _with(varied, key, value, _short(f"--vary {key}={value}"))
            for seed in [varied.groom.seed] if seeds is None else seeds:
                if seeds is not None:
                    varied = _with(varied, "groom.seed", seed, f"--seeds {seed}")
                name = f"v{len(out):0{width}d}"
                out.append(
                    Variant(name, source, seed, tuple(zip(keys, combo, strict=True)), varied)
                )
    return out


def run_batch(
    batch: Sequence[Variant],
    out_dir: str | os.PathLike[str],
    outputs: Outputs = Outputs(),
    scheduler: str | None = None,
    progress: Progress | None = None,
    manifest: str = "csv",
) -> Path:
    """Make every variant of ``batch`` into ``out_dir`` (made if need be), here or on
    the Dask cluster ``scheduler``, and write the ``manifest`` (``"csv"`` or
    ``"parquet"``; see the module). Returns the manifest's path; ``progress(done,
    total)`` counts variants as they finish."""
    if not batch:
        raise ConfigError("follicle batch: no variants (give a scene, or values to --vary)")
    if manifest not in MANIFESTS:
        raise ConfigError(f"--manifest {manifest!r}: one of {', '.join(MANIFESTS)}")
    if manifest == "parquet":
        _pyarrow()  # missing: said now, not after the batch
    out = Path(out_dir).resolve()
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out}: not a folder; -o names the batch's folder")
    check_apart([out / MANIFESTS[manifest]], _inputs(batch), fix="give the batch another folder")
    jobs = [_job(v, out, outputs) for v in batch]
    records: list[dict | None] = [
        _kept(out / v.name, job) for v, job in zip(batch, jobs, strict=True)
    ]
    todo = [i for i, r in enumerate(records) if r is None]
    done = len(batch) - len(todo)
    if progress is not None:
        progress(done, len(batch))
    with pending_folders([out]) as pending:
        calls = [(*jobs[i], str(out), pending[out]) for i in todo]
        for i, record in zip(todo, _made(calls, scheduler), strict=False):
            records[i] = record
            done += 1
            if progress is not None:
                progress(done, len(batch))
    path = out / MANIFESTS[manifest]
    header, rows = _manifest(batch, records)
    with atomic_path(path) as tmp:
        if manifest == "csv":
            buffer = io.StringIO()
            table = csv.writer(buffer, lineterminator="\n")
            table.writerows([header, *([_cell(v) for v in row] for row in rows)])
            tmp.write_text(buffer.getvalue(), encoding="utf-8", newline="")
        else:
            _write_parquet(tmp, header, rows)
    return path


@dataclass(frozen=True)
class BatchJob:
    """A checked batch: its ``variants``, made into the folder ``out`` with ``outputs``,
    here or on the Dask cluster ``scheduler``, and its ``manifest`` format. Made by
    :func:`plan_batch`."""

    variants: tuple[Variant, ...]
    out: str
    outputs: Outputs = Outputs()
    scheduler: str | None = None
    manifest: str = "csv"

    def run(self, stage: Stage = quietly) -> Path:
        """:func:`run_batch` under ``stage("making N variants")``: every variant not
        already made, then the manifest, whose path it returns."""
        where = " on Dask" if self.scheduler else ""
        count = len(self.variants)
        with stage(f"making {count:,} variant{'' if count == 1 else 's'}{where}") as progress:
            return run_batch(
                self.variants, self.out, self.outputs, self.scheduler, progress, self.manifest
            )


def plan_batch(
    scene_paths: Sequence[str | None],
    out: str | os.PathLike[str],
    *,
    vary: Sequence[str] = (),
    seeds: str | None = None,
    count: int | None = None,
    curves: str | None = None,
    image: bool = True,
    size: tuple[int, int] | None = None,
    engine: str | None = None,
    target: str | None = None,
    skin: bool = True,
    scheduler: str | None = None,
    manifest: str = "csv",
) -> BatchJob:
    """A checked :class:`BatchJob`, as ``follicle batch SCENE... -o OUT`` runs it; each
    keyword is the command's option of that name (None: not given). ``scene_paths``
    empty is the default scene; ``vary`` are ``KEY=SPEC`` texts (:func:`parse_vary`),
    ``seeds`` ``A:B`` (:func:`parse_seeds`); ``count``, ``size`` and ``engine``
    override each scene's; ``curves`` is the hair file's suffix (``usdc`` or
    ``.usdc``; None: each scene's [output].curves; ``"none"``: no hair file).
    ConfigError, before any variant is made, for a bad key, value or size."""
    from ..scene import load_scene, scene_with

    scenes = []
    for path in scene_paths or (None,):
        scene = scene_with(load_scene(path), "groom", {"count": count})
        scene = scene_with(scene, "render", {"size": size, "engine": engine})
        scenes.append((path or "default", scene))
    sweeps = [parse_vary(v) for v in vary]
    batch = variants(scenes, sweeps, None if seeds is None else parse_seeds(seeds))
    suffix = SCENE_SUFFIX if curves is None else curves.lower()
    if suffix not in ("none", SCENE_SUFFIX) and not suffix.startswith("."):
        suffix = f".{suffix}"  # usdc as well as .usdc
    outputs = Outputs(None if suffix == "none" else suffix, image, target, skin)
    return BatchJob(tuple(batch), os.fspath(out), outputs, scheduler, manifest)


def _inputs(batch: Sequence[Variant]) -> Iterator[tuple[str, str]]:
    """The files the batch reads, as (label, path): each source scene and the files of
    its scene, and each path a variant's swept values give."""
    seen: set[str] = set()
    for variant in batch:
        if variant.source not in seen:
            seen.add(variant.source)
            if variant.source != "default" or os.path.isfile(variant.source):
                yield "the scene", variant.source
            yield from scene_files(variant.scene)
        for key, value in variant.values:
            if isinstance(value, str) and not value.startswith("builtin:") and _is_path(key):
                yield f"--vary {key}", variant.scene.resolve(value)


def _is_path(key: str) -> bool:
    """Whether the scene key ``section.key`` holds file paths."""
    section, name = _field(key)
    return holds_paths(_section_model(section).model_fields[name])


def _section_model(section: str) -> type[BaseModel]:
    """The settings class of the scene's [``section``] (a field of :class:`Scene`)."""
    model = Scene.model_fields[section].annotation
    assert isinstance(model, type) and issubclass(model, BaseModel)  # every section is one
    return model


def _made(calls: list[tuple[Any, ...]], scheduler: str | None) -> Iterator[dict]:
    """Each call's variant made, in call order: here one after another, or as Dask tasks
    on the cluster ``scheduler``, all submitted at once (each writes its own folder
    as it finishes, so a stopped batch keeps every variant made)."""
    if scheduler is None:
        for call in calls:
            yield _make(*call)
        return
    from .cluster import cluster, in_order, submit_all

    with cluster(scheduler) as client:
        yield from in_order(submit_all(client, _variant_task, calls, "batch"))


def _job(variant: Variant, out: Path, outputs: Outputs) -> tuple:
    """A variant's task arguments before the folders: (name, scene TOML, base folder,
    curves suffix or "", image, target, skin)."""
    scene = variant.scene
    suffix = outputs.curves
    if suffix == SCENE_SUFFIX:
        suffix = Path(scene.output.curves).suffix.lower()
    target = outputs.target or scene.output.target
    if suffix:
        _check_curves(variant, suffix, target)
        if scene.output.layout != "file":  # its parts would escape the manifest's hashes
            raise ConfigError(
                f"{variant.source}: [output].layout = {scene.output.layout!r}: a batch"
                ' writes one curves file per variant; set it to "file" for the batch'
            )
    header = f"# follicle batch {variant.name} of {variant.source}; relative paths start in"
    text = f"{header} {_shown_path(scene.base_dir)}\n{scene_to_toml(scene, comments=False)}"
    return (
        variant.name,
        text,
        str(scene.base_dir),
        suffix or "",
        outputs.image,
        target,
        outputs.skin,
    )


def _check_curves(variant: Variant, suffix: str, target: str) -> None:
    """The hair file's suffix writable and ``target`` meant for it (as `follicle grow`
    checks them), before anything is grown."""
    from ..io.dispatch import WRITERS
    from ..io.targets import check_named

    if suffix not in WRITERS:
        raise ConfigError(
            f"--curves {suffix}: not a curves format follicle writes; one of"
            f" {', '.join(sorted(WRITERS))}, or none"
        )
    check_named(f"{variant.source} (--curves {suffix})", suffix, target)


def _shown_path(path: Path | str) -> str:
    """A scene's folder as a variant's first line names it: a local folder absolute, a
    URL (a scene served from another machine) as it is; control characters escaped."""
    shown = path if isinstance(path, str) else str(path.resolve())
    return json.dumps(shown, ensure_ascii=False)[1:-1]


def _kept(folder: Path, job: tuple) -> dict | None:
    """The record of a variant already made in ``folder`` by an earlier run of the same
    batch; None when there is none; ConfigError when the folder holds anything else."""
    if not os.path.lexists(folder):
        return None
    _, text, _, suffix, image, _, _ = job
    try:
        same = (folder / "scene.toml").read_text(encoding="utf-8") == text
        record = json.loads((folder / "outputs.json").read_text(encoding="utf-8"))
        files = record["files"]
        wanted = {"scene": "scene.toml"}
        if suffix:
            wanted["curves"] = f"hair{suffix}"
        if image:
            wanted["image"] = "hair.png"
        ok = same and all(files.get(r, [None])[0] == name for r, name in wanted.items())
        ok = ok and all((folder / name).is_file() for name in wanted.values())
    except (OSError, ValueError, KeyError, TypeError, IndexError, AttributeError):
        ok = False
    if not ok:
        raise ConfigError(
            f"{folder}: holds something other than this batch's variant (another scene or"
            " other outputs); remove it, or give the batch another folder (-o)"
        )
    return {**record, "files": {r: files[r] for r in wanted}}


def _variant_task(*call: Any) -> dict:
    """A Dask worker's task: one variant made (:func:`_make`)."""
    from .cluster import on_worker, task_setup

    task_setup()
    with on_worker():
        return _make(*call)


def _make(
    name: str,
    text: str,
    base_dir: str,
    suffix: str,
    image: bool,
    target: str,
    skin: bool,
    out: str,
    pending: str,
) -> dict:
    """Grow the variant ``text`` and write its folder ``out/name`` (through the batch's
    ``pending`` folder); returns its record (outputs.json). A FollicleError names the
    variant."""
    try:
        return _made_into(name, text, base_dir, suffix, image, target, skin, out, pending)
    except FollicleError as exc:
        raise type(exc)(f"batch variant {name}: {exc}") from None


def _made_into(
    name: str,
    text: str,
    base_dir: str,
    suffix: str,
    image: bool,
    target: str,
    skin: bool,
    out: str,
    pending: str,
) -> dict:
    """:func:`_make`'s work, its errors not yet naming the variant."""
    from ..io.dispatch import save
    from ..io.targets import writer_extras
    from ..pipeline import groom_inputs, groom_scene, render_scene
    from .grow import target_chunk

    scene = scene_from_toml(text, f"{name}/scene.toml", base_folder(base_dir))
    inputs = groom_inputs(scene, _INPUTS.get(pending))
    _INPUTS.clear()  # one batch's, one set at a time
    _INPUTS[pending] = inputs
    groom = groom_scene(scene, inputs)
    curves = groom.generate()
    record: dict = {"hairs": curves.curve_count, "points": curves.point_count, "files": {}}

    def write(folder: Path) -> None:
        folder.mkdir()
        files = {"scene": "scene.toml"}
        (folder / "scene.toml").write_text(text, encoding="utf-8")
        if suffix:
            files["curves"] = f"hair{suffix}"
            path = folder / files["curves"]
            mesh = groom.mesh if skin else None
            extras = writer_extras(path, target, groom.guides, mesh)
            save(target_chunk(groom, curves, target), path, **extras)
        if image:
            files["image"] = "hair.png"
            render_scene(curves, groom.mesh, scene.render, out=str(folder / files["image"]))
        record["files"] = {role: [f, _sha256(folder / f)] for role, f in files.items()}
        (folder / "outputs.json").write_text(json.dumps(record, sort_keys=True) + "\n")

    deliver(pending, Path(out) / name, write)
    return record


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _manifest(
    batch: Sequence[Variant], records: Sequence[dict | None]
) -> tuple[list[str], list[list[object]]]:
    """The manifest's header and a row of values per variant (see the module)."""
    keys = [k for k, _ in batch[0].values]
    roles = [r for r in ("scene", "curves", "image") if r in (records[0] or {})["files"]]
    header = ["variant", "source", "seed", *keys, "hairs", "points"]
    header += [c for r in roles for c in (r, f"{r}_sha256")]
    rows = []
    for variant, record in zip(batch, records, strict=True):
        assert record is not None
        files = record["files"]
        rows.append(
            [variant.name, variant.source, variant.seed]
            + [v for _, v in variant.values]
            + [record["hairs"], record["points"]]
            + [c for r in roles for c in (f"{variant.name}/{files[r][0]}", files[r][1])]
        )
    return header, rows


def _cell(value: object) -> object:
    """A CSV cell: a float as Python writes it back exactly (repr)."""
    return repr(value) if isinstance(value, float) else value


def _pyarrow() -> Any:  # pyarrow ships no types
    """pyarrow, or ConfigError saying how to get it."""
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401 - the writer, a submodule
    except ImportError:
        raise ConfigError(
            "--manifest parquet: needs pyarrow; pip install pyarrow (or use --manifest csv)"
        ) from None
    return pyarrow


def _write_parquet(path: Path, header: list[str], rows: list[list[object]]) -> None:
    """The manifest as a Parquet table at ``path``, each column typed by its values (a
    swept key whose values mix kinds, e.g. numbers and words, is text)."""
    pa = _pyarrow()
    columns = {}
    for i, name in enumerate(header):
        values = [row[i] for row in rows]
        try:
            columns[name] = pa.array(values)
        except (pa.ArrowInvalid, pa.ArrowTypeError):
            columns[name] = pa.array([str(_cell(v)) for v in values])
    pa.parquet.write_table(pa.table(columns), path)


def _field(key: str) -> tuple[str, str]:
    """``section.key`` of a scene file, checked: (section, key)."""
    section, _, name = key.partition(".")
    field = Scene.model_fields.get(section)
    sections = [k for k, f in Scene.model_fields.items() if not f.exclude]
    if not name:  # a bare key: the sections that have it
        owners = [f"{s}.{key}" for s in sections if key in _section_model(s).model_fields]
        hint = (
            f"did you mean {' or '.join(owners)}?" if owners else f"sections: {', '.join(sections)}"
        )
        raise ConfigError(f"--vary {key}: expected section.key; {hint}")
    if field is None or field.exclude:
        raise ConfigError(
            f"--vary {key}: [{section}]: {unknown_name(section, sections, 'section')}"
        )
    fields = list(_section_model(section).model_fields)
    if name not in fields:
        raise ConfigError(f"--vary {key}: [{section}].{name}: {unknown_name(name, fields)}")
    return section, name


def _with(scene: Scene, key: str, value: object, source: str) -> Scene:
    """``scene`` with ``section.key`` set to ``value``, validated by its section."""
    section, name = _field(key)
    params = getattr(scene, section).replace(source, **{name: value})
    return scene.replace(source, **{section: params})


def _value(text: str) -> object:
    """A swept value: a TOML value (``0.5``, ``true``, ``"a b"``, ``[1, 2]``), else the
    text itself as a string (a bare word: ``marschner``)."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except (tomllib.TOMLDecodeError, ValueError, RecursionError):
        return text


def _short(text: str) -> str:
    """``text`` as an error message shows it: at most 80 characters."""
    return text if len(text) <= 80 else f"{text[:77]}..."


def _spaced(text: str, start: str, stop: str, count: str) -> tuple[object, ...]:
    """``START:STOP:N``: N evenly spaced numbers from START to STOP, ends included."""
    ends = [_value(start.strip()), _value(stop.strip())]
    numbers = [v for v in ends if isinstance(v, (int, float)) and not isinstance(v, bool)]
    n = _value(count.strip())
    if (
        len(numbers) != 2
        or not isinstance(n, int)
        or isinstance(n, bool)
        or not 1 <= n <= _MAX_VARIANTS
    ):
        raise ConfigError(
            f"--vary {_short(text)}: START:STOP:N takes two numbers and a count of 1 to"
            f" {_MAX_VARIANTS:,}"
        )
    a, b = numbers
    if any(isinstance(v, int) and abs(v) >= 1 << 63 for v in (a, b)) or not (
        math.isfinite(a) and math.isfinite(b)
    ):
        raise ConfigError(
            f"--vary {_short(text)}: START and STOP must be finite (whole numbers within ±2^63)"
        )
    if n == 1:
        return (a,)
    whole = isinstance(a, int) and isinstance(b, int) and (b - a) % (n - 1) == 0
    if whole:
        step = (b - a) // (n - 1)
        return tuple(a + i * step for i in range(n))
    return (*(a + (b - a) * i / (n - 1) for i in range(n - 1)), b)  # STOP itself, exactly
