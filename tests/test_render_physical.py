"""The physical shading model's lobes on their own (the CPU engine's kernel, which the
OpenGL shader matches: test_render_shading.py renders both against the formulas):
energy conservation for white hair, absorption taking away what enters the fibre, and
the fibre's translucency (what lies behind it showing through)."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.melanin import absorption_scale
from follicle.render.cpu.shading import _shade_physical, pack_model
from follicle.render.options import model_uniforms, parse_shading, see_through, see_through_fit

T = (1.0, 0.0, 0.0)  # the strand along +x
NO_LIGHT = np.zeros(3)
OPAQUE = {"translucency": 0.0}  # the lobes alone: a see-through fibre's light is scaled
ONLY = {  # one term at a time
    "r": {"tt": 0.0, "trt": 0.0, "scatter": 0.0, **OPAQUE},
    "tt": {"r": 0.0, "trt": 0.0, "scatter": 0.0, **OPAQUE},
    "trt": {"r": 0.0, "tt": 0.0, "scatter": 0.0, **OPAQUE},
    "scatter": {"r": 0.0, "tt": 0.0, "trt": 0.0, "scatter": 1.0, **OPAQUE},  # 1: a fibre's
}


def sphere(n: int) -> np.ndarray:
    """n unit vectors spread evenly over the sphere (a Fibonacci lattice), each standing
    for 4π/n steradians."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = np.pi * (1.0 + 5**0.5) * k
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def shade(term: str, base, E, L, radiance: float = 1.0) -> np.ndarray:
    """The radiance of term ``term`` alone towards E, one light from L, no ambient."""
    params = parse_shading("physical", ONLY[term])
    prm = pack_model("physical", model_uniforms("physical", params))
    ldir = np.asarray([L], np.float32)
    lrad = np.full((1, 3), radiance, np.float32)
    rgb = _shade_physical(
        prm, T, tuple(E), tuple(float(c) for c in base), 1.0, 1, ldir, lrad, NO_LIGHT
    )
    return np.array(rgb)


@pytest.mark.parametrize("view", [(0.0, 0.0, 1.0), (0.5, 0.0, 0.866), (-0.7, 0.3, 0.648)])
def test_no_lobe_of_white_hair_reflects_more_than_it_receives(view):
    """White hair (σa = 0) under a light of irradiance 1 (radiance 1/π): each lobe's
    radiance integrated over every direction of the light, ∫ S_p dω_i (the BSDF's
    ∫ f |cos θ| dω with S_p normalised over cos θi dθi), is at most 1; the multiple
    scattering term, a reflectance under a light of radiance 1, (1/π) ∫ … dω, too.
    The lobes are real: each returns a sizeable share."""
    E = np.asarray(view) / np.linalg.norm(view)
    dirs = sphere(20000)
    white = (1.0, 1.0, 1.0)
    for term in ONLY:
        radiance = 1.0 / np.pi if term != "scatter" else 1.0
        total = sum(shade(term, white, E, L, radiance)[0] for L in dirs) * 4 * np.pi / len(dirs)
        albedo = total if term != "scatter" else total / np.pi
        assert 0.02 < albedo <= 1.0 + 1e-3, (term, albedo)


def test_absorption_takes_away_tt_and_trt_but_not_r():
    """Back-lit (TT) and front-lit at the TRT peak: as the hair darkens, σa = k (ln C)²
    grows from 0 and TT and TRT fall towards nothing, R (the surface) stays."""
    E = np.array([0.0, 0.0, 1.0])
    back = np.array([0.0, 0.25, -1.0]) / np.linalg.norm([0.0, 0.25, -1.0])
    front = np.array([-0.1, 0.0, 1.0]) / np.linalg.norm([-0.1, 0.0, 1.0])
    colours = [1.0, 0.6, 0.3, 0.1, 0.02, 1e-4]
    for term, L in (("tt", back), ("trt", front)):
        values = [shade(term, (c, c, c), E, L)[0] for c in colours]
        assert values[0] > 0.05, (term, values)  # σa = 0: the lobe is there
        assert all(a > b for a, b in zip(values, values[1:], strict=False)), (term, values)
        assert values[-1] < 0.01 * values[0], (term, values)
    r = [shade("r", (c, c, c), E, front)[0] for c in colours]
    assert max(r) == pytest.approx(min(r)) and r[0] > 0.02


def test_colour_tints_transmission_by_the_chiang_absorption():
    """Brown hair's TT keeps red most: exp(−σa·l) per channel with σa = k (ln C)²; the
    ratio of two channels' logarithms is that of their σa, (ln C_r / ln C_b)²."""
    E = np.array([0.0, 0.0, 1.0])
    back = np.array([0.0, 0.25, -1.0]) / np.linalg.norm([0.0, 0.25, -1.0])
    brown = (0.3, 0.15, 0.06)
    tt = shade("tt", brown, E, back)
    white = shade("tt", (1.0, 1.0, 1.0), E, back)
    assert tt[0] > tt[1] > tt[2]
    logs = np.log(tt / white)  # −σa·l, the same l for every channel
    assert logs[0] / logs[2] == pytest.approx((np.log(0.3) / np.log(0.06)) ** 2, rel=1e-6)


def test_lights_without_shadows_transmit_by_backlit():
    """TT of a light behind the strand: the key's in full, another light's (no shadow
    map: it would shine through the head) times ``backlit``."""
    E = (0.0, 0.0, 1.0)
    back = np.array([0.0, 0.25, -1.0]) / np.linalg.norm([0.0, 0.25, -1.0])
    ldir = np.asarray([back, back], np.float32)
    as_key = np.asarray([[1.0] * 3, [0.0] * 3], np.float32)
    as_fill = as_key[::-1].copy()
    base = (0.5, 0.5, 0.5)

    def tt(lrad, backlit):
        params = parse_shading("physical", {**ONLY["tt"], "backlit": backlit})
        prm = pack_model("physical", model_uniforms("physical", params))
        return _shade_physical(prm, T, E, base, 1.0, 2, ldir, lrad, NO_LIGHT)[0]

    key = tt(as_key, 0.0)
    assert key > 0.05
    assert tt(as_fill, 0.0) == 0.0
    assert tt(as_fill, 0.25) == pytest.approx(0.25 * key, rel=1e-9)


def test_see_through_is_the_mean_tt_attenuation_across_the_fibre():
    """A fibre seen side on lets through, of the light straight behind it, the mean over
    the offsets h of (1 − F)² exp(−2σa cos γt): checked by Monte Carlo over h (Snell's
    law, Fresnel's unpolarised reflectance written out here) for several σa, and at
    h = 0 alone ((1 − F₀)², F₀ = ((η − 1)/(η + 1))²) as a bound."""
    eta = 1.55
    clear, chord = see_through_fit(eta)
    rng = np.random.default_rng(7)
    h = rng.uniform(-1.0, 1.0, 400_000)
    gamma_i = np.arcsin(h)
    gamma_t = np.arcsin(h / eta)
    rs = (np.sin(gamma_i - gamma_t) / np.sin(gamma_i + gamma_t + 1e-300)) ** 2
    rp = (np.tan(gamma_i - gamma_t) / np.tan(gamma_i + gamma_t + 1e-300)) ** 2
    f0 = ((eta - 1.0) / (eta + 1.0)) ** 2
    fresnel = np.where(np.abs(h) < 1e-6, f0, 0.5 * (rs + rp))
    for sigma in (0.0, 0.1, 0.4, 1.0):
        exact = np.mean((1.0 - fresnel) ** 2 * np.exp(-2.0 * sigma * np.cos(gamma_t)))
        assert clear * np.exp(-chord * sigma) == pytest.approx(exact, rel=0.01), sigma
    assert 0.8 < clear < (1.0 - f0) ** 2  # grazing offsets reflect more than h = 0
    assert 1.5 < chord < 2.0  # the mean chord 2 cos γt, in fibre radii


def test_light_hair_lets_more_through_than_dark():
    """The share of what is behind a fibre that shows through it: most for white hair (σa
    = 0: the Fresnel losses only), little for brown, next to nothing for black hair, nothing with
    translucency 0, and only in the physical model."""
    params = parse_shading("physical", {})
    colours = np.array([[1.0, 1.0, 1.0], [0.6, 0.45, 0.3], [0.16, 0.09, 0.045], [1e-4] * 3])
    share = see_through(colours, params)
    clear, _ = see_through_fit(1.55)
    assert share[0] == pytest.approx(clear)
    assert share[0] > share[1] > share[2] > share[3]
    assert share[3] < 0.01  # the darkest colour's σa ≈ 2.4
    assert np.all(see_through(colours, parse_shading("physical", OPAQUE)) == 0.0)
    assert np.all(see_through(colours, parse_shading("kajiya-kay", {})) == 0.0)


def test_a_see_through_fibres_own_light_is_kept_and_the_hair_behind_tinted():
    """With translucency the blend gives a fibre opacity 1 − s (s = :func:`see_through`),
    so its single scattering is divided by 1 − s (what it reflects stays the same once
    blended), and the volume's light (multiple scattering) is tinted by how the fibre
    filters each channel, 1 + (d_c − s)/(1 − s), d_c = c·exp(−l σa,c): redder for brown
    hair, unchanged for grey."""
    E, L = (0.0, 0.0, 1.0), (0.0, 0.6, 0.8)
    ldir = np.asarray([L], np.float32)
    lrad = np.ones((1, 3), np.float32)

    def radiance(base, **params):
        prm = pack_model("physical", model_uniforms("physical", parse_shading("physical", params)))
        return np.array(_shade_physical(prm, T, E, base, 1.0, 1, ldir, lrad, NO_LIGHT))

    clear, chord = see_through_fit(1.55)
    grey = (0.5, 0.5, 0.5)
    s = see_through(np.array(grey), parse_shading("physical", {}))
    single = {"scatter": 0.0}
    assert radiance(grey, **single) == pytest.approx(radiance(grey, **single, **OPAQUE) / (1 - s))
    volume = {"r": 0.0, "tt": 0.0, "trt": 0.0}
    assert radiance(grey, **volume) == pytest.approx(radiance(grey, **volume, **OPAQUE))
    brown = (0.3, 0.15, 0.06)
    s = see_through(np.array(brown), parse_shading("physical", {}))
    d = clear * np.exp(-chord * absorption_scale() * np.log(brown) ** 2)
    tint = radiance(brown, **volume) / radiance(brown, **volume, **OPAQUE)
    assert tint[0] > 1.0 > tint[2]
    assert tint == pytest.approx(np.maximum(1.0 + (d - s) / (1.0 - s), 0.0), rel=2e-3)
