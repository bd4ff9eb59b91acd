"""The docs' generated reference (tools/docs_reference.py): every scene key and every
command and option has a description, the detector finds one that has none, and the
pages it writes carry the schema's real types, defaults, ranges and units."""

from __future__ import annotations

import click
from click.testing import CliRunner
from pydantic import BaseModel, Field
from tools import docs_reference as ref

from follicle.cli import main
from follicle.scene import Scene


def test_every_scene_key_has_a_description():
    assert ref.missing_scene_descriptions(Scene) == []
    for table, model in ref.scene_tables():
        assert (model.__doc__ or "").strip(), f"{table} ({model.__name__}) has no docstring"


def test_every_command_and_option_has_a_description():
    assert ref.missing_cli_descriptions(main) == []


class _Light(BaseModel):
    """A table inside a section."""

    colour: float = Field(1.0)  # no description


class _Section(BaseModel):
    """A section with one described key, one without and a table with a key without."""

    described: int = Field(0, description="has one")
    bare: int = 0
    blank: str = Field("", description="   ")
    lights: list[_Light] = Field(default_factory=list, description="tables")


def test_the_detector_finds_keys_without_a_description():
    assert ref.missing_scene_descriptions(_Section) == ["bare", "blank", "lights.colour"]


def test_the_detector_finds_a_section_without_a_docstring():
    class Undocumented(BaseModel):
        key: int = Field(0, description="described")

    class Outer(BaseModel):
        """A scene of one section."""

        section: Undocumented = Field(default_factory=Undocumented)

    assert ref.missing_scene_descriptions(Outer) == ["section"]


def test_the_detector_finds_commands_and_options_without_help():
    @click.group()
    def tool() -> None:
        """A tool."""

    @tool.command()
    @click.option("--quiet", is_flag=True)  # no help
    @click.option("--size", type=int, help="Described.")
    def bare(quiet: bool, size: int) -> None:  # no docstring: no help
        pass

    @tool.command()
    @click.option("-o", "--out", help="")  # empty help
    def told(out: str) -> None:
        """Has help."""

    assert ref.missing_cli_descriptions(tool) == ["bare", "bare --quiet", "told --out"]


def _row(page: str, table: str, key: str) -> list[str]:
    """The cells of ``key``'s row in ``table``'s section of the scene reference."""
    section = page[page.index(f"## `{table}`") :]
    line = next(x for x in section.splitlines() if x.startswith(f"| `{key}` |"))
    return [c.strip() for c in line.strip("|").split(" | ")]


def test_the_scene_reference_carries_types_defaults_ranges_and_units():
    page = ref.scene_reference()
    # key, type, default, range, unit: the values pydantic's Field(...) gives each
    assert _row(page, "[groom]", "count")[:5] == [
        "`count`",
        "integer",
        "`20,000`",
        "[0, 50,000,000]",
        "",
    ]
    assert _row(page, "[groom]", "frizz_tip")[1:5] == [
        "number, texture or table (map)",
        "`0`",
        "[0, 10]",
        "m",
    ]
    assert _row(page, "[sim]", "gravity")[1:5] == [
        "[number, number, number]",
        "`[0, -9.81, 0]`",
        "each in [-100, 100]",
        "m/s²",
    ]
    assert _row(page, "[render]", "fov")[2:5] == ["`30`", "(1, 170)", "degrees"]
    assert _row(page, "[sim]", "vertices")[1:4] == ["integer (or unset)", "`unset`", "[2, 256]"]
    assert _row(page, "[render]", "engine")[1] == '"auto" \\| "opengl" \\| "cpu" \\| "mitsuba"'
    assert _row(page, "[[sim.colliders]]", "radius")[2:5] == ["`0.1`", "(0, 100]", "m"]
    assert _row(page, "[[render.lights]]", "color")[4] == "linear RGB"


def test_the_scene_reference_lists_what_info_prints():
    """Every key `follicle info` writes for the default scene (its TOML, the oracle) has
    a row in its table of the reference."""
    from follicle.scene import scene_to_toml

    page = ref.scene_reference()
    table = None
    for line in scene_to_toml(Scene()).splitlines():
        if line.startswith("["):
            table = line.strip()
            assert f"## `{table}`" in page, table
        elif "=" in line and not line.startswith("#"):
            key = line.split("=")[0].strip()
            assert f"| `{key}` |" in page[page.index(f"## `{table}`") :], (table, key)


def test_the_cli_reference_has_every_command_of_the_help():
    """The commands `follicle --help` lists (its output, the oracle) each have a section
    with their options."""
    shown = CliRunner().invoke(main, ["--help"]).output
    commands = shown[shown.index("Commands:") :].split("\n\n")[0].splitlines()[1:]
    names = [line.split()[0] for line in commands]
    assert len(names) >= 12 and "grow" in names and "export-rib" in names
    page = ref.cli_reference()
    for name in names:
        assert f"## `follicle {name}`" in page, name
    grow = page[page.index("## `follicle grow`") :]
    assert "| `-o`, `--out` |" in grow
    assert "| `--seed` | INTEGER |" in grow


def test_units_as_descriptions_state_them():
    assert ref.unit_of("frizz amplitude at the tip, m") == "m"
    assert ref.unit_of("gravity, m/s² (each component within ±100)") == "m/s²"
    assert ref.unit_of("offset rotate: largest random tilt, ± degrees") == "degrees"
    assert ref.unit_of("style length, m: how long a strand stands out") == "m"
    assert ref.unit_of("air drag b of −b·v (Le Muzic 2012 eq. 5.3), 1/s") == "1/s"
    assert ref.unit_of("number of hairs") == ""
    assert ref.unit_of("share of tangential speed lost in contact, mostly") == ""
