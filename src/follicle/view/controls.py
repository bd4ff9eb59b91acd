"""The viewer's live parameters: which scene keys the panel offers, with slider ranges,
and validated updates of a scene section (bad keys and values name the field)."""

from __future__ import annotations

from typing import NamedTuple

from pydantic import BaseModel

from ..errors import ConfigError
from ..scene import GroomParams, RenderParams, SimParams
from ..settings import unknown_name

__all__ = ["Control", "CONTROLS", "SECTIONS", "check_key"]

SECTIONS: dict[str, type[BaseModel]] = {
    "sim": SimParams,
    "groom": GroomParams,
    "render": RenderParams,
}


class Control(NamedTuple):
    """One panel widget: ``kind`` is float, int, vec3, color, choice or bool; ``lo``/``hi``
    bound a slider (the scene's own validation still has the last word)."""

    key: str
    kind: str
    lo: float = 0.0
    hi: float = 1.0


def _f(key: str, lo: float = 0.0, hi: float = 1.0) -> Control:
    return Control(key, "float", lo, hi)


# Per section, in panel order. [sim] keys apply on the next step; [groom] keys regrow the
# displayed hair; [render] keys apply on the next frame. With [groom].settle > 0, a change
# of it or of the [sim] dynamics settles the guides again in the background.
CONTROLS: dict[str, tuple[Control, ...]] = {
    "sim": (
        Control("solver", "choice"),
        Control("gravity", "vec3", -20.0, 20.0),
        Control("wind", "vec3", -50.0, 50.0),
        _f("wind_turbulence", 0.0, 10.0),
        _f("wind_gust", 0.0, 10.0),
        _f("drag", 0.0, 50.0),
        _f("damping", 0.0, 20.0),
        Control("iterations", "int", 1, 64),
        _f("stretch_stiffness"),
        _f("bend_stiffness"),
        _f("bend_attenuation", 0.0, 10.0),
        _f("shape_local"),
        _f("shape_global"),
        _f("shape_hold", 0.0, 0.5),
        _f("friction"),
        _f("volume_friction"),
        _f("volume_repulsion"),
        Control("motion", "choice"),
        _f("motion_amplitude", 0.0, 90.0),
        _f("motion_period", 0.2, 10.0),
    ),
    "groom": (
        Control("count", "int", 0, 100_000),
        _f("frizz_root", 0.0, 0.02),
        _f("frizz_tip", 0.0, 0.02),
        _f("kink_root", 0.0, 0.02),
        _f("kink_tip", 0.0, 0.02),
        _f("curl_radius", 0.0, 0.02),
        _f("curl_frequency", 0.0, 200.0),
        Control("clump_count", "int", 0, 2000),
        _f("clump_tip"),
        Control("root_color", "color"),
        Control("tip_color", "color"),
        _f("root_width", 1e-6, 4e-4),
        _f("tip_width", 1e-6, 4e-4),
        _f("settle", 0.0, 10.0),
    ),
    "render": (
        Control("shading", "choice"),
        Control("shadows", "bool"),
        Control("subdivisions", "int", 1, 16),
    ),
}


def check_key(section: str, key: str) -> None:
    """ConfigError unless ``[section].key`` is a scene key the viewer can change."""
    if section not in SECTIONS:
        raise ConfigError(
            f"viewer: [{section}]: {unknown_name(section, list(SECTIONS), 'section')}"
        )
    if key not in SECTIONS[section].model_fields:
        keys = list(SECTIONS[section].model_fields)
        raise ConfigError(f"viewer: [{section}].{key}: {unknown_name(key, keys)}")
