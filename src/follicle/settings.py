"""What every settings section is made of: the frozen, validated base classes, the
shared value types (Unit, RGB, Vec3, …), the unit a key is measured in
(:func:`measured_in`) and the error text that names ``[section].key``.

The sections live beside the subsystem they configure (``groom.settings``,
``sim.settings``, ``render.settings``); :mod:`follicle.scene` puts them together into a
scene and reads and writes TOML. This module imports nothing of follicle but its errors,
so any layer may use it.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from typing import TYPE_CHECKING, Annotated, ClassVar, get_args

from pydantic import BaseModel, ConfigDict, Field, ValidationError
from pydantic.config import JsonDict
from pydantic.fields import FieldInfo

from .errors import ConfigError

if TYPE_CHECKING:
    from typing_extensions import Self

__all__ = [
    "Section",
    "StrictSection",
    "unknown_name",
    "suggestions",
    "Unit",
    "Component",
    "RGB",
    "Vec3",
    "UNITS",
    "measured_in",
    "unit_of",
    "format_errors",
    "not_bool",
    "shown",
]

Unit = Annotated[float, Field(ge=0.0, le=1.0)]
# a vector component (a position in m, a frequency in 1/m, an acceleration in m/s²):
# bounded like a mesh coordinate, so products of a few stay far from overflowing
Component = Annotated[float, Field(ge=-1e6, le=1e6)]
# strict sections want a tuple where TOML gives a list: the tuple takes a list, its
# items stay strict (a number, not true or "1")
RGB = Annotated[tuple[Unit, Unit, Unit], Field(strict=False)]
Vec3 = Annotated[tuple[Component, Component, Component], Field(strict=False)]

# the units a scene key is measured in (follicle works in metres, seconds and degrees);
# a colour's "unit" is its colour space
UNITS = ("m", "m/s", "m/s²", "1/m", "1/s", "s", "degrees", "pixels", "texels", "linear RGB")


def measured_in(unit: str) -> JsonDict:
    """A key's unit, part of its schema: ``Field(0.0, description="frizz amplitude",
    json_schema_extra=measured_in("m"))``. The docs' reference shows it in its unit
    column, ``follicle info`` after each key's description, and the JSON schema
    (``model_json_schema()``) as ``"unit"``; one of :data:`UNITS`."""
    if unit not in UNITS:
        raise ValueError(f"unknown unit {unit!r}; one of {', '.join(UNITS)}")
    return {"unit": unit}


def unit_of(field: FieldInfo) -> str:
    """The unit of a key's field (:func:`measured_in`), or "" for a number without one
    (a count, a share, a stiffness)."""
    extra = field.json_schema_extra
    unit = extra.get("unit", "") if isinstance(extra, dict) else ""
    return unit if isinstance(unit, str) else ""


class Section(BaseModel):
    """A scene table: unknown keys are errors and no number may be NaN or infinite.

    A value, never changed in place: ``replace(key=value)`` makes a validated copy, which
    its owner takes whole (``Simulator.params``, ``Groom.params``, ``Scene.replace``) and
    so knows what to rebuild; assigning to a key raises ConfigError saying so.

    A subclass names its ``[section]`` in a scene file (``_section``; None for a table
    inside one, such as ``[[render.lights]]``) and who takes a changed copy (``_owner``)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    _section: ClassVar[str | None] = None
    _owner: ClassVar[str | None] = None

    def __init__(self, /, **data: object) -> None:
        """Validated as :meth:`replace` validates: ConfigError naming ``[section].key``,
        not pydantic's ValidationError (a ValueError), for a value out of range."""
        try:
            super().__init__(**data)
        except ValidationError as err:
            cls = type(self)
            if cls._section is None:  # a table of a section ([[sim.colliders]]): its class
                raise ConfigError(format_errors("settings", err, cls, (cls.__name__,))) from None
            raise ConfigError(format_errors(cls.__name__, err, cls, (cls._section,))) from None

    # pydantic calls a model's own __init__ when it validates it inside another (a
    # [[sim.colliders]] entry); marked as its base __init__, it keeps to direct calls,
    # and the enclosing model's errors name the whole place ([sim].colliders.0.normal)
    __init__.__pydantic_base_init__ = True  # type: ignore[attr-defined]

    def __setattr__(self, name: str, value: object) -> None:
        kind = type(self).__name__
        raise ConfigError(
            f"{kind}.{name}: settings are values and do not change in place; make a changed"
            f" copy, {self._owner_hint(name)}"
        )

    def _owner_hint(self, name: str) -> str:
        """How to change key ``name``: a copy from replace, given to its owner."""
        where = f", and give it to {self._owner}" if self._owner else ""
        return f"params = params.replace({name}=...){where}"

    def replace(self, source: str = "settings", **changes: object) -> Self:
        """A copy with ``changes`` applied and validated as a scene file's would be;
        ConfigError naming ``[section].key`` (``source`` names where they came from)."""
        data = {**self.model_dump(), **changes}
        try:
            return type(self).model_validate(data)
        except ValidationError as err:
            prefix = () if self._section is None else (self._section,)
            raise ConfigError(format_errors(source, err, type(self), prefix)) from None


class StrictSection(Section):
    """A table whose values keep their TOML type: ``count = true`` or ``count = "10"`` is
    an error, not 1 or 10 (a float key takes an integer, nothing else)."""

    model_config = ConfigDict(strict=True)


def not_bool(v: object) -> object:
    """``v`` unless it is a bool (a Literal of numbers would take true as 1)."""
    if isinstance(v, bool):
        raise ValueError(f"expected a number (got {str(v).lower()})")
    return v


def shown(x: object) -> str:
    """``x`` as TOML shows a bool, else ``repr(x)`` cut to 60 characters: an error message
    stays one short line whatever value (a megabyte string, a long list) it quotes."""
    text = str(x).lower() if isinstance(x, bool) else repr(x)
    return text if len(text) <= 60 else text[:57] + "..."


def format_errors(
    source: str, err: ValidationError, model: type[BaseModel], prefix: tuple[str, ...] = ()
) -> str:
    """One line for pydantic's errors validating ``model``: ``source: [section].key:
    problem`` for each place, joined by "; ". ``prefix`` is where ``model`` sits in a
    scene (``("render",)`` for RenderParams; empty for the Scene itself)."""
    by_place: dict[str, str] = {}
    for e in err.errors():
        loc = [str(p) for p in e["loc"] if not str(p).startswith(("function-", "tuple["))]
        loc = [p if p.isprintable() else repr(p) for p in loc]  # a key "a\nb": one line
        # unions report a branch name ('str', 'float') as a location step: drop them
        loc = [p for p in loc if p not in {"str", "float", "int", "none", "constrained-float"}]
        loc = [*prefix, *loc]
        section = f"[{loc[0]}]" if loc else "scene"
        key = ".".join(loc[1:]) if len(loc) > 1 else ""
        where = f"{section}{'.' + key if key else ''}"
        if e["type"] == "extra_forbidden" or loc == ["base_dir"]:  # the loader sets base_dir
            allowed = _allowed_keys(model, loc[len(prefix) :])
            table = len(loc) == 1 and isinstance(e.get("input"), dict)  # [gromm]
            by_place[where] = f"{source}: {where}: " + unknown_name(
                loc[-1], allowed, "section" if table else "key"
            )
        elif where not in by_place or not e["type"].endswith("_type"):
            # a union reports each branch; a range message beats a type mismatch
            got = e.get("input")
            quoted = "" if isinstance(got, dict) or "(got" in e["msg"] else f" (got {shown(got)})"
            msg = e["msg"].removeprefix("Value error, ")
            by_place[where] = f"{source}: {where}: {msg}{quoted}"
    # a union of a number and a list reports the value and an item of it: keep the value's
    # one line, problems joined: the CLI promises one line
    return "; ".join(
        line
        for where, line in by_place.items()
        if not any(where.startswith(other + ".") for other in by_place)
    )


def suggestions(name: str, allowed: Sequence[str]) -> list[str]:
    """What ``name`` may have meant among ``allowed``, best first: the close spellings
    (difflib), then the names that begin with it (``curl`` → ``curl_radius``) or whose
    words it begins with (``count_max`` → ``count``); at most four."""
    close = difflib.get_close_matches(name, allowed, n=3, cutoff=0.6)
    parts = [a for a in allowed if name and (a.startswith(name) or name.startswith(a + "_"))]
    return list(dict.fromkeys(close + parts))[:4]


def unknown_name(name: str, allowed: Sequence[str], what: str = "key") -> str:
    """The text for an unknown ``name`` among ``allowed``, its :func:`suggestions` first
    (``unknown key; did you mean curl_radius?``); the whole list only when nothing is
    close, so that the line stays short."""
    shown_names = suggestions(name, allowed)
    if what == "section":
        shown_names = [f"[{a}]" for a in shown_names]
    if shown_names:
        return f"unknown {what}; did you mean {' or '.join(shown_names)}?"
    return f"unknown {what}; allowed {what}s: {', '.join(allowed)}"


def _allowed_keys(model: type[BaseModel], loc: list[str]) -> list[str]:
    """The keys of the table at ``loc`` below ``model`` (its last step the unknown key),
    following sections, nested tables and list entries such as ``[[render.lights]]``."""
    for step in loc[:-1]:
        if step.isdigit():  # an entry of a list of tables: its model is the list's
            continue
        field = model.model_fields.get(step)
        kinds = (field.annotation, *get_args(field.annotation)) if field else ()
        tables = [k for k in kinds if isinstance(k, type) and issubclass(k, BaseModel)]
        if not tables:
            break
        model = tables[0]
    return [k for k, f in model.model_fields.items() if not f.exclude]
