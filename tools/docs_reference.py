"""The docs' generated reference: every scene key from the settings schema (the pydantic
sections of :mod:`follicle.scene`) and every command and option from the ``follicle``
click group, written as Markdown when the site is built (``tools/mkdocs_hooks.py``), so
the reference cannot drift from the code.

Each key's type, default and range come from its pydantic field (its annotation, its
``ge``/``gt``/``le``/``lt`` constraints, a textured property's bounds); its unit from
the field's schema (``json_schema_extra=measured_in("m")``, :mod:`follicle.settings`).
``missing_scene_descriptions`` and ``missing_cli_descriptions`` list what has no
description; ``tests/test_docs_reference.py`` fails on any.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Iterator
from typing import Any, Literal

import click
from pydantic import BaseModel
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

from follicle.settings import unit_of

__all__ = [
    "scene_tables",
    "missing_scene_descriptions",
    "missing_cli_descriptions",
    "scene_reference",
    "cli_reference",
]

# click ≥ 8.2 marks an option without a default by a sentinel, older click by None
_UNSET = getattr(click.core, "UNSET", None)
_BOUND_SIGNS = (("ge", "≥"), ("gt", ">"), ("le", "≤"), ("lt", "<"))


def scene_tables() -> list[tuple[str, type[BaseModel]]]:
    """Every table of a scene file, in the order of the Scene's sections, each followed by
    the tables it holds (``[[sim.colliders]]`` after ``[sim]``)."""
    from follicle.scene import Scene

    found: list[tuple[str, type[BaseModel]]] = []
    for name, field in Scene.model_fields.items():
        if field.exclude or not _is_model(field.annotation):
            continue
        found.append((f"[{name}]", field.annotation))  # type: ignore[arg-type]
        found += list(_inner_tables(name, field.annotation))  # type: ignore[arg-type]
    return found


def _inner_tables(prefix: str, model: type[BaseModel]) -> Iterator[tuple[str, type[BaseModel]]]:
    """The arrays of tables (``list[Model]``) inside ``model``, as ``[[prefix.key]]``."""
    for key, field in model.model_fields.items():
        for arg in typing.get_args(field.annotation):
            if _is_model(arg):
                yield f"[[{prefix}.{key}]]", arg


def _is_model(tp: object) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _keys(model: type[BaseModel]) -> Iterator[tuple[str, FieldInfo]]:
    """The keys a scene file may set in ``model`` (``exclude``d fields are the loader's)."""
    return ((k, f) for k, f in model.model_fields.items() if not f.exclude)


def missing_scene_descriptions(model: type[BaseModel], prefix: str = "") -> list[str]:
    """``section.key`` of each key of ``model``, and of the tables below it, that has no
    description (empty or only spaces)."""
    missing = []
    for key, field in _keys(model):
        # a section (a model-valued key of the Scene) is described by its class docstring
        described = field.annotation.__doc__ if _is_model(field.annotation) else field.description
        if not (described or "").strip():
            missing.append(f"{prefix}{key}")
        inner = [a for a in (field.annotation, *typing.get_args(field.annotation)) if _is_model(a)]
        for sub in inner:
            missing += missing_scene_descriptions(sub, f"{prefix}{key}.")
    return missing


def missing_cli_descriptions(group: click.Group) -> list[str]:
    """Each command of ``group`` without help, and each ``command --option`` without help
    (click's own ``--help`` included: it always has one)."""
    missing = []
    ctx = click.Context(group)
    for name in group.list_commands(ctx):
        command = group.get_command(ctx, name)
        assert command is not None
        if not (command.help or command.short_help or "").strip():
            missing.append(name)
        for param in command.params:
            if isinstance(param, click.Option) and not (param.help or "").strip():
                missing.append(f"{name} {max(param.opts, key=len)}")
    return missing


# ---- the scene reference -------------------------------------------------------------


def _bounds(items: object) -> dict[str, float]:
    """The ge/gt/le/lt constraints among pydantic metadata (annotated-types objects, a
    nested FieldInfo, a textured property's ``bounds``)."""
    found: dict[str, float] = {}
    for item in items if isinstance(items, (list, tuple)) else ():
        if isinstance(item, FieldInfo):
            found.update(_bounds(item.metadata))
        for key, _ in _BOUND_SIGNS:
            if isinstance(getattr(item, key, None), (int, float)):
                found[key] = getattr(item, key)
        if isinstance(getattr(item, "bounds", None), tuple):
            found.update(dict(item.bounds))
    return found


def _number(x: float) -> str:
    if isinstance(x, float) and x.is_integer() and abs(x) < 1e15:
        x = int(x)
    return f"{x:,}" if isinstance(x, int) and abs(x) >= 10_000 else repr(x)


def _interval(b: dict[str, float]) -> str:
    """``[0, 1]``, ``(0, 100]``, ``≥ 0`` from ge/gt/le/lt."""
    low = ("[", b["ge"]) if "ge" in b else ("(", b["gt"]) if "gt" in b else None
    high = (b["le"], "]") if "le" in b else (b["lt"], ")") if "lt" in b else None
    if low and high:
        return f"{low[0]}{_number(low[1])}, {_number(high[0])}{high[1]}"
    if low:
        return f"{'≥' if low[0] == '[' else '>'} {_number(low[1])}"
    if high:
        return f"{'≤' if high[1] == ']' else '<'} {_number(high[0])}"
    return ""


def _strip(tp: Any) -> tuple[Any, dict[str, float]]:
    """``tp`` without its Annotated layer, and that layer's bounds."""
    if typing.get_origin(tp) is typing.Annotated:
        inner, *meta = typing.get_args(tp)
        return inner, _bounds(meta)
    return tp, {}


def _type_and_range(tp: Any, metadata: list[Any]) -> tuple[str, str]:
    """A key's type as a scene file writes it, and its range."""
    prop = next((m for m in metadata if hasattr(m, "color") and hasattr(m, "bounds")), None)
    if prop is not None:  # a textured property (groom.settings._Property)
        kind = "[r, g, b]" if prop.color else "number"
        rng = "each in [0, 1]" if prop.color else _interval(dict(prop.bounds))
        return f"{kind}, texture or table (map)", rng
    tp, inner = _strip(tp)
    bounds = {**inner, **_bounds(metadata)}
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        parts = [_type_and_range(a, []) for a in args if a is not type(None)]
        kind = " or ".join(dict.fromkeys(p[0] for p in parts))
        # the field's own bounds (``int | None = Field(ge=2)``) hold for its number
        ranges = [p[1] for p in parts if p[1]] or ([_interval(bounds)] if bounds else [])
        if type(None) in args:
            kind += " (or unset)"
        return kind, ranges[0] if len(ranges) == 1 else "; ".join(ranges)
    if origin is Literal:
        return " | ".join(f'"{a}"' if isinstance(a, str) else str(a) for a in args), ""
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            items = _type_and_range(args[0], [])[0]
            limit = f"at most {metadata_len(metadata)} items" if metadata_len(metadata) else ""
            return f"[{items}, …]", limit
        parts = [_type_and_range(a, []) for a in args]
        item_ranges = {p[1] for p in parts}
        rng = f"each in {item_ranges.pop()}" if len(item_ranges) == 1 and parts[0][1] else ""
        return f"[{', '.join(p[0] for p in parts)}]", rng
    if origin is list and args and _is_model(args[0]):
        return "array of tables", ""
    if origin is dict:
        value, rng = _type_and_range(args[1], [])
        return f"table of {value}", f"each in {rng}" if rng and "each" not in rng else rng
    name = getattr(tp, "__name__", str(tp))
    return {"str": "string", "float": "number", "int": "integer", "bool": "true/false"}.get(
        name, name
    ), _interval(bounds)


def metadata_len(metadata: list[Any]) -> int | None:
    """A ``max_length`` constraint among field metadata, if any."""
    return next((m.max_length for m in metadata if hasattr(m, "max_length")), None)


def _default(field: FieldInfo) -> str:
    """The default as TOML writes it; "unset" for None."""
    value = field.default_factory() if field.default is PydanticUndefined else field.default  # type: ignore[call-arg,misc]
    if value is None:
        return "unset"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_default_item(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{}" if not value else str(value)
    return _number(value) if isinstance(value, (int, float)) else str(value)


def _default_item(v: object) -> str:
    return f'"{v}"' if isinstance(v, str) else _number(v) if isinstance(v, (int, float)) else "…"


def _cell(text: str) -> str:
    """Text safe in a Markdown table cell: no pipes, no raw angle brackets, one line."""
    text = " ".join(text.split())
    return text.replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;")


def scene_reference() -> str:
    """The scene-key reference page: one table per scene table."""
    out = [
        "# Scene keys",
        "",
        "Every key a scene file (TOML) may set, generated from the settings schema"
        " (`follicle.scene.Scene` and its sections) when the docs are built. A key left"
        " out takes its default; `follicle info scene.toml` prints a scene with every"
        " default filled in. *(map)* marks a property that takes a number, a texture path"
        ' or a table `{value = …, texture = "map.png", wrap = "repeat"}`: the value at'
        " a root is value × texture(uv) (Šik 2012 §2.2.2). The unit column gives each"
        " key's unit, from the schema (follicle works in metres, seconds and degrees;"
        " a colour's is its colour space); a number without one is a count, a share or"
        " a factor.",
        "",
        "See [Scene files](../how-to/scene-files.md) for how a scene is written.",
    ]
    for table, model in scene_tables():
        out += ["", f"## `{table}`", "", _cell(model.__doc__ or "").replace("\\|", "|"), ""]
        out += [
            "| key | type | default | range | unit | description |",
            "|---|---|---|---|---|---|",
        ]
        for key, field in _keys(model):
            kind, rng = _type_and_range(field.annotation, list(field.metadata))
            desc = field.description or ""
            unit = unit_of(field)
            row = (f"`{key}`", _cell(kind), f"`{_default(field)}`", _cell(rng), _cell(unit))
            out.append("| " + " | ".join(row) + f" | {_cell(desc)} |")
    return "\n".join(out) + "\n"


# ---- the command-line reference ------------------------------------------------------


def _help_text(text: str) -> str:
    """A command's help as Markdown: click's ``\\b`` (keep lines) markers dropped, its
    paragraphs kept."""
    paragraphs = [p.strip() for p in text.replace("\b", "").split("\n\n")]
    return "\n\n".join(" ".join(p.split()) for p in paragraphs if p)


def _examples(command: click.Command) -> list[str]:
    """A command's example lines (its epilog's ``Example:`` block, follicle.cli._examples)
    as a ``bash`` block, or nothing where it has none."""
    lines = (command.epilog or "").replace("\b", "").splitlines()
    start = next((i for i, x in enumerate(lines) if x.strip() in ("Example:", "Examples:")), None)
    if start is None:
        return []
    found = [x.strip() for x in lines[start + 1 :] if x.strip()]
    return ["```bash", *found, "```", ""]


def _option_row(param: click.Option) -> str:
    names = ", ".join(f"`{n}`" for n in (*param.opts, *param.secondary_opts))
    if param.is_flag:
        kind = "flag"
    else:
        if isinstance(param.type, click.Tuple):
            kind = " ".join(t.name.upper() for t in param.type.types)
        elif isinstance(param.type, click.Choice):
            kind = " \\| ".join(f"`{c}`" for c in param.type.choices)
        else:
            kind = param.metavar or param.type.name.upper()
        if param.multiple:
            kind += " (repeatable)"
    default = param.default
    shown = (
        ""
        if any(default is nothing for nothing in (None, False, _UNSET))
        or callable(default)
        or param.is_flag
        and not default
        else f"`{default}`"
        if not isinstance(default, (tuple, list))
        else f"`{' '.join(map(str, default))}`"
    )
    kind = kind if isinstance(param.type, click.Choice) else _cell(kind)
    return f"| {names} | {kind} | {shown} | {_cell(param.help or '')} |"


def cli_reference() -> str:
    """The command-line reference page: every command, its usage, arguments and options."""
    from follicle.cli import main

    ctx = click.Context(main, info_name="follicle")
    out = [
        "# Command line",
        "",
        "Every `follicle` command and option, generated from the click commands"
        " (`follicle.cli`) when the docs are built; `follicle COMMAND --help` prints the"
        " same. See [the command line](../getting-started/command-line.md) for a tour.",
        "",
        "```text",
        main.get_usage(ctx),
        "```",
        "",
        _help_text(main.help or ""),
        "",
        *_examples(main),
        "| option | value | default | description |",
        "|---|---|---|---|",
        *(_option_row(p) for p in main.params if isinstance(p, click.Option)),
    ]
    for name in main.list_commands(ctx):
        command = main.get_command(ctx, name)
        assert command is not None
        sub = click.Context(command, info_name=name, parent=ctx)
        out += ["", f"## `follicle {name}`", "", "```text", command.get_usage(sub), "```", ""]
        out += [_help_text(command.help or ""), ""]
        out += _examples(command)
        arguments = [p for p in command.params if isinstance(p, click.Argument)]
        if arguments:
            out += ["Arguments: " + ", ".join(f"`{p.human_readable_name}`" for p in arguments)]
            out += [""]
        options = [p for p in command.params if isinstance(p, click.Option)]
        if options:
            out += ["| option | value | default | description |", "|---|---|---|---|"]
            out += [_option_row(p) for p in options]
    return "\n".join(out) + "\n"
