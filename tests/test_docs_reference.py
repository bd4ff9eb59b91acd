"""The docs' generated reference (tools/docs_reference.py): every scene key and every
command and option has a description, the detector finds one that has none, and the
pages it writes carry the schema's real types, defaults, ranges and units."""

from __future__ import annotations

import click
import pytest
from click.testing import CliRunner
from pydantic import BaseModel, Field
from tools import docs_reference as ref

from follicle.cli import main
from follicle.scene import Scene
from follicle.settings import measured_in, unit_of


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


def test_the_cli_reference_shows_each_commands_examples():
    """The example lines `follicle render --help` ends with (its output, the oracle) are
    the render section's bash block."""
    shown = CliRunner().invoke(main, ["render", "--help"]).output
    examples = [x.strip() for x in shown[shown.index("Examples:") :].splitlines()[1:] if x]
    assert len(examples) == 2 and examples[0].startswith("follicle render ")
    page = ref.cli_reference()
    render = page[page.index("## `follicle render`") :]
    render = render[: render.index("## `follicle", 5)]
    assert "```bash\n" + "\n".join(examples) + "\n```" in render


# the unit of each key whose description stated one before units became part of the
# schema (", m" at its end, read by the reference then), and of those that had it in
# words ("turns per metre", "per second") or not at all (a camera position)
UNITS = {
    "[guides]": {"length": "m", "lift": "degrees"},
    "[groom]": {
        **dict.fromkeys(["offset_angle", "hue_variation", "strand_twist"], "degrees"),
        **dict.fromkeys(
            ["curl_radius", "frizz_root", "frizz_tip", "kink_root", "kink_tip", "root_width"]
            + ["tip_width", "strand_splay_root", "strand_splay_centre", "strand_splay_tip"]
            + ["strand_offset", "skin_clearance"],
            "m",
        ),
        **dict.fromkeys(
            ["frizz_frequency", "kink_frequency", "curl_frequency", "curl_frequency_tip"], "1/m"
        ),
        **dict.fromkeys(["root_color", "tip_color", "mutant_color", "dye"], "linear RGB"),
        "frizz_speed": "m/s",
        "settle": "s",
    },
    "[sim]": {
        **dict.fromkeys(["substep", "wind_gust_period", "motion_period"], "s"),
        **dict.fromkeys(["gravity", "wind"], "m/s²"),
        **dict.fromkeys(["drag", "damping"], "1/s"),
        **dict.fromkeys(["cone_angle", "motion_amplitude"], "degrees"),
        **dict.fromkeys(["shape_hold", "collision_margin", "skin_voxel", "motion_pivot"], "m"),
        "wind_frequency": "1/m",
        "wind_drift": "m/s",
    },
    "[[sim.colliders]]": dict.fromkeys(["centre", "a", "b", "radius"], "m"),
    "[render]": {
        **dict.fromkeys(["size", "lod"], "pixels"),
        **dict.fromkeys(["eye", "target", "hair_width"], "m"),
        **dict.fromkeys(
            ["background_top", "background_bottom", "hair_color", "skin_color"], "linear RGB"
        ),
        "fov": "degrees",
    },
    "[[render.lights]]": {"color": "linear RGB"},
    "[cards]": dict.fromkeys(["atlas", "padding", "strand_texels"], "texels"),
}
# the numbers without a unit: counts, shares, stiffnesses, factors, directions (their
# length does not matter) and the [mesh] / [guides] units themselves
NO_UNIT = {
    "[mesh]": {"units", "displacement_scale"},
    "[guides]": {"units", "comb", "gravity"},
    "[groom]": {"density", "cut", "scale", "random_scale", "clump_root", "clump_tip"}
    | {"clump_profile", "clump_noise", "frizz_direction", "frizz_blend"}
    | {"saturation_variation", "value_variation", "mutant_fraction", "melanin"}
    | {"melanin_redness", "random_melanin", "random_redness", "root_opacity", "tip_opacity"}
    | {"strand_aspect", "strand_randomize", "skip_threshold"},
    "[sim]": {"wind_turbulence", "wind_gust", "stretch_stiffness", "stretch_limit"}
    | {"stretch_limit_damping", "bend_stiffness", "bend_scale", "bend_attenuation"}
    | {"shape_local", "shape_global", "shape_global_range", "dftl_damping", "friction"}
    | {"volume_friction", "volume_repulsion"},
    "[[sim.colliders]]": {"normal"},
    "[render]": {"shading_params", "hair_opacity", "scalp_tint"},
    "[cards]": {"reserve", "alpha_cutoff"},
    "[[render.lights]]": {"direction", "intensity"},
}


def test_every_key_with_a_unit_has_it_in_its_schema_and_the_reference_shows_it():
    page = ref.scene_reference()
    tables = dict(ref.scene_tables())
    for table, units in UNITS.items():
        for key, unit in units.items():
            field = tables[table].model_fields[key]
            assert unit_of(field) == unit, (table, key)
            assert field.json_schema_extra == {"unit": unit}, (table, key)
            assert _row(page, table, key)[4] == unit, (table, key)
            # said once: the description no longer ends in its unit
            assert not (field.description or "").endswith(f", {unit}"), (table, key)


def test_every_number_has_a_unit_or_is_listed_as_having_none():
    """A new number key (a float, a vector, a textured property) fails here until it gets
    a unit (measured_in) or joins NO_UNIT; a listed key that gains a unit fails too."""
    numbers: dict[str, set[str]] = {}
    with_unit: dict[str, set[str]] = {}
    for table, model in ref.scene_tables():
        for key, field in model.model_fields.items():
            if field.exclude:
                continue
            kind, _ = ref._type_and_range(field.annotation, list(field.metadata))
            if unit_of(field):
                with_unit.setdefault(table, set()).add(key)
            elif "number" in kind:
                numbers.setdefault(table, set()).add(key)
    assert numbers == NO_UNIT
    assert with_unit == {table: set(units) for table, units in UNITS.items()}


def test_the_schema_carries_the_unit_and_a_typo_is_refused():
    from follicle.sim.settings import SimParams

    schema = SimParams.model_json_schema()["properties"]
    assert schema["gravity"]["unit"] == "m/s²"
    assert "unit" not in schema["iterations"]
    assert measured_in("m") == {"unit": "m"}
    with pytest.raises(ValueError, match="unknown unit 'metres'"):
        measured_in("metres")


def test_info_prints_each_unit_before_the_description():
    """`follicle info` (no scene: the defaults) shows the units the schema gives."""
    shown = CliRunner().invoke(main, ["info"]).output.splitlines()
    assert "frizz_tip = 0.0  # [m] (map) frizz amplitude at the tip" in shown
    assert (
        "gravity = [0.0, -9.81, 0.0]  # [m/s²] gravity (each component within ±100, about 10 g)"
        in shown
    )
    assert "fov = 30.0  # [degrees] vertical field of view" in shown
    assert "iterations = 8  # constraint iterations per substep" in shown
