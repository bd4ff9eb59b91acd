"""Scene files: TOML with [mesh] [guides] [groom] [sim] [render] [output] [cards] sections.

Every section is a pydantic model that forbids unknown keys, so a typo is an error
naming the key instead of a silently ignored setting. Relative paths are resolved
against the scene file's folder. ``scene_to_toml`` writes a scene back out, with every
default filled in (``follicle info``).

This is the composition root of the settings: each section lives beside its subsystem
(``GroomParams`` in :mod:`follicle.groom.settings`, ``SimParams`` and ``ColliderParams``
in :mod:`follicle.sim.settings`, ``RenderParams`` and ``LightParams`` in
:mod:`follicle.render.settings`, ``CardParams`` in :mod:`follicle.cards.settings`, the
base classes in :mod:`follicle.settings`); the scene puts them together, and every name
is importable from here as well.
"""

from __future__ import annotations

import math
import os
import sys
import types
import typing
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

from pydantic import (
    BaseModel,
    Field,
    PlainValidator,
    PrivateAttr,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic.fields import FieldInfo

from .cards.settings import CardParams
from .errors import ConfigError, FileAccessError
from .groom.settings import GroomParams, GuideLength, PropertyTag
from .inputs import check_apart, input_file, is_remote, is_url, remote_reach
from .io.targets import TARGET_NAMES
from .render.settings import LightParams, RenderParams
from .settings import (
    StrictSection,
    Unit,
    Vec3,
    format_errors,
    measured_in,
    shown,
    unit_of,
    unknown_name,
)
from .sim.settings import ColliderParams, SimParams
from .units import UNITS, metres_per_unit, units_for
from .validate import file_path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

__all__ = [
    "Scene",
    "MeshParams",
    "GuidesParams",
    "GroomParams",
    "SimParams",
    "ColliderParams",
    "RenderParams",
    "LightParams",
    "OutputParams",
    "PropertyTag",
    "holds_paths",
    "load_scene",
    "parse_scene",
    "scene_files",
    "scene_paths",
    "scene_with",
    "check_outputs",
    "scene_to_toml",
    "MAX_SCENE_BYTES",
]

# a scene file is a few kB; 1 MiB bounds the time tomllib (pure Python, ~3 s a MiB of
# numbers here) can spend on a file given by mistake or malice
MAX_SCENE_BYTES = 1 << 20


def _units(value: object) -> str | float:
    """A ``units`` value as given ("cm", or a number as float), else the reason why not."""
    metres_per_unit(value, key=None)
    return value if isinstance(value, str) else float(value)  # type: ignore[arg-type]


def _units_apply(value: str | float, info: ValidationInfo) -> str | float:
    """``units`` other than metres only for a file without a unit of its own (not for a
    builtin, nor USD or glTF): checked against the section's ``path``, unless [guides]
    generates its guides (GuidesParams refuses ``units`` with ``generate``)."""
    if "path" in info.data and info.data.get("generate") is None:
        units_for(info.data["path"], value, key=None)
    return value


# "m", "cm", "mm", "in" or metres per unit (follicle.units), as written in the scene; a
# name, not a path (the viewer's save_scene rewrites keys typed str)
UnitName = Literal["m", "cm", "mm", "in"]  # UNITS' names spelled out for a type checker
if typing.get_args(UnitName) != tuple(UNITS):  # pragma: no cover - a programming error
    raise RuntimeError(f"UnitName {typing.get_args(UnitName)} is not UNITS' {tuple(UNITS)}")
UnitsSetting = Annotated[UnitName | float, PlainValidator(_units, json_schema_input_type=Any)]
_UNITS_HELP = (
    'the file\'s units, converted to metres when loaded: "m", "cm", "mm",'
    ' "in" or metres per unit; not for builtins or USD/glTF (they declare theirs)'
)


class MeshParams(StrictSection):
    """The skin the hair grows on."""

    _section: ClassVar[str] = "mesh"

    path: str = Field(
        "builtin:bust",
        description="mesh file (OBJ/PLY/GLB/STL, USD, Alembic), builtin:bust (a head on"
        " shoulders) or builtin:head (the head alone, older scenes')",
    )
    units: UnitsSetting = Field("m", description=_UNITS_HELP)
    _units_fit_path = field_validator("units")(_units_apply)
    displacement: str | None = Field(
        None, description="displacement map (image path): roots sit on P + scale·D(uv)·N"
    )
    displacement_scale: float = Field(
        1.0, ge=-10, le=10, description="displacement in scene units per texture unit"
    )


# the [guides] keys that make guides (generate) and those that read them (path)
_GENERATE_KEYS = ("count", "length", "vertices", "comb", "lift", "gravity", "seed")
_PATH_KEYS = ("path", "units")


class GuidesParams(StrictSection):
    """The guide curves every hair is interpolated from: read from ``path``, or made on
    the mesh (``generate``: :func:`follicle.groom.starter.generate_guides`).

    A scene whose mesh is its own (not a ``builtin:``) and that has no [guides] table
    gets ``generate = "normal"`` (:meth:`implied`), never the built-in head's guides."""

    _section: ClassVar[str] = "guides"
    # made for a scene without [guides] (Scene): the groom says so when it makes them
    _implied: bool = PrivateAttr(False)

    generate: Literal["normal", "comb"] | None = Field(
        None,
        description="make starter guides on the mesh instead of reading path: normal"
        " (straight out of the skin) or comb (along comb, lifted by lift); unset: read"
        " path, or normal for a scene with its own mesh and no [guides] table",
    )
    path: str = Field(
        "builtin:long",
        description="builtin:long|short|curly or a curves file; not with generate",
    )
    units: UnitsSetting = Field(
        "m", description=_UNITS_HELP + "; not with generate (its length is in metres)"
    )
    _units_fit_path = field_validator("units")(_units_apply)
    count: int = Field(
        300, ge=1, le=100_000, description="generate: guides, spread evenly by area × density"
    )
    length: GuideLength | None = Field(
        None,
        description="(map) generate: guide length (a texel of 0 grows no guide); unset: 8 %"
        " of the mesh's bounding-box diagonal",
        json_schema_extra=measured_in("m"),
    )
    vertices: int = Field(12, ge=2, le=256, description="generate: vertices per guide")
    comb: Vec3 = Field(
        (0.0, 0.0, 1.0),
        description="generate = comb: the direction (world) guides lie along, projected"
        " onto the skin at each root",
    )
    lift: float = Field(
        30.0,
        ge=0.0,
        le=90.0,
        description="generate = comb: angle of a guide's start above the skin (90: the normal)",
        json_schema_extra=measured_in("degrees"),
    )
    gravity: Unit = Field(
        0.0,
        description="generate: bend towards -Y along the guide (0: straight; 1: the tip"
        " hangs straight down); guides stay out of the skin",
    )
    seed: int = Field(0, ge=0, lt=2**31, description="generate: another evenly spread set of roots")

    @model_validator(mode="after")
    def _one_source(self) -> GuidesParams:
        """``generate`` and ``path`` (or ``units``, a file's) name two sources: refused."""
        given = [key for key in _PATH_KEYS if key in self.model_fields_set]
        if self.generate is not None and given:
            raise ValueError(
                f"generate and {' and '.join(given)} are exclusive: generate makes guides on"
                f" the mesh, path reads them from a file; remove {' and '.join(given)} or"
                " generate"
            )
        return self

    @classmethod
    def implied(cls) -> GuidesParams:
        """The guides of a scene with its own mesh and no [guides] table: generated along
        the normals, marked so that the groom says so (:attr:`is_implied`)."""
        made = cls(generate="normal")
        assert made.__pydantic_private__ is not None  # the private attribute's storage
        made.__pydantic_private__["_implied"] = True
        return made

    @property
    def is_implied(self) -> bool:
        """Whether these are :meth:`implied` guides (a scene without [guides]); a copy
        made with ``replace`` is the user's choice, and is not."""
        return self._implied

    def unused_keys(self) -> tuple[str, ...]:
        """The keys the other source would read: path's with generate, else generate's."""
        return _PATH_KEYS if self.generate is not None else _GENERATE_KEYS


class OutputParams(StrictSection):
    """Where `follicle grow` / `follicle render` write when no -o is given."""

    _section: ClassVar[str] = "output"

    curves: str = Field("hair.npz", description="grown curves file")
    image: str = Field("hair.png", description="rendered image")
    target: Literal[TARGET_NAMES] = Field(  # type: ignore[valid-type]
        "generic",
        description="the tool USD / Alembic output is written for: its attribute"
        " names, types and units (docs: Formats › Targets)",
    )
    layout: Literal["file", "payloads"] = Field(
        "file",
        description="USD from `follicle grow`: one file, or a root layer with one payload"
        " per part file in CURVES.payloads/ (docs: Beyond one machine)",
    )


def _unchosen_guides(mesh_path: object) -> GuidesParams:
    """The guides of a scene that chose none, on the mesh at ``mesh_path``: generated on
    one's own mesh (:meth:`GuidesParams.implied`), the built-in head's on a built-in."""
    own = isinstance(mesh_path, str) and not mesh_path.startswith("builtin:")
    return GuidesParams.implied() if own else GuidesParams()


class Scene(StrictSection):
    """A whole scene; every section optional."""

    mesh: MeshParams = Field(default_factory=MeshParams)
    guides: GuidesParams = Field(default_factory=GuidesParams)
    groom: GroomParams = Field(default_factory=GroomParams)
    sim: SimParams = Field(default_factory=SimParams)
    render: RenderParams = Field(default_factory=RenderParams)
    output: OutputParams = Field(default_factory=OutputParams)
    cards: CardParams = Field(default_factory=CardParams)
    base_dir: Path | str = Field(
        Path("."), exclude=True, description="folder relative paths start in (or a URL)"
    )

    @model_validator(mode="before")
    @classmethod
    def _own_mesh_own_guides(cls, data: object) -> object:
        """A scene with its own mesh and no [guides] table grows guides generated on that
        mesh (:meth:`GuidesParams.implied`), not the built-in head's, which belong on the
        built-in meshes alone."""
        if not isinstance(data, dict) or "guides" in data:
            return data
        mesh = data.get("mesh", {})
        path = mesh.get("path") if isinstance(mesh, dict) else getattr(mesh, "path", None)
        guides = _unchosen_guides(path)
        return {**data, "guides": guides} if guides.is_implied else data

    @field_validator("base_dir", mode="before")
    @classmethod
    def _set_by_the_loader(cls, value: object) -> object:
        """A scene file cannot name its own folder (the loader sets it, unvalidated)."""
        raise ValueError("not a scene key")

    def replace(self, source: str = "settings", **changes: object) -> Scene:
        """A copy with whole sections (a SimParams for ``sim``, …) or ``base_dir``
        replaced; ConfigError for an unknown section or a value of the wrong type.

        A new ``mesh`` without new ``guides`` keeps guides the user chose; guides the
        scene did not choose follow the mesh as a scene file's do: generated on one's own
        mesh (:meth:`GuidesParams.implied`), the built-in head's on a built-in one."""
        for key, value in changes.items():
            field = Scene.model_fields.get(key)
            if field is None:
                raise ConfigError(
                    f"{source}: [{key}]: {unknown_name(key, list(Scene.model_fields), 'section')}"
                )
            want = (Path, str) if key == "base_dir" else field.annotation
            assert isinstance(want, (type, tuple))  # a section's class, or the base_dir types
            if (
                not isinstance(value, want)
                or key == "base_dir"
                and isinstance(value, str)
                and not is_url(value)
            ):
                wanted = "a Path or a URL" if isinstance(want, tuple) else want.__name__
                raise ConfigError(f"{source}: {key}: expected {wanted}, got {type(value).__name__}")
        mesh = changes.get("mesh")
        chosen = "guides" in self.model_fields_set and not self.guides.is_implied
        if isinstance(mesh, MeshParams) and "guides" not in changes and not chosen:
            guides = _unchosen_guides(mesh.path)
            if guides.is_implied != self.guides.is_implied:
                changes["guides"] = guides
        return self.model_copy(update=changes)

    def resolve(self, path: str) -> str:
        """A scene path made absolute against the scene's folder, or joined onto it with
        ``/`` when the scene came from a URL (builtins, absolute paths and URLs untouched)."""
        if path.startswith("builtin:") or os.path.isabs(path) or is_url(path):
            return path
        if isinstance(self.base_dir, str):
            return f"{self.base_dir.rstrip('/')}/{path}"
        return str(self.base_dir / path)

    def output_path(self, name: str) -> str:
        """Where a default output ``name`` ([output].curves, …) goes: resolved like an
        input beside a scene of this machine; for a scene read from another machine (a
        URL), its file name alone, in the current folder."""
        if is_remote(self.base_dir):
            return Path(name).name or name
        return self.resolve(name)

    def _owner_hint(self, name: str) -> str:
        return f"scene = scene.replace({name}=...)"


# every section names its [table] (Section.replace): the scene's field of that name
assert all(
    f.exclude or getattr(f.annotation, "_section", None) == k for k, f in Scene.model_fields.items()
)


def holds_paths(field: FieldInfo) -> bool:
    """Whether a scene key's text values are file paths: typed ``str`` (alone or in a
    union) or a property (a groom's, or the optional [guides].length: a number, an image
    path, or a table with ``texture``); a choice (Literal) holds names, not paths."""
    a = field.annotation
    union = typing.get_origin(a) in (typing.Union, types.UnionType)
    # a union's members, each without its Annotated metadata (an optional property)
    members = {
        typing.get_args(t)[0] if typing.get_origin(t) is Annotated else t
        for t in (typing.get_args(a) if union else ())
    }
    return a is typing.Any or a is str or bool({str, Any} & members)


def scene_paths(scene: Scene, outputs: bool = False) -> Iterator[tuple[str, str]]:
    """Every file path the scene's keys give, as written: (``[section].key``, path),
    for text values of path keys (:func:`holds_paths`) and a groom property table's
    ``texture``; the [output] keys only with ``outputs``."""
    for name, field in Scene.model_fields.items():
        if field.exclude or (name == "output" and not outputs):
            continue
        model = getattr(scene, name)
        for key, sub in type(model).model_fields.items():
            if not holds_paths(sub):
                continue
            value = getattr(model, key)
            if isinstance(value, dict):
                value = value.get("texture")
            if isinstance(value, str):
                yield f"[{name}].{key}", value


def scene_files(scene: Scene) -> list[tuple[str, str]]:
    """The files a scene reads (its inputs, not [output]), resolved as it reads them, as
    (``the scene's [section].key``, path) pairs; built-ins left out."""
    return [
        (f"the scene's {key}", scene.resolve(path))
        for key, path in scene_paths(scene)
        if not path.startswith("builtin:")
    ]


def scene_with(
    scene: Scene, section: str, values: Mapping[str, object], source: str = "command line"
) -> Scene:
    """``scene`` with the keys of ``values`` that are not None replaced in [``section``]
    (a command's options: ``{"count": None}`` means "not given"); ConfigError naming
    ``source`` for a value the section refuses."""
    changes = {key: value for key, value in values.items() if value is not None}
    if not changes:
        return scene
    return scene.replace(**{section: getattr(scene, section).replace(source, **changes)})


def check_outputs(
    outputs: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    source: str | None = None,
    scene: Scene | None = None,
    more: Sequence[tuple[str, str | None]] = (),
    folders: Sequence[str | os.PathLike[str]] = (),
) -> None:
    """Before anything is read: InputError when an output would replace an input of the
    same run: the scene file ``source``, a file the ``scene`` reads (its mesh, guides,
    textures, skin animation), or one of ``more`` ((label, path or None) pairs), or
    when one of ``folders`` (replaced whole) holds one (:func:`follicle.inputs.check_apart`)."""
    inputs: list[tuple[str, str | os.PathLike[str]]] = [("the scene", source)] if source else []
    inputs += scene_files(scene) if scene is not None else []
    inputs += [(label, path) for label, path in more if path]
    outs = [outputs] if isinstance(outputs, (str, os.PathLike)) else outputs
    check_apart(outs, inputs, folders)


def _check_remote(scene: Scene, source: str) -> None:
    """A scene read from another machine reads only files beside it on its own server:
    ConfigError naming the key of one that is a path of this machine, a ``file://`` URL
    or a file of another server (the user never named those). Its [output] names only
    a file name (:meth:`Scene.output_path`)."""
    for key, path in scene_paths(scene):
        why = remote_reach(source, path)
        if why is not None:
            raise ConfigError(
                f"{source}: {key} = {shown(path)}: is {why}; a scene read from a URL names"
                " files beside it on its own server (a relative path)"
            )


def parse_scene(
    data: dict[str, Any], source: str = "scene", base_dir: Path | str | None = None
) -> Scene:
    """Validate a scene dictionary (as read from TOML)."""
    try:
        scene = Scene.model_validate(data)
    except ValidationError as err:
        raise ConfigError(format_errors(source, err, Scene)) from None
    return scene if base_dir is None else scene.model_copy(update={"base_dir": base_dir})


def load_scene(path: str | os.PathLike[str] | None) -> Scene:
    """Read and validate a scene TOML file (None gives the default scene).

    Only a regular file of at most :data:`MAX_SCENE_BYTES` is read (a FIFO, device or
    folder is refused before opening it); anything the TOML parser cannot take (bad
    syntax or UTF-8, nesting too deep for its recursion, an integer of thousands of
    digits) is a ConfigError naming the file.
    """
    if path is None:
        return Scene()
    path = file_path(path, "load_scene path")
    p = Path(path)
    if not is_url(path) and not os.path.lexists(p):
        raise FileAccessError(f"{p}: no such scene file")
    p = input_file(path, "scene file (TOML)", MAX_SCENE_BYTES)
    try:
        with open(p, "rb") as fh:
            raw = fh.read(MAX_SCENE_BYTES + 1)
    except OSError as exc:
        raise FileAccessError(f"{p}: cannot be read ({exc.strerror or exc})") from None
    if len(raw) > MAX_SCENE_BYTES:
        raise ConfigError(
            f"{p}: larger than {MAX_SCENE_BYTES >> 20} MiB; a scene file is a short TOML text"
        )
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{p}: not a UTF-8 text file (bad byte at offset {exc.start})") from None
    if is_url(path):  # its relative paths are URLs beside it
        scene = scene_from_toml(text, str(path), str(path).rsplit("/", 1)[0])
        if is_remote(path):
            _check_remote(scene, str(path))
        return scene
    return scene_from_toml(text, str(p), p.resolve().parent)


def scene_from_toml(text: str, source: str, base_dir: Path | str | None = None) -> Scene:
    """A scene from TOML text (a file's, or one stored in a cache or frame file); anything
    the parser cannot take (bad syntax, nesting too deep for its recursion, an integer of
    thousands of digits) is a ConfigError naming ``source``."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: TOML syntax error: {exc}") from None
    except RecursionError:
        raise ConfigError(
            f"{source}: arrays or tables nested too deeply to parse; a scene nests a few levels"
        ) from None
    except (ValueError, MemoryError) as exc:  # e.g. an integer of more than 4300 digits
        why = str(exc).split(";")[0] or type(exc).__name__  # not Python's set_int_max_str_digits
        raise ConfigError(f"{source}: a TOML value is too large to read ({why})") from None
    return parse_scene(data, source, base_dir)


# a TOML basic string: backslash, quote and control characters escaped (\uXXXX), so any
# text (a path with a newline or NUL, say) is one valid line that reads back the same
_TOML_ESCAPES = str.maketrans(
    {"\\": "\\\\", '"': '\\"', **{chr(c): f"\\u{c:04x}" for c in (*range(0x20), 0x7F)}}
)


def _toml_value(value: Any) -> str:
    if isinstance(value, BaseModel):  # e.g. [[sim.colliders]] entries: inline tables
        value = value.model_dump()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isinf(value) or math.isnan(value):
            raise ConfigError(f"cannot write {value} to TOML")
        return repr(value)
    if isinstance(value, str):
        if any("\ud800" <= c <= "\udfff" for c in value):  # e.g. undecodable file-name bytes
            raise ConfigError(f"cannot write {shown(value)} to TOML: it is not valid Unicode")
        return '"' + value.translate(_TOML_ESCAPES) + '"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        pairs = (f"{_toml_value(k)} = {_toml_value(v)}" for k, v in value.items())
        return "{" + ", ".join(pairs) + "}"
    raise ConfigError(f"cannot write a {type(value).__name__} to TOML")


def scene_to_toml(scene: Scene, comments: bool = True) -> str:
    """The scene as TOML text with every default filled in (unset values commented out),
    each key followed by its unit in brackets and its description as a comment
    (``comments``): ``frizz_tip = 0.0  # [m] (map) frizz amplitude at the tip``."""
    out: list[str] = []
    for section, field in Scene.model_fields.items():
        if field.exclude:
            continue
        model: BaseModel = getattr(scene, section)
        unused = model.unused_keys() if isinstance(model, GuidesParams) else ()
        out.append(f"[{section}]")
        for key, sub in type(model).model_fields.items():
            value = getattr(model, key)
            unit = unit_of(sub)
            text = f"[{unit}] {sub.description}" if unit else sub.description
            note = f"  # {text}" if comments and text else ""
            if key in unused:  # read only by the other choice ([guides]: path or generate)
                out.append(
                    f"# {key} = {_toml_value(value) if value is not None else '(unset)'}{note}"
                )
            elif value is None:
                out.append(f"# {key} = (unset){note}")
            else:
                out.append(f"{key} = {_toml_value(value)}{note}")
        out.append("")
    return "\n".join(out)
