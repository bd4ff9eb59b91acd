"""Units of input files: follicle works in metres; a mesh or curves file in other units is
converted once, when it is loaded, as the user says (``[mesh].units``, ``[guides].units``,
``load_mesh(..., units=)``, ``load_curves(..., units=)``, ``load_guides(..., units=)``).

A unit is ``"m"``, ``"cm"``, ``"mm"``, ``"in"`` or a positive number of metres per unit.
It applies to files whose numbers carry no unit (OBJ, PLY, STL, OFF, cyHair, TressFX,
Mitsuba, NPZ, …). A file that declares its own unit is converted by its reader and
refuses another one here, so a unit is never applied twice: USD (the stage's
``metersPerUnit``; unauthored means centimetres) and glTF (metres by its specification).
Built-in meshes and guides are in metres.

Sizes that suggest another unit are flagged on the ``follicle`` logger, one line each,
naming the file, what looks wrong and the exact setting that would fix it: a mesh
outside 1 cm to 20 m across (its bounding-box diagonal), guides whose median length is
outside 1 mm to 2 m or out of proportion with the mesh, and guide roots that would lie on
the mesh if scaled by 100 or 1000 (:func:`off_mesh_factor`). Each problem is told once:
a guides size warning replaces the roots' off-mesh one, and roots that miss the mesh only
because the mesh is off by a factor add nothing to the mesh's warning.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable

import numpy as np

from .curves import HairCurves
from .errors import InputError

__all__ = [
    "Units",
    "UNITS",
    "DECLARED_UNITS",
    "metres_per_unit",
    "units_for",
    "scale_curves",
    "median_length",
    "mesh_factors",
    "warn_mesh_size",
    "warn_guide_size",
    "off_mesh_factor",
    "units_fix",
]

log = logging.getLogger("follicle")

Units = str | float
UNITS: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}
_NAMES = {"m": "metres", "cm": "centimetres", "mm": "millimetres", "in": "inches"}
_ACCEPTED = '"m", "cm", "mm", "in" or a positive number of metres per unit'

# formats whose files say what their numbers mean, by suffix: their readers convert
_USD = "USD files declare their own unit (metersPerUnit; unset means centimetres)"
_GLTF = "glTF files are in metres by the glTF specification"
DECLARED_UNITS: dict[str, str] = {
    **dict.fromkeys((".usd", ".usda", ".usdc", ".usdz"), _USD),
    **dict.fromkeys((".glb", ".gltf"), _GLTF),
}

# plausible sizes, metres: a mesh's bounding-box diagonal, a guide's length
MESH_SIZE = (0.01, 20.0)
GUIDE_LENGTH = (0.001, 2.0)
# a guide's median length against the mesh's diagonal: beyond these the two look to be in
# different units (a strand twice the size of what it grows on is not hair; curly guides
# of the built-in head are 1.07×)
GUIDE_TO_MESH = (0.001, 2.0)


def metres_per_unit(units: object, key: str | None = "units") -> float:
    """Metres per unit of ``units`` (a name of :data:`UNITS` or a positive finite number).

    Anything else is an InputError whose one line starts with ``key`` (none when None,
    for a caller that names the key itself) and lists what is accepted.
    """
    if isinstance(units, str) and units in UNITS:
        return UNITS[units]
    if isinstance(units, (int, float, np.integer, np.floating)) and not isinstance(units, bool):
        value = float(units)
        if math.isfinite(value) and value > 0:
            return value
    shown = str(units).lower() if isinstance(units, bool) else repr(units)
    shown = shown if len(shown) <= 60 else shown[:57] + "..."
    prefix = f"{key}: " if key else ""
    raise InputError(f"{prefix}expected {_ACCEPTED} (got {shown})")


def units_for(path: str | os.PathLike[str], units: object, key: str | None = "units") -> float:
    """Metres per unit of ``units`` for the file (or ``builtin:`` name) ``path``.

    ``units`` must be valid (:func:`metres_per_unit`), and other than metres only for a
    file whose numbers carry no unit: built-in meshes and guides are in metres, and a
    format of :data:`DECLARED_UNITS` is converted by its reader. An InputError names
    ``key`` and says to remove it.
    """
    mpu = metres_per_unit(units, key)
    if mpu == 1.0:
        return mpu
    text = os.fsdecode(path)
    prefix = f"{key}: " if key else ""
    got = f"(got {_shown(units if isinstance(units, str) else mpu)})"
    if text.startswith("builtin:"):
        raise InputError(f"{prefix}{text} is in metres; units apply to files only: remove it {got}")
    suffix = os.path.splitext(text)[1].lower()
    if suffix in DECLARED_UNITS:
        raise InputError(
            f"{prefix}{DECLARED_UNITS[suffix]}, which follicle applies when reading"
            f" {os.path.basename(text)!r}; more units would count twice: remove"
            f" them {got}"
        )
    return mpu


def scale_curves(
    curves: HairCurves, factor: float, width_factor: float | None = None
) -> HairCurves:
    """``curves`` with points times ``factor`` and ``point_data['width']`` (a diameter)
    times ``width_factor`` (default ``factor``: a file whose widths have their points'
    unit); other attributes (colours, normals, UVs, …) carry no length and are kept."""
    width_factor = factor if width_factor is None else width_factor
    if factor == 1.0 and width_factor == 1.0:
        return curves
    point_data = dict(curves.point_data)
    if "width" in point_data:
        width = point_data["width"]
        point_data["width"] = (width * np.float64(width_factor)).astype(width.dtype)
    points = (curves.points * np.float64(factor)).astype(np.float32)
    return HairCurves(points, curves.offsets, point_data, curves.curve_data)


def median_length(curves: HairCurves) -> float:
    """The median polyline length of the curves, in their units (0 for no curves)."""
    if curves.curve_count == 0:
        return 0.0
    steps = np.linalg.norm(np.diff(curves.points.astype(np.float64), axis=0), axis=1)
    steps = np.append(steps, 0.0)
    steps[curves.offsets[1:] - 1] = 0.0  # no step from a curve's tip to the next root
    return float(np.median(np.add.reduceat(steps, curves.offsets[:-1])))


def _factors(size: float, bounds: tuple[float, float]) -> tuple[float, ...]:
    """The factors the units may be off by when ``size`` is outside ``bounds``, likelier
    first: 1/100 and 1/1000 when too large (1/1000 first beyond 100× the top), 100 and
    1000 when too small (1000 first below 1/100 of the bottom); none when inside."""
    lo, hi = bounds
    if size > hi:
        return (1e-3, 1e-2) if size > 100 * hi else (1e-2, 1e-3)
    if size < lo:
        return (1e3, 1e2) if size < lo / 100 else (1e2, 1e3)
    return ()


def _likely_factor(size: float, bounds: tuple[float, float], units: Units) -> float | None:
    """Of :func:`_factors`, the first that brings ``size`` inside ``bounds`` and makes
    ``units`` a named unit, else the first inside, else the likeliest; None when inside
    already (a metre file read as "mm" is 1000× too small, not 100×: "m", not 0.1 m)."""
    factors = _factors(size, bounds)
    inside = [f for f in factors if bounds[0] <= size * f <= bounds[1]]
    mpu = metres_per_unit(units)
    first = inside[0] if inside else factors[0] if factors else None
    return next((f for f in inside if _named(mpu * f)), first)


def mesh_factors(diagonal: float) -> tuple[float, ...]:
    """The factors a mesh ``diagonal`` metres across may be off by (outside
    :data:`MESH_SIZE`; none when plausible): what its size warning is about."""
    return _factors(diagonal, MESH_SIZE)


def _named(mpu: float) -> str | None:
    """The name of :data:`UNITS` worth ``mpu`` metres, or None."""
    return next((n for n, v in UNITS.items() if math.isclose(v, mpu, rel_tol=1e-9)), None)


def units_fix(what: str, key: str, function: str, units: Units, factor: float) -> str:
    """The advice for numbers read in ``units`` that look ``factor`` times off, e.g. ``if
    the mesh is in centimetres, set [mesh].units = "cm" (load_mesh(..., units="cm"))``."""
    mpu = metres_per_unit(units) * factor
    name = _named(mpu)
    unit, value = (_NAMES[name], f'"{name}"') if name else (f"units of {mpu:.6g} m", f"{mpu:.6g}")
    return f"if {what} in {unit}, set {key} = {value} ({function}(..., units={value}))"


def _shown(units: Units) -> str:
    """``units`` as a scene file writes it: "cm" or 0.01."""
    return f'"{units}"' if isinstance(units, str) else f"{float(units):g}"


def _read_as(units: Units) -> str:
    return "" if metres_per_unit(units) == 1.0 else f" (read with units = {_shown(units)})"


def warn_mesh_size(diagonal: float, units: Units, source: str) -> None:
    """Warn when a mesh ``diagonal`` metres across (converted from ``units``) suggests
    other units (outside :data:`MESH_SIZE`); ``source`` names the file."""
    factor = _likely_factor(diagonal, MESH_SIZE, units)
    if factor is not None:
        lo, hi = MESH_SIZE
        log.warning(
            "%s: the mesh is %.3g m across%s, outside %g cm to %g m: %s",
            source,
            diagonal,
            _read_as(units),
            lo * 100,
            hi,
            units_fix("the mesh is", "[mesh].units", "load_mesh", units, factor),
        )


def warn_guide_size(curves: HairCurves, mesh_diagonal: float, units: Units, source: str) -> bool:
    """Warn when guides (in metres, converted from ``units``) suggest other units: a median
    length outside :data:`GUIDE_LENGTH`, else out of proportion (:data:`GUIDE_TO_MESH`)
    with a mesh of plausible size, ``mesh_diagonal`` metres across. True when it warned."""
    length = median_length(curves)
    fix = ("the guides are", "[guides].units", "load_guides", units)
    factor = _likely_factor(length, GUIDE_LENGTH, units)
    if factor is not None:
        lo, hi = GUIDE_LENGTH
        log.warning(
            "%s: the guides' median length is %.3g m%s, outside %g mm to %g m: %s",
            source,
            length,
            _read_as(units),
            lo * 1000,
            hi,
            units_fix(*fix, factor),
        )
        return True
    if mesh_factors(mesh_diagonal):  # the mesh's own warning says what to set
        return False
    ratio = length / mesh_diagonal
    factor = _likely_factor(ratio, GUIDE_TO_MESH, units)
    if factor is None:
        return False
    if _named(metres_per_unit(units) * factor):
        hint = units_fix(*fix, factor)
    else:  # metre guides far too short for the mesh: more likely a mesh in cm read as metres
        hint = units_fix(
            "the mesh was read as metres but is", "[mesh].units", "load_mesh", "m", 1 / factor
        )
    log.warning(
        "%s: the guides' median length %.3g m%s is %.3g× the mesh's size (%.3g m across): %s",
        source,
        length,
        _read_as(units),
        ratio,
        mesh_diagonal,
        hint,
    )
    return True


def off_mesh_factor(
    roots: np.ndarray, distance: Callable[[np.ndarray], np.ndarray], tolerance: float
) -> float | None:
    """The factor (1/100, 1/1000, 100 or 1000) that puts most guide ``roots`` (the median
    one) within ``tolerance`` of the mesh (``distance`` (n,) of points (n, 3) from its
    surface), still spread wider than it (not merely shrunk onto a spot of a mesh through
    the origin), or None: roots that lie off the mesh by such a factor were written in
    other units."""
    for factor in (1e-2, 1e-3, 1e2, 1e3):
        scaled = np.asarray(roots, dtype=np.float64) * factor
        if (
            np.linalg.norm(np.ptp(scaled, axis=0)) > tolerance
            and np.median(distance(scaled)) <= tolerance
        ):
            return factor
    return None
