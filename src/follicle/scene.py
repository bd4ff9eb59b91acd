"""Scene files: TOML with [mesh] [guides] [groom] [sim] [render] [output] sections.

Every section is a pydantic model that forbids unknown keys, so a typo is an error
naming the key instead of a silently ignored setting. Relative paths are resolved
against the scene file's folder. ``scene_to_toml`` writes a scene back out, with every
default filled in (``follicle info``).
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal, get_args

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PlainValidator,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from .errors import ConfigError, FormatError
from .io.inputs import input_file
from .io.targets import TARGET_NAMES
from .render.camera import DEFAULT_FOV
from .render.options import DEFAULT_BACKGROUND
from .units import UNITS, metres_per_unit, units_for

if TYPE_CHECKING:
    from typing_extensions import Self

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
    "load_scene",
    "parse_scene",
    "scene_to_toml",
    "MAX_SCENE_BYTES",
]

# a scene file is a few kB; 1 MiB bounds the time tomllib (pure Python, ~3 s a MiB of
# numbers here) can spend on a file given by mistake or malice
MAX_SCENE_BYTES = 1 << 20

Unit = Annotated[float, Field(ge=0.0, le=1.0)]
# a vector component (a position in m, a frequency in 1/m, an acceleration in m/s²):
# bounded like a mesh coordinate, so products of a few stay far from overflowing
Component = Annotated[float, Field(ge=-1e6, le=1e6)]
# strict sections want a tuple where TOML gives a list: the tuple takes a list, its
# items stay strict (a number, not true or "1")
RGB = Annotated[tuple[Unit, Unit, Unit], Field(strict=False)]
Vec3 = Annotated[tuple[Component, Component, Component], Field(strict=False)]
# an acceleration on the hair (gravity, wind): beyond ±100 m/s² (10 g) the skin's
# collisions and the strands' lengths fight and segments stretch (README: Dynamics)
MAX_ACCELERATION = 100.0
Accel = Annotated[float, Field(ge=-MAX_ACCELERATION, le=MAX_ACCELERATION)]
Acceleration = Annotated[tuple[Accel, Accel, Accel], Field(strict=False)]


class _Section(BaseModel):
    """A scene table: unknown keys are errors and no number may be NaN or infinite.

    A value, never changed in place: ``replace(key=value)`` makes a validated copy, which
    its owner takes whole (``Simulator.params``, ``Groom.params``, ``Scene.replace``) and
    so knows what to rebuild; assigning to a key raises ConfigError saying so."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    def __setattr__(self, name: str, value: object) -> None:
        kind = type(self).__name__
        raise ConfigError(
            f"{kind}.{name}: settings are values and do not change in place; make a changed"
            f" copy, {_owner_hint(kind, name)}"
        )

    def replace(self, source: str = "settings", **changes: object) -> Self:
        """A copy with ``changes`` applied and validated as a scene file's would be;
        ConfigError naming ``[section].key`` (``source`` names where they came from)."""
        data = {**self.model_dump(), **changes}
        section = _SECTION_NAMES.get(type(self))
        if section is not None:
            return getattr(parse_scene({section: data}, source), section)
        try:
            return type(self).model_validate(data)
        except ValidationError as err:
            raise ConfigError(_format_errors(source, err)) from None


class _StrictSection(_Section):
    """A table whose values keep their TOML type: ``count = true`` or ``count = "10"`` is
    an error, not 1 or 10 (a float key takes an integer, nothing else)."""

    model_config = ConfigDict(strict=True)


def _not_bool(v: object) -> object:
    """``v`` unless it is a bool (a Literal of numbers would take true as 1)."""
    if isinstance(v, bool):
        raise ValueError(f"expected a number (got {str(v).lower()})")
    return v


def _units(value: object) -> str | float:
    """A ``units`` value as given ("cm", or a number as float), else the reason why not."""
    metres_per_unit(value, key=None)
    return value if isinstance(value, str) else float(value)  # type: ignore[arg-type]


def _units_apply(value: str | float, info: ValidationInfo) -> str | float:
    """``units`` other than metres only for a file without a unit of its own (not for a
    builtin, nor USD or glTF): checked against the section's ``path``."""
    if "path" in info.data:
        units_for(info.data["path"], value, key=None)
    return value


# "m", "cm", "mm", "in" or metres per unit (follicle.units), as written in the scene; a
# name, not a path (the viewer's save_scene rewrites keys typed str)
UnitsSetting = Annotated[
    Literal[tuple(UNITS)] | float,  # type: ignore[valid-type]
    PlainValidator(_units, json_schema_input_type=Any),
]
_UNITS_HELP = (
    'the file\'s units, converted to metres when loaded: "m", "cm", "mm",'
    ' "in" or metres per unit; not for builtins or USD/glTF (they declare theirs)'
)


class MeshParams(_StrictSection):
    """The skin the hair grows on."""

    path: str = Field("builtin:head", description="mesh file (OBJ/PLY/GLB/STL) or builtin:head")
    units: UnitsSetting = Field("m", description=_UNITS_HELP)
    _units_fit_path = field_validator("units")(_units_apply)
    displacement: str | None = Field(
        None, description="displacement map (image path): roots sit on P + scale·D(uv)·N"
    )
    displacement_scale: float = Field(
        1.0, ge=-10, le=10, description="displacement in scene units per texture unit"
    )


class GuidesParams(_StrictSection):
    """The artist-made guide curves every hair is interpolated from."""

    path: str = Field("builtin:long", description="builtin:long|short|curly or a curves file")
    units: UnitsSetting = Field("m", description=_UNITS_HELP)
    _units_fit_path = field_validator("units")(_units_apply)


def _shown(x: object) -> str:
    """``x`` as TOML shows a bool, else ``repr(x)`` cut to 60 characters: an error message
    stays one short line whatever value (a megabyte string, a long list) it quotes."""
    text = str(x).lower() if isinstance(x, bool) else repr(x)
    return text if len(text) <= 60 else text[:57] + "..."


def _in_range(x: object, bounds: dict[str, float]) -> float:
    """``x`` as a float within ``bounds`` (pydantic-style ge/gt/le keys), else ValueError."""
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
        raise ValueError(f"expected a finite number (got {_shown(x)})")
    for key, sign, ok in (
        ("ge", "≥", x >= bounds.get("ge", -math.inf)),
        ("gt", ">", x > bounds.get("gt", -math.inf)),
        ("le", "≤", x <= bounds.get("le", math.inf)),
    ):
        if not ok:
            raise ValueError(f"must be {sign} {bounds[key]:g} (got {x!r})")
    return float(x)


def _prop_value(v: object, color: bool, bounds: dict[str, float]) -> float | tuple[float, ...]:
    if not color:
        return _in_range(v, bounds)
    if not isinstance(v, (list, tuple)) or len(v) != 3:
        raise ValueError(f"expected an [r, g, b] list of 3 numbers (got {_shown(v)})")
    try:
        return tuple(_in_range(c, {"ge": 0.0, "le": 1.0}) for c in v)
    except ValueError as exc:
        raise ValueError(f"colour components {exc}") from None


@dataclass(frozen=True)
class PropertyTag:
    """What marks a textured groom property in GroomParams' schema: an RGB colour or a
    number, and whether the number is a fraction in [0, 1] (clipped after value ×
    texture). :mod:`follicle.groom.properties` reads its lists from these tags."""

    color: bool
    fraction: bool


def _prop(color: bool = False, **bounds: float) -> Any:
    """A property (Šik 2012 §2.2.2): a number (or [r, g, b]), a texture path, or a table
    ``{value, texture, wrap}``; the value at a root is value × texture(uv)."""

    def check(v: object) -> object:
        if isinstance(v, str):
            if not v:
                raise ValueError("empty texture path")
            return v
        if isinstance(v, dict):
            unknown = sorted(set(v) - {"value", "texture", "wrap"})
            if unknown:
                raise ValueError(
                    f"unknown key(s) {_shown(unknown)}; a table takes value, texture, wrap"
                )
            if not isinstance(v.get("texture"), str) or not v["texture"]:
                raise ValueError('a table needs texture = "image path or builtin:name"')
            if v.get("wrap") not in (None, "repeat", "clamp"):
                raise ValueError(f'wrap must be "repeat" or "clamp" (got {_shown(v["wrap"])})')
            out = dict(v)
            out["value"] = _prop_value(v.get("value", (1.0,) * 3 if color else 1.0), color, bounds)
            return out
        return _prop_value(v, color, bounds)

    tag = PropertyTag(color, not color and bounds == {"ge": 0.0, "le": 1.0})
    return Annotated[Any, PlainValidator(check, json_schema_input_type=Any), tag]


Length = _prop(ge=0.0, le=10.0)
Fraction = _prop(ge=0.0, le=1.0)
Color = _prop(color=True)


class GroomParams(_StrictSection):
    """How many hairs grow and how they look (Šik 2012 §2.2).

    Properties marked "(map)" take a number, a texture path (value 1 × texture) or a
    table ``{value = ..., texture = "map.png", wrap = "repeat"}``: the value read at each
    hair root's UV is value × texture(uv).
    """

    count: int = Field(20000, ge=0, le=50_000_000, description="number of hairs")
    seed: int = Field(0, ge=0, lt=2**63, description="random seed")
    density: str | Annotated[float, Field(gt=0, le=1e6)] | None = Field(
        None,
        description="root density: a number (uniform; at most 1e6), an image path"
        " (PNG/JPEG/TIFF; 16-bit and float TIFF for HDR) or builtin:scalp; unset ="
        " builtin:scalp on the built-in head, uniform elsewhere",
    )
    density_refine: int = Field(
        0, ge=0, le=4, description="extra subdivision levels below the density texel size"
    )
    groups: str | None = Field(
        None,
        description="interpolation groups: an image (one group per colour), builtin:parting"
        " or none; a hair takes guides of its own group only; unset = builtin:parting for"
        " built-in guides on the built-in head (they part at its mid-plane), none elsewhere",
    )
    group_vertices: dict[str, Annotated[int, Field(ge=2, le=256)]] = Field(
        default_factory=dict,
        description='vertices per hair of a group, by colour: {"#ff0000" = 12}',
    )
    interpolation: Literal["idw", "barycentric", "offset"] = Field(
        "idw",
        description="idw: n+1 nearest guides; barycentric: the 3 guides of the enclosing"
        " triangle of the guide roots; offset: the nearest guide, rotated or translated",
    )
    guide_samples: int = Field(
        4, ge=1, le=32, description="idw: guides per hair (n; the (n+1)-th sets the radius)"
    )
    offset_mode: Literal["rotate", "translate"] = Field(
        "rotate", description="offset: turn the guide shape by random angles, or shift it"
    )
    offset_angle: float = Field(
        10.0, ge=0, le=90, description="offset rotate: largest random tilt, ± degrees"
    )
    vertices: int | None = Field(
        None, ge=2, le=256, description="vertices per hair; unset = as many as the guides have"
    )
    cut: Fraction = Field(1.0, description="(map) where hairs end: 1 whole, 0.5 half, 0 none")
    scale: _prop(gt=0.0, le=100.0) = Field(1.0, description="(map) length scale of hairs")
    random_scale: Fraction = Field(
        0.0, description="(map) random shortening: scale × (1 − random_scale·ξ)"
    )
    curl_radius: Length = Field(0.0, description="(map) curl helix radius, m (0: no curl)")
    curl_frequency: _prop(ge=-10000.0, le=10000.0) = Field(
        40.0, description="(map) curl turns per metre of hair at the root"
    )
    curl_frequency_tip: float | None = Field(
        None, ge=-10000, le=10000, description="curl turns per metre at the tip; unset = root"
    )
    clump_count: int = Field(0, ge=0, le=1_000_000, description="clumps (0: no clumping)")
    clump_root: Fraction = Field(0.0, description="(map) pull towards the clump centre at roots")
    clump_tip: Fraction = Field(0.8, description="(map) pull towards the clump centre at tips")
    clump_profile: float = Field(
        1.0, gt=0, le=10, description="shape of the pull from root to tip: t^profile"
    )
    clump_noise: Fraction = Field(0.2, description="(map) random weakening of each hair's pull")
    frizz_root: Length = Field(0.0, description="(map) frizz amplitude at the root, m")
    frizz_tip: Length = Field(0.0, description="(map) frizz amplitude at the tip, m")
    frizz_frequency: Vec3 = Field((20.0, 20.0, 20.0), description="frizz noise frequency, 1/m")
    frizz_direction: Vec3 = Field((0.0, 1.0, 0.0), description="animated frizz: noise drift")
    frizz_speed: float = Field(0.0, ge=0, le=1000, description="animated frizz: drift, m/s")
    frizz_blend: Fraction = Field(0.0, description="(map) share of animated frizz")
    kink_root: Length = Field(0.0, description="(map) kink amplitude at the root, m")
    kink_tip: Length = Field(0.0, description="(map) kink amplitude at the tip, m")
    kink_frequency: Vec3 = Field((60.0, 60.0, 60.0), description="kink noise frequency, 1/m")
    root_width: _prop(gt=0.0, le=0.1) = Field(80e-6, description="(map) diameter at root, m")
    tip_width: _prop(gt=0.0, le=0.1) = Field(30e-6, description="(map) diameter at tip, m")
    root_color: Color = Field((0.03, 0.017, 0.009), description="(map) linear RGB at the root")
    tip_color: Color = Field((0.085, 0.05, 0.025), description="(map) linear RGB at the tip")
    hue_variation: _prop(ge=0.0, le=180.0) = Field(
        0.0, description="(map) per-hair hue shift, ± degrees"
    )
    saturation_variation: Fraction = Field(0.0, description="(map) per-hair saturation shift, ±")
    value_variation: Fraction = Field(0.0, description="(map) per-hair value shift, ±")
    mutant_fraction: Fraction = Field(0.0, description="(map) share of hairs in mutant_color")
    mutant_color: Color = Field((0.8, 0.8, 0.8), description="(map) linear RGB of mutant hairs")
    root_opacity: Fraction = Field(1.0, description="(map) opacity at the root")
    tip_opacity: Fraction = Field(1.0, description="(map) opacity at the tip")
    strand_count: int = Field(1, ge=1, le=64, description="fibres per hair strand (1: plain)")
    strand_splay_root: Length = Field(0.0, description="(map) strand radius at the root, m")
    strand_splay_centre: Length = Field(0.002, description="(map) strand radius mid-way, m")
    strand_splay_tip: Length = Field(0.001, description="(map) strand radius at the tip, m")
    strand_twist: _prop(ge=-36000.0, le=36000.0) = Field(
        0.0, description="(map) strand twist from root to tip, degrees"
    )
    strand_aspect: _prop(ge=0.0, le=100.0) = Field(
        1.0, description="(map) strand cross-section: binormal / normal radius"
    )
    strand_offset: _prop(ge=-10.0, le=10.0) = Field(
        0.0, description="(map) strand tips pushed along the curve normal (t³), m"
    )
    strand_randomize: Fraction = Field(0.0, description="(map) random shortening of fibres")
    skip_threshold: Annotated[float, Field(gt=0.0, le=1.0)] | None = Field(
        None,
        description="drop a vertex whose tangent is within acos(threshold) of both"
        " neighbours' (e.g. 0.9995); unset = keep all",
    )


class ColliderParams(_StrictSection):
    """A sphere (centre, radius) or capsule (a, b, radius) the hair cannot enter."""

    kind: Literal["sphere", "capsule"] = Field("sphere", description="sphere or capsule")
    centre: Vec3 = Field((0.0, 0.0, 0.0), description="sphere centre, m")
    a: Vec3 = Field((0.0, 0.0, 0.0), description="capsule axis start, m")
    b: Vec3 = Field((0.0, 0.0, 0.0), description="capsule axis end, m")
    radius: float = Field(0.1, gt=0, le=100, description="radius, m")
    follow: bool = Field(
        True, description="moves with the transform given to set_pose (the head); false: fixed"
    )


class SimParams(_StrictSection):
    """Guide-strand dynamics (Almeida 2014 §3, Le Muzic 2012 §5.1.2–5.1.3)."""

    solver: Literal["pbd", "dftl"] = Field(
        "pbd", description="inextensibility: PBD distance constraints or Dynamic Follow-The-Leader"
    )
    integrator: Literal["verlet", "euler"] = Field(
        "verlet", description="Verlet (Le Muzic 2012 eq. 5.1) or semi-implicit Euler"
    )
    substep: float = Field(
        1 / 120,
        gt=0,
        le=1 / 30,
        description="internal fixed time step, s"
        " (at most 1/30: longer steps let the skin sweep through the hair)",
    )
    iterations: int = Field(8, ge=1, le=200, description="constraint iterations per substep")
    vertices: int | None = Field(
        None, ge=2, le=256, description="vertices per simulated strand; unset = the guides'"
    )
    gravity: Acceleration = Field(
        (0.0, -9.81, 0.0), description="gravity, m/s² (each component within ±100, about 10 g)"
    )
    damping: float = Field(0.5, ge=0, le=100, description="velocity damping per second")
    drag: float = Field(
        0.0, ge=0, le=1000, description="air drag b of −b·v (Le Muzic 2012 eq. 5.3), 1/s"
    )
    wind: Acceleration = Field(
        (0.0, 0.0, 0.0),
        description="wind acceleration w of Le Muzic"
        " 2012 eq. 5.2, m/s² (each component within ±100)",
    )
    wind_turbulence: float = Field(
        0.5, ge=0, le=10, description="noise added to the wind, relative to its strength"
    )
    wind_frequency: float = Field(4.0, ge=0, le=1000, description="turbulence frequency, 1/m")
    wind_drift: Vec3 = Field(
        (1.0, 0.0, 0.0), description="speed the turbulence pattern drifts with, m/s"
    )
    wind_gust: float = Field(
        0.0,
        ge=0,
        le=100,
        description="gusts: the wind × (1 + gust·g(t)), g a smooth noise in [0, 1]; 0 = steady",
    )
    wind_gust_period: float = Field(2.0, gt=0, le=1000, description="typical gust length, s")
    stretch_stiffness: Unit = Field(1.0, description="PBD distance constraint stiffness")
    stretch_limit: float | None = Field(
        1e-4,
        ge=0,
        le=1,
        description="PBD: afterwards no segment longer than (1 + limit) × rest; unset = off",
    )
    stretch_limit_damping: Unit = Field(
        0.8,
        description="PBD: the limit's moves leave velocities like DFTL's (Almeida 2014 eq. 3.1)",
    )
    bend_stiffness: Unit = Field(0.2, description="bending (Le Muzic 2012 eq. 5.6) stiffness")
    bend_scale: float = Field(
        1.0,
        ge=0.5,
        le=10,
        description="bending rest distances × scale (> 1 stiffens; below"
        " 0.5 the rest distances pull the strand into its root and fight inextensibility)",
    )
    bend_attenuation: float = Field(
        1.0, ge=0, le=100, description="bending weakens along the strand: k / (1 + att·(i−1))"
    )
    cone_angle: float = Field(
        180.0, gt=0, le=180, description="largest turn between segments, degrees; 180 = off"
    )
    shape_local: Unit = Field(
        0.0, description="stiffness towards each segment's rest direction (local shape)"
    )
    shape_global: Unit = Field(
        0.05,
        description="stiffness towards the skinned rest pose (0.05 keeps a groom's"
        " style under gravity and still lets it swing; 0 = hair falls freely)",
    )
    shape_global_range: Annotated[tuple[Unit, Unit], Field(strict=False)] = Field(
        (0.0, 1.0),
        description="global shape: full up to the first, zero from the second"
        " (root-to-tip fractions)",
    )
    dftl_damping: Unit = Field(0.9, description="DFTL velocity correction s (Almeida 2014 eq. 3.1)")
    collision_margin: float = Field(
        0.002, ge=0, le=1, description="distance kept from colliders, m"
    )
    friction: Unit = Field(0.3, description="share of tangential speed lost in contact")
    colliders: list[ColliderParams] = Field(
        default_factory=list, description="spheres and capsules: [[sim.colliders]] tables"
    )
    skin_collision: bool = Field(
        True, description="collide with the skin mesh through its signed distance field"
    )
    skin_voxel: float | None = Field(
        None,
        gt=0,
        le=1,
        description="skin SDF voxel size, m; unset = the mesh's longest side / 64",
    )
    volume_friction: Unit = Field(
        0.05,
        description="hair-hair friction: velocities pulled to the grid's (Almeida 2014 eq. 3.4)",
    )
    volume_repulsion: float = Field(
        0.0,
        ge=0,
        le=1,
        description="hair-hair repulsion down the density gradient, voxels"
        " per substep (Almeida 2014 eq. 3.5–3.7)",
    )
    volume_resolution: int = Field(
        32, ge=2, le=128, description="hair volume grid: cells along the hair's longest side"
    )
    volume_blur: int = Field(1, ge=0, le=8, description="box-blur passes on the volume grid")
    motion: Literal["none", "turn", "nod", "shake"] = Field(
        "none", description="`follicle simulate`: the built-in head animation"
    )
    motion_amplitude: float = Field(40.0, ge=0, le=180, description="head animation angle, degrees")
    motion_period: float = Field(2.0, gt=0, le=100, description="head animation period, s")
    motion_pivot: Vec3 | None = Field(
        None, description="head animation pivot; unset = the neck (bottom centre of the mesh)"
    )

    @model_validator(mode="after")
    def _range_ordered(self) -> SimParams:
        if self.shape_global_range[0] > self.shape_global_range[1]:
            raise ValueError("shape_global_range: the start must not exceed the end")
        return self

    @model_validator(mode="after")
    def _wind_bounded(self) -> SimParams:
        """Gusts and turbulence scale the wind: its peak, like gravity, stays ≤ 100 m/s²."""
        peak = max(map(abs, self.wind)) * (1 + self.wind_gust) * (1 + self.wind_turbulence)
        if peak > MAX_ACCELERATION:
            raise ValueError(
                f"wind × (1 + wind_gust) × (1 + wind_turbulence) peaks at {peak:.4g} m/s²; at"
                f" most {MAX_ACCELERATION:g} (10 g): lower wind, wind_gust or wind_turbulence"
            )
        return self


class LightParams(_StrictSection):
    """A light of the render: `[[render.lights]]` tables, in order; the first
    directional one is the key light, the one that casts shadows."""

    type: Literal["directional", "ambient"] = Field(
        "directional", description="directional or ambient (uniform, from everywhere)"
    )
    direction: Vec3 = Field((0.0, 1.0, 0.0), description="towards the light (directional only)")
    space: Literal["camera", "world"] = Field(
        "camera",
        description="direction in camera space (x right, y up, z towards the viewer;"
        " the light follows the camera) or world space",
    )
    color: RGB = Field((1.0, 1.0, 1.0), description="linear RGB")
    intensity: float = Field(1.0, ge=0, le=1000, description="scales the colour")

    @model_validator(mode="after")
    def _has_direction(self) -> LightParams:
        if self.type == "directional" and not any(self.direction):
            raise ValueError("direction: a directional light needs a non-zero direction")
        return self


class RenderParams(_StrictSection):
    """The offline OpenGL render."""

    size: Annotated[
        tuple[Annotated[int, Field(ge=1, le=8192)], Annotated[int, Field(ge=1, le=8192)]],
        Field(strict=False),
    ] = Field((960, 960), description="image width and height, pixels")
    shading: Literal["kajiya-kay", "scheuermann", "marschner"] = Field(
        "kajiya-kay", description="hair shading model"
    )
    shading_params: dict[str, float | Vec3] = Field(
        default_factory=dict,
        description="the model's parameters, e.g. {specular = 0.3} (README: Rendering)",
    )
    shadows: bool = Field(True, description="the key light casts hair and skin shadows")
    lights: list[LightParams] = Field(
        default_factory=list,
        description="[[render.lights]] tables; none: key, fill and rim"
        " lights that follow the camera, and a little ambient",
    )
    msaa: Annotated[Literal[0, 1, 2, 4, 8, 16], BeforeValidator(_not_bool)] = Field(
        4, description="multisample anti-aliasing samples"
    )
    subdivisions: int = Field(
        4,
        ge=1,
        le=16,
        description="most Catmull-Rom steps per segment"
        " (fewer where it is short and straight on screen)",
    )
    eye: Vec3 | None = Field(None, description="camera position; unset = framed automatically")
    target: Vec3 | None = Field(None, description="camera target; unset = framed automatically")
    fov: float = Field(DEFAULT_FOV, gt=1, lt=170, description="vertical field of view, degrees")
    background_top: RGB = Field(DEFAULT_BACKGROUND[0], description="background gradient top")
    background_bottom: RGB = Field(DEFAULT_BACKGROUND[1], description="background gradient bottom")

    @model_validator(mode="after")
    def _eye_and_target_together(self) -> RenderParams:
        if (self.eye is None) != (self.target is None):
            raise ValueError("set both eye and target, or neither (automatic framing)")
        return self

    @model_validator(mode="after")
    def _shading_params_fit_the_model(self) -> RenderParams:
        from .errors import InputError
        from .render.options import parse_shading

        try:
            parse_shading(self.shading, self.shading_params)
        except InputError as exc:
            raise ValueError(str(exc)) from None
        return self

    def light_list(self) -> list | None:
        """The lights as :class:`follicle.render.Light` objects; None: the default rig."""
        from .render.camera import Light

        return [
            Light(None if p.type == "ambient" else p.direction, p.color, p.intensity, p.space)
            for p in self.lights
        ] or None


class OutputParams(_StrictSection):
    """Where `follicle grow` / `follicle render` write when no -o is given."""

    curves: str = Field("hair.npz", description="grown curves file")
    image: str = Field("hair.png", description="rendered image")
    target: Literal[TARGET_NAMES] = Field(  # type: ignore[valid-type]
        "generic",
        description="the tool USD / Alembic output is written for: its attribute"
        " names, types and units (README: Formats, Targets)",
    )


class Scene(_StrictSection):
    """A whole scene; every section optional."""

    mesh: MeshParams = Field(default_factory=MeshParams)
    guides: GuidesParams = Field(default_factory=GuidesParams)
    groom: GroomParams = Field(default_factory=GroomParams)
    sim: SimParams = Field(default_factory=SimParams)
    render: RenderParams = Field(default_factory=RenderParams)
    output: OutputParams = Field(default_factory=OutputParams)
    base_dir: Path = Field(Path("."), exclude=True, description="folder relative paths start in")

    def replace(self, source: str = "settings", **changes: object) -> Scene:
        """A copy with whole sections (a SimParams for ``sim``, …) or ``base_dir``
        replaced; ConfigError for an unknown section or a value of the wrong type."""
        for key, value in changes.items():
            field = Scene.model_fields.get(key)
            if field is None:
                raise ConfigError(
                    f"{source}: {key}: unknown scene section; allowed:"
                    f" {', '.join(Scene.model_fields)}"
                )
            want = Path if key == "base_dir" else field.annotation
            if not isinstance(value, want):
                raise ConfigError(
                    f"{source}: {key}: expected {want.__name__}, got {type(value).__name__}"
                )
        return self.model_copy(update=changes)

    def resolve(self, path: str) -> str:
        """A scene path made absolute against the scene's folder (builtins untouched)."""
        if path.startswith("builtin:") or os.path.isabs(path):
            return path
        return str(self.base_dir / path)


# each section's class and its [name] in a scene file
_SECTION_NAMES: dict[type, str] = {
    f.annotation: name
    for name, f in Scene.model_fields.items()
    if isinstance(f.annotation, type) and issubclass(f.annotation, _Section)
}
_OWNERS = {"SimParams": "Simulator.params", "GroomParams": "Groom.params"}


def _owner_hint(kind: str, name: str) -> str:
    """How to change ``kind``'s key ``name``: a copy from replace, given to its owner."""
    if kind == "Scene":
        return f"scene = scene.replace({name}=...)"
    owner = _OWNERS.get(kind)
    where = f", and give it to {owner}" if owner else ""
    return f"params = params.replace({name}=...){where}"


def _format_errors(source: str, err: ValidationError) -> str:
    by_place: dict[str, str] = {}
    for e in err.errors():
        loc = [str(p) for p in e["loc"] if not str(p).startswith(("function-", "tuple["))]
        loc = [p if p.isprintable() else repr(p) for p in loc]  # a key "a\nb": one line
        # unions report a branch name ('str', 'float') as a location step: drop them
        loc = [p for p in loc if p not in {"str", "float", "int", "none", "constrained-float"}]
        section = f"[{loc[0]}]" if loc else "scene"
        key = ".".join(loc[1:]) if len(loc) > 1 else ""
        where = f"{section}{'.' + key if key else ''}"
        if e["type"] == "extra_forbidden" or loc == ["base_dir"]:  # the loader sets base_dir
            allowed = _allowed_keys(loc)
            by_place[where] = f"{source}: {where}: unknown key; allowed keys: {allowed}"
        elif where not in by_place or not e["type"].endswith("_type"):
            # a union reports each branch; a range message beats a type mismatch
            got = e.get("input")
            shown = "" if isinstance(got, dict) or "(got" in e["msg"] else f" (got {_shown(got)})"
            msg = e["msg"].removeprefix("Value error, ")
            by_place[where] = f"{source}: {where}: {msg}{shown}"
    # a union of a number and a list reports the value and an item of it: keep the value's
    # one line, problems joined: the CLI promises one line
    return "; ".join(
        line
        for where, line in by_place.items()
        if not any(where.startswith(other + ".") for other in by_place)
    )


def _allowed_keys(loc: list[str]) -> str:
    """The keys of the table at ``loc`` (its last step the unknown key), following
    sections, nested tables and list entries such as ``[[render.lights]]``."""
    model: type[BaseModel] = Scene
    for step in loc[:-1]:
        if step.isdigit():  # an entry of a list of tables: its model is the list's
            continue
        field = model.model_fields.get(step)
        kinds = (field.annotation, *get_args(field.annotation)) if field else ()
        tables = [k for k in kinds if isinstance(k, type) and issubclass(k, BaseModel)]
        if not tables:
            break
        model = tables[0]
    return ", ".join(k for k, f in model.model_fields.items() if not f.exclude)


def parse_scene(data: dict[str, Any], source: str = "scene", base_dir: Path | None = None) -> Scene:
    """Validate a scene dictionary (as read from TOML)."""
    try:
        scene = Scene.model_validate(data)
    except ValidationError as err:
        raise ConfigError(_format_errors(source, err)) from None
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
    p = Path(path)
    if not os.path.lexists(p):
        raise FormatError(f"{p}: no such scene file")
    input_file(p, "scene file (TOML)")
    try:
        with open(p, "rb") as fh:
            raw = fh.read(MAX_SCENE_BYTES + 1)
    except OSError as exc:
        raise FormatError(f"{p}: cannot be read ({exc.strerror or exc})") from None
    if len(raw) > MAX_SCENE_BYTES:
        raise ConfigError(
            f"{p}: larger than {MAX_SCENE_BYTES >> 20} MiB; a scene file is a short TOML text"
        )
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{p}: not a UTF-8 text file (bad byte at offset {exc.start})") from None
    return scene_from_toml(text, str(p), p.resolve().parent)


def scene_from_toml(text: str, source: str, base_dir: Path | None = None) -> Scene:
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
            raise ConfigError(f"cannot write {_shown(value)} to TOML: it is not valid Unicode")
        return '"' + value.translate(_TOML_ESCAPES) + '"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        pairs = (f"{_toml_value(k)} = {_toml_value(v)}" for k, v in value.items())
        return "{" + ", ".join(pairs) + "}"
    raise ConfigError(f"cannot write a {type(value).__name__} to TOML")


def scene_to_toml(scene: Scene, comments: bool = True) -> str:
    """The scene as TOML text with every default filled in (unset values commented out)."""
    out: list[str] = []
    for section, field in Scene.model_fields.items():
        if field.exclude:
            continue
        model: BaseModel = getattr(scene, section)
        out.append(f"[{section}]")
        for key, sub in type(model).model_fields.items():
            value = getattr(model, key)
            note = f"  # {sub.description}" if comments and sub.description else ""
            if value is None:
                out.append(f"# {key} = (unset){note}")
            else:
                out.append(f"{key} = {_toml_value(value)}{note}")
        out.append("")
    return "\n".join(out)
