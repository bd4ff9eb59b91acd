"""[render]: the settings of a render, one object for every renderer (the OpenGL
:func:`~follicle.render.render_image` and :class:`~follicle.render.Renderer`, Mitsuba, the
viewer), and the lights of ``[[render.lights]]``.

Every default is defined once, in :mod:`.options` and :mod:`.camera`, and read here.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import BeforeValidator, Field, model_validator

from ..errors import ConfigError, InputError
from ..settings import RGB, StrictSection, Unit, Vec3, measured_in, not_bool, shown
from .camera import DEFAULT_FOV, Camera, Light
from .options import (
    DEFAULT_BACKGROUND,
    DEFAULT_HAIR_COLOR,
    DEFAULT_HAIR_OPACITY,
    DEFAULT_HAIR_WIDTH,
    DEFAULT_SCALP_TINT,
    DEFAULT_SHADOW_SIZE,
    DEFAULT_SKIN_COLOR,
    ENGINE_NAMES,
    MAX_SHADOW_SIZE,
    MAX_SIZE,
    MAX_SPP,
    MAX_SUBDIVISIONS,
    SHADINGS,
    parse_shading,
)

__all__ = ["RenderParams", "LightParams", "light_table", "with_overrides"]


def light_table(light: Light) -> dict[str, object]:
    """A :class:`~follicle.render.Light` as a ``[[render.lights]]`` table. A colour above 1
    (a table's colour is at most 1) moves its excess into the intensity."""
    color = [float(c) for c in light.color]
    intensity = float(light.intensity)
    peak = max(color)
    if peak > 1.0:
        color, intensity = [c / peak for c in color], intensity * peak
    table: dict[str, object] = {
        "type": "ambient" if light.is_ambient else "directional",
        "space": light.space,
        "color": tuple(color),
        "intensity": intensity,
    }
    if light.direction is not None:  # not ambient
        table["direction"] = tuple(float(x) for x in light.direction)
    return table


def _light_tables(value: object) -> object:
    """``[render].lights`` as given, with :class:`~follicle.render.Light` objects (from
    Python) made tables; anything else is left to the tables' own validation."""
    if isinstance(value, (list, tuple)):
        return [light_table(v) if isinstance(v, Light) else v for v in value]
    return value


class LightParams(StrictSection):
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
    color: RGB = Field(
        (1.0, 1.0, 1.0),
        description="colour of the light",
        json_schema_extra=measured_in("linear RGB"),
    )
    intensity: float = Field(1.0, ge=0, le=1000, description="scales the colour")

    @model_validator(mode="after")
    def _has_direction(self) -> LightParams:
        if self.type == "directional" and not any(self.direction):
            raise ValueError("direction: a directional light needs a non-zero direction")
        return self


class RenderParams(StrictSection):
    """How a picture is rendered: the image, the camera, the lights, the shading and the
    colours of hair, skin and background. The renderers take it whole; a changed copy
    comes from ``replace`` (``follicle.render_image(..., size=...)`` makes one)."""

    _section: ClassVar[str] = "render"

    size: Annotated[
        tuple[Annotated[int, Field(ge=1, le=MAX_SIZE)], Annotated[int, Field(ge=1, le=MAX_SIZE)]],
        Field(strict=False),
    ] = Field(
        (960, 960), description="image width and height", json_schema_extra=measured_in("pixels")
    )
    engine: Literal[ENGINE_NAMES] = Field(  # type: ignore[valid-type]
        "auto",
        description="engine: auto (OpenGL on a GPU, follicle's CPU strand rasterizer on a"
        " software GL or without EGL), opengl, cpu, or mitsuba (a path-traced still, the"
        " pbr extra)",
    )
    shading: Literal[SHADINGS] = Field(  # type: ignore[valid-type]
        "kajiya-kay", description="hair shading model"
    )
    shading_params: dict[str, float | Vec3] = Field(
        default_factory=dict,
        description="the model's parameters, e.g. {specular = 0.3} (docs: Rendering)",
    )
    shadows: bool = Field(True, description="the key light casts hair and skin shadows")
    shadow_size: int = Field(
        DEFAULT_SHADOW_SIZE,
        ge=16,
        le=MAX_SHADOW_SIZE,
        description="texels per side of the key light's shadow maps",
    )
    lights: Annotated[list[LightParams], BeforeValidator(_light_tables)] = Field(
        default_factory=list,
        description="[[render.lights]] tables; none: key, fill and rim"
        " lights that follow the camera, and a little ambient",
    )
    msaa: Annotated[Literal[0, 1, 2, 4, 8, 16], BeforeValidator(not_bool)] = Field(
        4, description="multisample anti-aliasing samples"
    )
    spp: Annotated[int, BeforeValidator(not_bool)] = Field(
        64, ge=1, le=MAX_SPP, description="samples per pixel of a path tracer (mitsuba)"
    )
    oit: bool = Field(
        True,
        description="order-independent transparency; false: hair segments sorted back to"
        " front on the CPU and blended over",
    )
    subdivisions: int = Field(
        4,
        ge=1,
        le=MAX_SUBDIVISIONS,
        description="most Catmull-Rom steps per segment"
        " (fewer where it is short and straight on screen)",
    )
    lod: float = Field(
        0.0,
        ge=0,
        le=64,
        description="level of detail: draw a share of the hairs, widened to keep their"
        " coverage, so that they are at most this many pixels wide (from the hair's"
        " on-screen width); 0 = every hair",
        json_schema_extra=measured_in("pixels"),
    )
    eye: Vec3 | None = Field(
        None,
        description="camera position; unset = framed automatically",
        json_schema_extra=measured_in("m"),
    )
    target: Vec3 | None = Field(
        None,
        description="camera target; unset = framed automatically",
        json_schema_extra=measured_in("m"),
    )
    fov: float = Field(
        DEFAULT_FOV,
        gt=1,
        lt=170,
        description="vertical field of view",
        json_schema_extra=measured_in("degrees"),
    )
    background_top: RGB = Field(
        DEFAULT_BACKGROUND[0],
        description="background gradient top",
        json_schema_extra=measured_in("linear RGB"),
    )
    background_bottom: RGB = Field(
        DEFAULT_BACKGROUND[1],
        description="background gradient bottom",
        json_schema_extra=measured_in("linear RGB"),
    )
    hair_color: RGB = Field(
        DEFAULT_HAIR_COLOR,
        description="colour of hair whose curves have no colour",
        json_schema_extra=measured_in("linear RGB"),
    )
    hair_width: float = Field(
        DEFAULT_HAIR_WIDTH,
        gt=0,
        le=1,
        description="diameter of hair whose curves have no width",
        json_schema_extra=measured_in("m"),
    )
    hair_opacity: Unit = Field(
        DEFAULT_HAIR_OPACITY, description="opacity of hair whose curves have no opacity"
    )
    skin_color: RGB = Field(
        DEFAULT_SKIN_COLOR,
        description="colour of the skin",
        json_schema_extra=measured_in("linear RGB"),
    )
    scalp_tint: Unit = Field(
        DEFAULT_SCALP_TINT,
        description="the skin under the hair blended towards the roots' colour, as game"
        " engines paint the scalp (0: bare skin; raster engines)",
    )

    @model_validator(mode="after")
    def _eye_and_target_together(self) -> RenderParams:
        if (self.eye is None) != (self.target is None):
            raise ValueError("set both eye and target, or neither (automatic framing)")
        return self

    @model_validator(mode="after")
    def _shading_params_fit_the_model(self) -> RenderParams:
        try:
            parse_shading(self.shading, self.shading_params)
        except InputError as exc:
            raise ValueError(str(exc)) from None
        return self

    def light_list(self) -> list[Light] | None:
        """The lights as :class:`follicle.render.Light` objects; None: the default rig."""
        return [
            Light(None if p.type == "ambient" else p.direction, p.color, p.intensity, p.space)
            for p in self.lights
        ] or None

    def camera(self) -> Camera | None:
        """The camera of ``eye`` and ``target`` at ``fov``; None when they are unset (the
        renderers then frame hair and mesh at ``fov``)."""
        if self.eye is None or self.target is None:
            return None
        return Camera(eye=self.eye, target=self.target, fov_y=self.fov)

    @property
    def background(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(top, bottom) of the background gradient."""
        return self.background_top, self.background_bottom


def _plain(value: object) -> object:
    """A numpy array or number as the list or number validation takes."""
    return value.tolist() if isinstance(value, (np.ndarray, np.generic)) else value


# an override of None means the setting's default where the setting itself cannot be None
_NONE_IS: dict[str, object] = {"lights": [], "shading_params": {}}


def with_overrides(
    settings: RenderParams | None, overrides: Mapping[str, Any], source: str = "render"
) -> RenderParams:
    """``settings`` (None: the defaults) with keyword ``overrides`` applied through
    :meth:`RenderParams.replace`, so a bad one is a ConfigError naming ``[render].key``.

    Besides the keys of RenderParams, ``background`` takes one linear RGB colour or
    (top, bottom), and ``lights`` :class:`~follicle.render.Light` objects; numpy arrays
    are taken as lists."""
    if settings is None:
        settings = _DEFAULTS
    elif not isinstance(settings, RenderParams):
        raise InputError(
            f"settings: expected RenderParams (the [render] settings) or None, got"
            f" {type(settings).__name__}"
        )
    if not overrides:
        return settings
    changes = {key: _plain(value) for key, value in overrides.items()}
    for key, empty in _NONE_IS.items():
        if key in changes and changes[key] is None:
            changes[key] = empty
    if "background" in changes:
        background = changes.pop("background")
        if background is not None:
            try:
                pair = len(background) == 2  # type: ignore[arg-type]
            except TypeError:
                raise ConfigError(
                    f"{source}: background: expected one linear RGB colour (r, g, b) or a"
                    f" vertical gradient ((r, g, b) top, (r, g, b) bottom), got {shown(background)}"
                ) from None
            top: object
            bottom: object
            top, bottom = background if pair else (background, background)  # type: ignore[misc]
            changes.update(background_top=_plain(top), background_bottom=_plain(bottom))
    return settings.replace(source, **changes)


_DEFAULTS = RenderParams()
