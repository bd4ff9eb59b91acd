"""[groom]: how many hairs grow and how they look (Šik 2012 §2.2), and the tags that mark
its textured properties (read by :mod:`follicle.groom.properties`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, Literal, TypeAlias

from pydantic import Field, GetCoreSchemaHandler, PlainValidator, field_validator, model_validator
from pydantic_core import core_schema

from ..settings import RGB, StrictSection, Unit, Vec3, measured_in, shown, suggestions

__all__ = ["GroomParams", "PropertyTag", "MELANIN_KEYS", "COLOR_KEYS"]

# what melanin colours hair with, and the keys of root/tip colouring it takes the place of
MELANIN_KEYS = ("melanin_redness", "dye", "random_melanin", "random_redness")
COLOR_KEYS = (
    "root_color",
    "tip_color",
    "hue_variation",
    "saturation_variation",
    "value_variation",
    "mutant_fraction",
    "mutant_color",
)


def _in_range(x: object, bounds: dict[str, float]) -> float:
    """``x`` as a float within ``bounds`` (pydantic-style ge/gt/le keys), else ValueError."""
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
        raise ValueError(f"expected a finite number (got {shown(x)})")
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
        raise ValueError(f"expected an [r, g, b] list of 3 numbers (got {shown(v)})")
    try:
        return tuple(_in_range(c, {"ge": 0.0, "le": 1.0}) for c in v)
    except ValueError as exc:
        raise ValueError(f"colour components {exc}") from None


@dataclass(frozen=True)
class PropertyTag:
    """What marks a textured groom property in GroomParams' schema: an RGB colour or a
    number, whether the number is a fraction in [0, 1] (clipped after value × texture),
    and the least a number may be (``low``: a texture may not push a length or an
    amplitude below 0). :mod:`follicle.groom.properties` reads its lists from these tags."""

    color: bool
    fraction: bool
    low: float | None = None


@dataclass(frozen=True)
class _Property(PropertyTag):
    """A property's Annotated metadata (Šik 2012 §2.2.2): its PropertyTag, and the check
    of a number (or [r, g, b]) within ``bounds``, a texture path, or a table
    ``{value, texture, wrap}``; the value at a root is value × texture(uv).

    One object is both the tag and the validator, so each property is a plain
    ``Annotated[Any, _prop(...)]`` alias that a type checker reads as what it holds."""

    # compared too: typing caches Annotated[Any, tag] by the tag's equality, so two
    # properties of other bounds must never be equal (hue_variation ≤ 180, not Length's 10)
    bounds: tuple[tuple[str, float], ...] = ()

    def check(self, v: object) -> object:
        bounds = dict(self.bounds)
        if isinstance(v, str):
            if not v:
                raise ValueError("empty texture path")
            return v
        if isinstance(v, dict):
            unknown = sorted(set(v) - {"value", "texture", "wrap"})
            if unknown:
                meant = suggestions(str(unknown[0]), ["value", "texture", "wrap"])
                hint = f"did you mean {' or '.join(meant)}? " if meant else ""
                raise ValueError(
                    f"unknown key(s) {shown(unknown)}; {hint}a table takes value, texture, wrap"
                )
            if not isinstance(v.get("texture"), str) or not v["texture"]:
                raise ValueError('a table needs texture = "image path or builtin:name"')
            if v.get("wrap") not in (None, "repeat", "clamp"):
                raise ValueError(f'wrap must be "repeat" or "clamp" (got {shown(v["wrap"])})')
            out = dict(v)
            default = (1.0,) * 3 if self.color else 1.0
            out["value"] = _prop_value(v.get("value", default), self.color, bounds)
            return out
        return _prop_value(v, self.color, bounds)

    def __get_pydantic_core_schema__(
        self, source: Any, handler: GetCoreSchemaHandler
    ) -> core_schema.CoreSchema:
        validator = PlainValidator(self.check, json_schema_input_type=Any)
        return validator.__get_pydantic_core_schema__(source, handler)


def _prop(color: bool = False, **bounds: float) -> _Property:
    """The metadata of a "(map)" property: ``Annotated[Any, _prop(ge=0.0, le=10.0)]``."""
    fraction = not color and bounds == {"ge": 0.0, "le": 1.0}
    low = None if color or fraction else bounds.get("ge")
    return _Property(color, fraction, low, tuple(bounds.items()))


# A property holds a number (or [r, g, b]), a texture path or a table, hence Any.
Length: TypeAlias = Annotated[Any, _prop(ge=0.0, le=10.0)]
Fraction: TypeAlias = Annotated[Any, _prop(ge=0.0, le=1.0)]
Color: TypeAlias = Annotated[Any, _prop(color=True)]
# a generated guide's length ([guides].length): value × texture, more than 0 (a texel of
# 0 grows no guide there)
GuideLength: TypeAlias = Annotated[Any, _prop(gt=0.0, le=1000.0)]


class GroomParams(StrictSection):
    """How many hairs grow and how they look (Šik 2012 §2.2).

    Properties marked "(map)" take a number, a texture path (value 1 × texture) or a
    table ``{value = ..., texture = "map.png", wrap = "repeat"}``: the value read at each
    hair root's UV is value × texture(uv).
    """

    _section: ClassVar[str] = "groom"
    _owner: ClassVar[str] = "Groom.params"

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
        10.0,
        ge=0,
        le=90,
        description="offset rotate: largest random tilt, either way",
        json_schema_extra=measured_in("degrees"),
    )
    vertices: int | None = Field(
        None, ge=2, le=256, description="vertices per hair; unset = as many as the guides have"
    )
    cut: Fraction = Field(1.0, description="(map) where hairs end: 1 whole, 0.5 half, 0 none")
    scale: Annotated[Any, _prop(gt=0.0, le=100.0)] = Field(
        1.0, description="(map) length scale of hairs"
    )
    random_scale: Fraction = Field(
        0.0, description="(map) random shortening: scale × (1 − random_scale·ξ)"
    )
    curl_radius: Length = Field(
        0.0, description="(map) curl helix radius (0: no curl)", json_schema_extra=measured_in("m")
    )
    curl_frequency: Annotated[Any, _prop(ge=-10000.0, le=10000.0)] = Field(
        40.0,
        description="(map) curl turns per metre of hair at the root",
        json_schema_extra=measured_in("1/m"),
    )
    curl_frequency_tip: float | None = Field(
        None,
        ge=-10000,
        le=10000,
        description="curl turns per metre at the tip; unset = root",
        json_schema_extra=measured_in("1/m"),
    )
    clump_count: int = Field(0, ge=0, le=1_000_000, description="clumps (0: no clumping)")
    clump_root: Fraction = Field(0.0, description="(map) pull towards the clump centre at roots")
    clump_tip: Fraction = Field(0.8, description="(map) pull towards the clump centre at tips")
    clump_profile: float = Field(
        1.0, gt=0, le=10, description="shape of the pull from root to tip: t^profile"
    )
    clump_noise: Fraction = Field(0.2, description="(map) random weakening of each hair's pull")
    frizz_root: Length = Field(
        0.0, description="(map) frizz amplitude at the root", json_schema_extra=measured_in("m")
    )
    frizz_tip: Length = Field(
        0.0, description="(map) frizz amplitude at the tip", json_schema_extra=measured_in("m")
    )
    frizz_frequency: Vec3 = Field(
        (20.0, 20.0, 20.0),
        description="frizz noise frequency",
        json_schema_extra=measured_in("1/m"),
    )
    frizz_direction: Vec3 = Field((0.0, 1.0, 0.0), description="animated frizz: noise drift")
    frizz_speed: float = Field(
        0.0,
        ge=0,
        le=1000,
        description="animated frizz: drift speed",
        json_schema_extra=measured_in("m/s"),
    )
    frizz_blend: Fraction = Field(0.0, description="(map) share of animated frizz")
    kink_root: Length = Field(
        0.0, description="(map) kink amplitude at the root", json_schema_extra=measured_in("m")
    )
    kink_tip: Length = Field(
        0.0, description="(map) kink amplitude at the tip", json_schema_extra=measured_in("m")
    )
    kink_frequency: Vec3 = Field(
        (60.0, 60.0, 60.0), description="kink noise frequency", json_schema_extra=measured_in("1/m")
    )
    root_width: Annotated[Any, _prop(gt=0.0, le=0.1)] = Field(
        240e-6,
        description="(map) diameter at root (3× a real hair: docs, Rendering)",
        json_schema_extra=measured_in("m"),
    )
    tip_width: Annotated[Any, _prop(gt=0.0, le=0.1)] = Field(
        90e-6, description="(map) diameter at tip", json_schema_extra=measured_in("m")
    )
    root_color: Color = Field(
        (0.03, 0.017, 0.009),
        description="(map) colour at the root",
        json_schema_extra=measured_in("linear RGB"),
    )
    tip_color: Color = Field(
        (0.085, 0.05, 0.025),
        description="(map) colour at the tip",
        json_schema_extra=measured_in("linear RGB"),
    )
    hue_variation: Annotated[Any, _prop(ge=0.0, le=180.0)] = Field(
        0.0, description="(map) per-hair hue shift, ±", json_schema_extra=measured_in("degrees")
    )
    saturation_variation: Fraction = Field(0.0, description="(map) per-hair saturation shift, ±")
    value_variation: Fraction = Field(0.0, description="(map) per-hair value shift, ±")
    mutant_fraction: Fraction = Field(0.0, description="(map) share of hairs in mutant_color")
    mutant_color: Color = Field(
        (0.8, 0.8, 0.8),
        description="(map) colour of mutant hairs",
        json_schema_extra=measured_in("linear RGB"),
    )
    melanin: float | None = Field(
        None,
        ge=0.0,
        le=1.0,
        description="hair colour by pigment, Blender's Principled Hair Melanin: blond ≈ 0.2,"
        " brown ≈ 0.6, black ≈ 0.95; in place of root/tip_color, *_variation and mutants;"
        " unset = those",
    )
    melanin_redness: Unit = Field(
        0.0, description="with melanin: share of pheomelanin (red), 0 brown–black, 1 red"
    )
    dye: RGB = Field(
        (1.0, 1.0, 1.0),
        description="with melanin: dye on the pigment (white: none)",
        json_schema_extra=measured_in("linear RGB"),
    )
    random_melanin: Unit = Field(
        0.0,
        description="with melanin: per-hair melanin × (1 ± random_melanin), Blender's Random Color",
    )
    random_redness: Unit = Field(
        0.0, description="with melanin: per-hair melanin_redness × (1 ± random_redness)"
    )
    root_opacity: Fraction = Field(1.0, description="(map) opacity at the root")
    tip_opacity: Fraction = Field(1.0, description="(map) opacity at the tip")
    strand_count: int = Field(1, ge=1, le=64, description="fibres per hair strand (1: plain)")
    strand_splay_root: Length = Field(
        0.0, description="(map) strand radius at the root", json_schema_extra=measured_in("m")
    )
    strand_splay_centre: Length = Field(
        0.002, description="(map) strand radius mid-way", json_schema_extra=measured_in("m")
    )
    strand_splay_tip: Length = Field(
        0.001, description="(map) strand radius at the tip", json_schema_extra=measured_in("m")
    )
    strand_twist: Annotated[Any, _prop(ge=-36000.0, le=36000.0)] = Field(
        0.0,
        description="(map) strand twist from root to tip",
        json_schema_extra=measured_in("degrees"),
    )
    strand_aspect: Annotated[Any, _prop(ge=0.0, le=100.0)] = Field(
        1.0, description="(map) strand cross-section: binormal / normal radius"
    )
    strand_offset: Annotated[Any, _prop(ge=-10.0, le=10.0)] = Field(
        0.0,
        description="(map) strand tips pushed along the curve normal (t³)",
        json_schema_extra=measured_in("m"),
    )
    strand_randomize: Fraction = Field(0.0, description="(map) random shortening of fibres")
    inherit: Annotated[tuple[str, ...], Field(strict=False, max_length=64)] = Field(
        (),
        description="the guides' point and curve attributes the hairs take, blended by"
        ' their interpolation weights: ["color", "width", …]; an inherited color, width'
        " or opacity replaces the one of root_*/tip_*",
    )
    settle: float = Field(
        0.0,
        ge=0,
        le=60,
        description="how long the guides run [sim] dynamics (gravity, the skin and"
        " [[sim.colliders]], the head still) before growing: long hair falls onto the"
        " shoulders and rests, and that is the rest shape grown, rendered, exported and"
        " simulated from; at most 60; 0 = the guides as given",
        json_schema_extra=measured_in("s"),
    )
    skin_collision: bool = Field(
        True,
        description="keep grown hairs off the skin: a hair with a vertex inside it or"
        " nearer than skin_clearance is rebuilt from its root, each vertex pushed out"
        " along the skin's normal (its SDF's) at its segment's length from the one"
        " before, so lengths are kept; false = the hairs as interpolated",
    )
    skin_clearance: float = Field(
        0.001,
        ge=0,
        le=0.1,
        description="with skin_collision: distance kept between hair vertices and the skin",
        json_schema_extra=measured_in("m"),
    )
    skip_threshold: Annotated[float, Field(gt=0.0, le=1.0)] | None = Field(
        None,
        description="drop a vertex whose tangent is within acos(threshold) of both"
        " neighbours' (e.g. 0.9995); unset = keep all",
    )

    @field_validator("inherit")
    @classmethod
    def _names(cls, names: tuple[str, ...]) -> tuple[str, ...]:
        """Attribute names: not empty, each once."""
        if any(not name for name in names):
            raise ValueError("an attribute name is empty")
        twice = sorted({name for name in names if names.count(name) > 1})
        if twice:
            raise ValueError(f"{shown(twice)} named more than once")
        return names

    @model_validator(mode="after")
    def _one_way_to_colour(self) -> GroomParams:
        """Hair is coloured by melanin or by root/tip colours, never both: a key of the
        way not taken, changed from its default, would silently do nothing."""
        if self.melanin is not None and "color" in self.inherit:
            raise ValueError(
                "inherit: melanin gives the hair's colour; take color from the guides or"
                " melanin, not both"
            )
        unused = COLOR_KEYS if self.melanin is not None else MELANIN_KEYS
        fields = type(self).model_fields
        for key in unused:
            if getattr(self, key) != fields[key].default:
                if self.melanin is not None:
                    raise ValueError(
                        f"{key}: melanin gives the hair's colour; unset {key} or melanin"
                    )
                raise ValueError(f"{key}: takes effect with melanin only; set melanin too")
        return self
