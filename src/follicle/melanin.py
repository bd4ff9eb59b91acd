"""Hair colour from melanin: pigment concentrations, the absorption σ_a they give, and
the colour a hair of that σ_a shows (Chiang et al. 2016 §4.2; d'Eon et al. 2011).

A hair's colour comes from two pigments in its cortex: eumelanin (brown to black) and
pheomelanin (red to yellow). Their concentrations set the fibre's absorption
coefficient σ_a, here per unit of fibre *radius*, as Chiang 2016's model, pbrt-v3's
``HairBSDF`` and Mitsuba 3's ``hair`` BSDF take it (a ray crossing the fibre's
centre travels 2 radii):

- ``melanin`` in [0, 1] and ``redness`` in [0, 1] mean what Blender's Principled Hair
  BSDF (Cycles, "Melanin concentration" parametrisation) means by "Melanin" and
  "Melanin Redness": the amount q = −ln(max(1 − melanin, 10⁻⁴)) (0 none, 9.2 the most),
  split into eumelanin = q·(1 − redness) and pheomelanin = q·redness;
- σ_a = eumelanin·(0.419, 0.697, 1.37) + pheomelanin·(0.187, 0.4, 1.05) (Chiang 2016
  §4.2, from d'Eon 2011's measured spectra; pbrt-v3's ``SigmaAFromConcentration``, and
  what Mitsuba 3's ``hair`` takes for its ``eumelanin`` / ``pheomelanin``);
- a dye (Blender's "Tint"), a linear RGB colour, adds the σ_a of that colour,
  :func:`absorption_from_color` (white: none).

Chiang 2016 §4.2 fits the colour C a hair shows under multiple scattering to its σ_a
and azimuthal roughness β_n: σ_a = (ln C / D(β_n))², D(β) = 5.969 − 0.215β + 2.532β²
− 10.73β³ + 5.574β⁴ + 0.245β⁵. :func:`absorption_from_color` is that fit,
:func:`color_from_absorption` its inverse, C = exp(−√σ_a · D(β_n)): the colour the
raster engines shade a hair with, so that they and the path tracer (which takes σ_a)
draw the same hair.

Blender's own Cycles code multiplies the concentrations by other RGB coefficients,
(0.506, 0.841, 1.653) and (0.343, 0.733, 1.924), so the same melanin renders a little
lighter and redder there than here, in pbrt and in Mitsuba (docs: How-to › Grooming).
"""

from __future__ import annotations

import numpy as np

from .errors import InputError
from .rng import purpose_id, uniforms
from .validate import number

__all__ = [
    "absorption_scale",
    "EUMELANIN_SIGMA_A",
    "PHEOMELANIN_SIGMA_A",
    "AZIMUTHAL_ROUGHNESS",
    "concentrations",
    "absorption_from_concentrations",
    "absorption_from_color",
    "color_from_absorption",
    "melanin_absorption",
    "melanin_color",
    "hair_pigments",
]

# σ_a per unit fibre radius of a unit concentration, linear RGB (Chiang 2016 §4.2)
EUMELANIN_SIGMA_A = (0.419, 0.697, 1.37)
PHEOMELANIN_SIGMA_A = (0.187, 0.4, 1.05)
AZIMUTHAL_ROUGHNESS = 0.3  # β_n: Mitsuba's hair default, and the colour fit's here
_FLOOR = 1e-4  # the least 1 − melanin (Blender) and the darkest colour channel
_VARIATION = purpose_id("melanin variation")  # numbers 0, 1: melanin, redness


def _roughness_factor(beta_n: float) -> float:
    """D(β_n) of Chiang 2016 §4.2's colour fit."""
    b = number(beta_n, "beta_n", lo=0.0, hi=1.0)
    return 5.969 - 0.215 * b + 2.532 * b**2 - 10.73 * b**3 + 5.574 * b**4 + 0.245 * b**5


def _fractions(x: object, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=np.float64)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0.0) or np.any(arr > 1.0):
        raise InputError(f"{name}: expected numbers in [0, 1]")
    return arr


def _colors(x: object, name: str) -> np.ndarray:
    arr = _fractions(x, name)
    if arr.ndim < 1 or arr.shape[-1] != 3:
        raise InputError(f"{name}: expected [r, g, b] colours, shape (..., 3), got {arr.shape}")
    return arr


def concentrations(melanin: object, redness: object) -> tuple[np.ndarray, np.ndarray]:
    """(eumelanin, pheomelanin) for Blender's Melanin and Melanin Redness, each in [0, 1]
    (arrays broadcast): q = −ln(max(1 − melanin, 10⁻⁴)), eumelanin = q·(1 − redness),
    pheomelanin = q·redness."""
    m, r = np.broadcast_arrays(_fractions(melanin, "melanin"), _fractions(redness, "redness"))
    q = -np.log(np.maximum(1.0 - m, _FLOOR))
    return q * (1.0 - r), q * r


def absorption_from_concentrations(eumelanin: object, pheomelanin: object) -> np.ndarray:
    """σ_a (..., 3) of pigment concentrations ≥ 0 (Chiang 2016 §4.2)."""
    eu = np.asarray(eumelanin, dtype=np.float64)
    pheo = np.asarray(pheomelanin, dtype=np.float64)
    for arr, name in ((eu, "eumelanin"), (pheo, "pheomelanin")):
        if not np.all(np.isfinite(arr)) or np.any(arr < 0.0):
            raise InputError(f"{name}: expected finite concentrations ≥ 0")
    return eu[..., None] * EUMELANIN_SIGMA_A + pheo[..., None] * PHEOMELANIN_SIGMA_A


def absorption_scale(beta_n: float = AZIMUTHAL_ROUGHNESS) -> float:
    """k of σ_a = k·(ln C)² (:func:`absorption_from_color`): 1 / D(β_n)². The raster
    engines' physical shading takes k as a number and applies it per shaded point."""
    return 1.0 / _roughness_factor(beta_n) ** 2


def absorption_from_color(color: object, beta_n: float = AZIMUTHAL_ROUGHNESS) -> np.ndarray:
    """σ_a giving a hair about ``color`` (linear RGB) under multiple scattering, Chiang
    et al. 2016 §4.2: σ_a = (ln C / D(β_n))².

    C is clipped to [1e-4, 1]: white hair absorbs nothing, black gets a finite σ_a.
    """
    c = np.clip(np.asarray(color, dtype=np.float64), _FLOOR, 1.0)
    return np.log(c) ** 2 * absorption_scale(beta_n)


def color_from_absorption(sigma_a: object, beta_n: float = AZIMUTHAL_ROUGHNESS) -> np.ndarray:
    """The colour (linear RGB) a hair of absorption ``sigma_a`` ≥ 0 shows: the inverse of
    :func:`absorption_from_color`, C = exp(−√σ_a · D(β_n)) (Chiang 2016 §4.2)."""
    s = np.asarray(sigma_a, dtype=np.float64)
    if not np.all(np.isfinite(s)) or np.any(s < 0.0):
        raise InputError("sigma_a: expected finite absorption coefficients ≥ 0")
    return np.exp(-np.sqrt(s) * _roughness_factor(beta_n))


def melanin_absorption(
    melanin: object,
    redness: object,
    dye: object = (1.0, 1.0, 1.0),
    beta_n: float = AZIMUTHAL_ROUGHNESS,
) -> np.ndarray:
    """σ_a (..., 3) of hair of ``melanin`` and ``redness`` (Blender's meaning, in [0, 1])
    dyed ``dye`` (linear RGB in [0, 1], (3,) or one a hair; white: no dye): the
    pigments' σ_a plus the dye's, as Cycles' Principled Hair adds its tint's."""
    pigments = absorption_from_concentrations(*concentrations(melanin, redness))
    return pigments + absorption_from_color(_colors(dye, "dye"), beta_n)


def melanin_color(
    melanin: object,
    redness: object,
    dye: object = (1.0, 1.0, 1.0),
    beta_n: float = AZIMUTHAL_ROUGHNESS,
) -> np.ndarray:
    """The linear RGB colour (..., 3) of :func:`melanin_absorption`'s hair."""
    return color_from_absorption(melanin_absorption(melanin, redness, dye, beta_n), beta_n)


def hair_pigments(
    hair_ids: object,
    seed: int,
    melanin: float,
    redness: float,
    random_melanin: float = 0.0,
    random_redness: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Each hair's (melanin, redness), float32 (n,) each, for hairs ``hair_ids``.

    Blender's "Random Color": melanin × (1 + random_melanin·(2ξ − 1)), ξ uniform per hair;
    likewise the redness with ``random_redness``; both clipped to [0, 1] (a melanin
    above 1 would mean what 1 means). ξ comes from the stream (seed, hair id, "melanin
    variation"), so any split of the ids gives the same values.
    """
    values = [
        number(v, name, lo=0.0, hi=1.0)
        for v, name in (
            (melanin, "melanin"),
            (redness, "melanin_redness"),
            (random_melanin, "random_melanin"),
            (random_redness, "random_redness"),
        )
    ]
    xi = uniforms(seed, hair_ids, _VARIATION, 2)
    m = values[0] * (1.0 + values[2] * (2.0 * xi[:, 0] - 1.0))
    r = values[1] * (1.0 + values[3] * (2.0 * xi[:, 1] - 1.0))
    return np.clip(m, 0.0, 1.0).astype(np.float32), np.clip(r, 0.0, 1.0).astype(np.float32)
