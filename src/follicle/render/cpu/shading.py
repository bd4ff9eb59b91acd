"""The hair and skin shading of the CPU engine: the same models, lights and shadow
lookups as the OpenGL shaders (``shaders/shade_*.glsl``, ``lights.glsl``,
``hair_radiance.glsl``, ``mesh_fs.glsl``), as numba functions over plain tuples.

Kajiya-Kay (Almeida 2014 §3.3.1 eq. 3.8–3.9; Le Muzic 2012 §5.2.3), Scheuermann 2004
(Almeida 2014 §3.3.1, Alg. 5–6), the real-time Marschner et al. 2003 model and the
physical one (Karis 2016's forms with Chiang et al. 2016's absorption); the key
light's visibility through deep opacity maps (Yuksel & Keyser 2008) and the skin's
shadow map with 2×2 percentage-closer filtering. The model's parameters come packed in
one float64 array (:func:`pack_model`) in the order of :data:`PARAM_ORDER`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ...kernels import kernel
from ..options import SHADINGS, ShadingValue, scalar_param

__all__ = [
    "MODELS",
    "PARAM_ORDER",
    "POWER_STEPS",
    "pack_model",
    "pack_powers",
    "pack_shadow",
    "no_shadow",
]

MODELS = {name: i for i, name in enumerate(SHADINGS)}
_KK: tuple[str, ...] = (
    "diffuse",
    "specular",
    "shininess",
    "specular_color",
    "specular2",
    "shininess2",
)
_KK += ("shift", "shift2", "specular_tint")
PARAM_ORDER = {
    "kajiya-kay": _KK,
    "scheuermann": (*_KK, "shift_noise", "sparkle", "noise_frequency"),
    "marschner": ("alpha", "beta", "r", "tt", "trt", "tt_width", "eta", "diffuse"),
    "physical": (
        "roughness",
        "cuticle_tilt",
        "eta",
        "r",
        "tt",
        "trt",
        "scatter",
        "absorption",
        "backlit",
        "translucency",
        "clear",
        "chord",
    ),  # fmt: skip
}
_U32 = np.uint64(0xFFFFFFFF)


def pack_model(shading: str, model: Mapping[str, ShadingValue]) -> np.ndarray:
    """The model's parameters as one float64 array in :data:`PARAM_ORDER` (a colour
    takes three places), from the shaders' uniforms
    (:attr:`follicle.render.frame.Frame.model`: ``p_`` names, angles in radians)."""
    out: list[float] = []
    for key in PARAM_ORDER[shading]:
        value = model[f"p_{key}"]
        if isinstance(value, (tuple, list)):
            out.extend(float(v) for v in value)
        else:
            out.append(float(value))
    return np.array(out, dtype=np.float64)


POWER_STEPS = 4096  # intervals of the specular power tables: error 1e-4 at p = 120, 3e-4 at 200


def pack_powers(shading: str, model: Mapping[str, ShadingValue]) -> np.ndarray:
    """The specular lobes' power tables, (2, POWER_STEPS + 1) float64: x^e over x in
    [0, 1] for the primary and secondary exponents (Kajiya-Kay: the shininesses;
    Scheuermann: half of them, its lobes being (1 − cos²)^(p/2)); the physical models
    use none."""
    if shading in ("marschner", "physical"):
        return np.zeros((2, POWER_STEPS + 1))
    half = 0.5 if shading == "scheuermann" else 1.0
    x = np.linspace(0.0, 1.0, POWER_STEPS + 1)
    exponents = (
        half * scalar_param(model, "p_shininess"),
        half * scalar_param(model, "p_shininess2"),
    )
    return np.stack([x**e for e in exponents])


def no_shadow() -> tuple:
    """The shadow lookup's arguments with shadows off (one-texel maps, never read)."""
    one = np.ones((1, 1), np.float32)
    return (np.eye(4), one, np.zeros((1, 1, 4), np.float32), one, pack_shadow(False, 1, 1, 0, 0))


def pack_shadow(
    enabled: bool,
    layer_depth: float,
    depth_per_metre: float,
    texel: float,
    density: float,
    soft: int = 0,
) -> np.ndarray:
    """The shadow lookup's numbers: on, layer thickness and depth units per metre (light
    depth, 0..1), texel size (m), κ of exp(−κ·opacity), the skin receivers' filter
    radius in texels (:func:`~follicle.render.options.soft_radius`)."""
    values = [float(enabled), layer_depth, depth_per_metre, texel, density, float(soft)]
    return np.array(values, np.float64)


# ----------------------------------------------------------------------------- vectors
@kernel
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@kernel
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@kernel
def scaled(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@kernel
def added(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@kernel
def unit(a):
    n = math.sqrt(dot(a, a))
    if n <= 0.0:
        return a
    return (a[0] / n, a[1] / n, a[2] / n)


# ----------------------------------------------------------------------------- noise
@kernel
def _hash01(x):
    """hair_common.glsl's lowbias32 mix of a 32-bit unsigned integer, to [0, 1)."""
    x = x & _U32
    x ^= x >> np.uint64(16)
    x = (x * np.uint64(0x7FEB352D)) & _U32
    x ^= x >> np.uint64(15)
    x = (x * np.uint64(0x846CA68B)) & _U32
    x ^= x >> np.uint64(16)
    return float(x) * (1.0 / 4294967296.0)


@kernel
def _strand_noise(seed, x):
    """Smooth value noise along a strand: x in cycles, seed in [0, 1) picks the strand."""
    i = math.floor(x)
    f = x - i
    base = (np.uint64(np.int64(seed * 16777216.0)) * np.uint64(1024)) & _U32
    base = (base + np.uint64(np.int64(i) & 1023)) & _U32
    s = f * f * (3.0 - 2.0 * f)
    a = _hash01(base)
    return a + (_hash01(base + np.uint64(1)) - a) * s


# ----------------------------------------------------------------------------- models
@kernel(inline="always")
def _power(powers, row, x):
    """x^e for x in [0, 1] from row ``row`` of :func:`pack_powers`' tables (linear
    between POWER_STEPS + 1 exact values): a pow call costs 20–40 ns, and each step of
    each light takes two."""
    f = min(max(x, 0.0), 1.0) * POWER_STEPS
    i = min(int(f), POWER_STEPS - 1)
    a = powers[row, i]
    return a + (powers[row, i + 1] - a) * (f - i)


@kernel(inline="always")
def _kk_specular(T, L, E, powers, row):
    """Almeida 2014 eq. 3.9 on the cone of mirror directions around T, to the power of
    the table's exponent."""
    tl = dot(T, L)
    te = dot(T, E)
    c = math.sqrt(max(0.0, 1.0 - tl * tl)) * math.sqrt(max(0.0, 1.0 - te * te)) - tl * te
    return _power(powers, row, c)


@kernel(inline="always")
def _strand_specular(T, H, powers, row):
    """Scheuermann 2004 (Almeida 2014 Alg. 6 lines 19–21): sin(T, H)^p, faded out as T
    turns away from H; sin^p as (1 − cos²)^(p/2) from the table."""
    th = dot(T, H)
    x = min(max(th + 1.0, 0.0), 1.0)  # smoothstep(-1, 0, th)
    return x * x * (3.0 - 2.0 * x) * _power(powers, row, 1.0 - th * th)


@kernel
def _gaussian(width, x):
    return math.exp(-0.5 * x * x / (width * width)) / (width * math.sqrt(2.0 * math.pi))


@kernel
def _fresnel(eta, c):
    """Unpolarised Fresnel reflectance of a dielectric at incidence cosine c."""
    sin_t2 = (1.0 - c * c) / (eta * eta)
    if sin_t2 >= 1.0:
        return 1.0
    ct = math.sqrt(1.0 - sin_t2)
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    return 0.5 * (rs * rs + rp * rp)


@kernel(inline="always")
def _light(lrad, i, key):
    s = key if i == 0 else 1.0
    return (lrad[i, 0] * s, lrad[i, 1] * s, lrad[i, 2] * s)


@kernel(inline="always")
def _shade_tangent(model, prm, powers, T, N, E, base, t, seed, key, nl, ldir, lrad, amb):
    """Kajiya-Kay (model 0) or Scheuermann (model 1): diffuse, a primary lobe towards
    the hair's hue by specular_tint and a secondary lobe tinted by the hair colour, on
    tangents shifted along N (shade_kajiya_kay.glsl, shade_scheuermann.glsl)."""
    jitter = 0.0
    mask = 1.0
    if model == 1:
        x = t * prm[13]
        jitter = prm[11] * (_strand_noise(seed, x) - 0.5)
        m = _strand_noise(seed + 0.5 - math.floor(seed + 0.5), 2.3 * x + 0.37)
        mask = 1.0 + (m - 1.0) * prm[12]
    T1 = unit(added(T, scaled(N, prm[8] + jitter)))
    T2 = unit(added(T, scaled(N, prm[9] + jitter)))
    # the primary lobe's colour towards the hair's hue (hair_common.glsl: tinted)
    tint = prm[10]
    top = max(max(base[0], base[1]), max(base[2], 1e-6))
    pr = prm[1] * prm[3] * (1.0 + (base[0] / top - 1.0) * tint)
    pg = prm[1] * prm[4] * (1.0 + (base[1] / top - 1.0) * tint)
    pb = prm[1] * prm[5] * (1.0 + (base[2] / top - 1.0) * tint)
    dr = dg = db = 0.0
    sr = sg = sb = 0.0
    for i in range(nl):
        L = (float(ldir[i, 0]), float(ldir[i, 1]), float(ldir[i, 2]))
        rad = _light(lrad, i, key)
        if model == 0:
            tl = dot(T, L)
            d = math.sqrt(max(0.0, 1.0 - tl * tl))
            s1 = _kk_specular(T1, L, E, powers, 0)
            s2 = _kk_specular(T2, L, E, powers, 1)
        else:
            H = unit(added(L, E))
            d = max(0.0, 0.75 * dot(N, L) + 0.25)
            s1 = _strand_specular(T1, H, powers, 0)
            s2 = mask * _strand_specular(T2, H, powers, 1)
        dr += rad[0] * d
        dg += rad[1] * d
        db += rad[2] * d
        sr += rad[0] * (pr * s1 + prm[6] * base[0] * s2)
        sg += rad[1] * (pg * s1 + prm[6] * base[1] * s2)
        sb += rad[2] * (pb * s1 + prm[6] * base[2] * s2)
    k = prm[0]
    return (
        base[0] * (amb[0] + k * dr) + sr,
        base[1] * (amb[1] + k * dg) + sg,
        base[2] * (amb[2] + k * db) + sb,
    )


@kernel(inline="always")
def _shade_marschner(prm, T, E, base, key, nl, ldir, lrad, amb):
    """Marschner et al. 2003, simplified for real time (shade_marschner.glsl): R, TT and
    TRT lobes with the hair colour as an absorption per fibre diameter, and a sin(T, L)
    diffuse term."""
    alpha, beta, p_r, p_tt, p_trt, tt_width, eta, p_diffuse = (
        prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6], prm[7],
    )  # fmt: skip
    sig = (
        -math.log(min(max(base[0], 1e-4), 1.0)),
        -math.log(min(max(base[1], 1e-4), 1.0)),
        -math.log(min(max(base[2], 1e-4), 1.0)),
    )
    sin_r = min(max(dot(T, E), -1.0), 1.0)
    theta_r = math.asin(sin_r)
    Ep = added(E, scaled(T, -sin_r))
    r = base[0] * amb[0]
    g = base[1] * amb[1]
    b = base[2] * amb[2]
    for i in range(nl):
        L = (float(ldir[i, 0]), float(ldir[i, 1]), float(ldir[i, 2]))
        rad = _light(lrad, i, key)
        sin_i = min(max(dot(T, L), -1.0), 1.0)
        theta_i = math.asin(sin_i)
        cos_i = math.sqrt(1.0 - sin_i * sin_i)
        theta_h = 0.5 * (theta_i + theta_r)
        theta_d = 0.5 * (theta_r - theta_i)
        cos_d = max(math.cos(theta_d), 0.2)
        Lp = added(L, scaled(T, -sin_i))
        cos_phi = dot(Lp, Ep) / math.sqrt(max(dot(Lp, Lp) * dot(Ep, Ep), 1e-12))
        phi = math.acos(min(max(cos_phi, -1.0), 1.0))
        m_r = _gaussian(beta, theta_h - alpha)
        m_tt = _gaussian(0.5 * beta, theta_h + 0.5 * alpha)
        m_trt = _gaussian(2.0 * beta, theta_h + 1.5 * alpha)
        sin_d = math.sin(theta_d)
        cos_t = math.sqrt(1.0 - sin_d * sin_d / (eta * eta))
        eta_2d = math.sqrt(eta * eta - sin_d * sin_d) / cos_d
        f_centre = _fresnel(eta, cos_d)
        n_r = 0.25 * math.cos(0.5 * phi) * _fresnel(eta, cos_d * math.cos(0.5 * phi))
        tt = (1.0 - f_centre) * (1.0 - f_centre) * _gaussian(tt_width, math.pi - phi)
        cos_gt = math.sqrt(1.0 - 0.75 / (eta_2d * eta_2d))
        f_trt = _fresnel(eta, 0.5 * cos_d)
        trt = 0.25 * (1.0 - f_trt) * (1.0 - f_trt) * f_trt
        scale = 1.0 / (cos_d * cos_d)
        path = 2.0 * cos_gt / cos_t
        for c in range(3):
            s = (
                p_r * m_r * n_r
                + p_tt * m_tt * tt * math.exp(-sig[c] / cos_t)
                + p_trt * m_trt * trt * math.exp(-sig[c] * path)
            ) * scale
            v = rad[c] * (s * cos_i + p_diffuse * base[c] * cos_i)
            if c == 0:
                r += v
            elif c == 1:
                g += v
            else:
                b += v
    return (r, g, b)


LOBE_CUT = -15.0  # a TT or TRT lobe whose exponent is below this adds < 1e-6: skipped


@kernel(inline="always")
def _schlick(f0, c):
    """Schlick's Fresnel of the fibre at incidence cosine c."""
    m = min(max(1.0 - c, 0.0), 1.0)
    m2 = m * m
    return f0 + (1.0 - f0) * m2 * m2 * m


@kernel(inline="always")
def _shade_physical(prm, T, E, base, key, nl, ldir, lrad, amb):
    """shade_physical.glsl: Karis 2016's real-time R, TT and TRT (Gaussian M_p in
    sin θi + sin θr, his fitted N_p) with the absorption σa = k (ln C)² of Chiang 2016
    §4.2 over the chords inside the fibre, under the irradiance π·radiance; plus Karis's
    multiple scattering term, its key light seen through the hair as v^(1 − C); the
    unshadowed lights' TT scaled by ``backlit``; the light divided by the fibre's opacity
    left by ``translucency`` (:func:`follicle.render.options.see_through`). A TT or
    TRT lobe's M_p, N_p and transmittance share one exp per channel, skipped where the
    exponent is below :data:`LOBE_CUT`."""
    rho, tilt, eta, p_r, p_tt, p_trt, p_scatter, k_abs, backlit = (
        prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6], prm[7], prm[8],
    )  # fmt: skip
    translucency, clear, chord = prm[9], prm[10], prm[11]
    c0 = min(max(base[0], 1e-4), 1.0)
    c1 = min(max(base[1], 1e-4), 1.0)
    c2 = min(max(base[2], 1e-4), 1.0)
    l0 = math.log(c0)
    l1 = math.log(c1)
    l2 = math.log(c2)
    s0 = k_abs * l0 * l0
    s1 = k_abs * l1 * l1
    s2 = k_abs * l2 * l2
    rho2 = rho * rho
    rho10 = rho2 * rho2 * rho
    rho10 *= rho10
    beta = 0.726 * rho + 0.812 * rho2 + 3.7 * rho10 * rho10  # the R lobe's width
    g = 0.5 / (beta * beta)  # exp(-g x²): the R lobe; TT 4g (β/2), TRT g/4 (2β)
    norm = 1.0 / (beta * math.sqrt(2.0 * math.pi))  # R; TT 2·norm, TRT norm / 2
    f0 = (1.0 - eta) / (1.0 + eta)
    f0 *= f0
    sin_r = min(max(dot(T, E), -1.0), 1.0)
    cos_r = math.sqrt(1.0 - sin_r * sin_r)
    Ep = added(E, scaled(T, -sin_r))
    ep2 = dot(Ep, Ep)
    Nf = scaled(Ep, 1.0 / math.sqrt(max(ep2, 1e-12)))
    k0 = k1 = k2 = 1.0
    if key < 1.0:
        lk = math.log(max(key, 1e-6))
        k0 = math.exp((1.0 - c0) * lk)
        k1 = math.exp((1.0 - c1) * lk)
        k2 = math.exp((1.0 - c2) * lk)
    r = base[0] * amb[0]  # the ambient and multiple scattering: the hair volume's
    gr = base[1] * amb[1]
    b = base[2] * amb[2]
    sr = sg = sb = 0.0  # single scattering: the fibre's own
    for i in range(nl):
        L = (float(ldir[i, 0]), float(ldir[i, 1]), float(ldir[i, 2]))
        sin_i = min(max(dot(T, L), -1.0), 1.0)
        cos_i = math.sqrt(1.0 - sin_i * sin_i)
        cos_d = max(math.sqrt(max(0.5 + 0.5 * (cos_i * cos_r + sin_i * sin_r), 0.0)), 0.2)
        Lp = added(L, scaled(T, -sin_i))
        cos_phi = dot(Lp, Ep) / math.sqrt(max(dot(Lp, Lp) * ep2, 1e-12))
        cos_phi = min(max(cos_phi, -1.0), 1.0)
        cos_half = math.sqrt(0.5 + 0.5 * cos_phi)
        x = sin_i + sin_r
        sin_d2 = 1.0 - cos_d * cos_d
        cos_t = math.sqrt(1.0 - sin_d2 / (eta * eta))
        a = cos_d / math.sqrt(eta * eta - sin_d2)  # 1 / η', the 2D (Bravais) index
        xr = x + 2.0 * tilt
        fr = _schlick(f0, math.sqrt(min(max(0.5 + 0.5 * dot(L, E), 0.0), 1.0)))
        single = p_r * norm * math.exp(-g * xr * xr) * 0.25 * cos_half * fr
        t0 = t1 = t2 = single
        xt = x - tilt
        e_tt = -4.0 * g * xt * xt - 3.65 * cos_phi - 3.98
        tt_share = p_tt if i == 0 else p_tt * backlit
        if e_tt > LOBE_CUT and tt_share > 0.0:
            h = cos_half * (1.0 + a * (0.6 - 0.8 * cos_phi))
            f_tt = _schlick(f0, cos_d * math.sqrt(max(1.0 - h * h, 0.0)))
            w = tt_share * 2.0 * norm * (1.0 - f_tt) * (1.0 - f_tt)
            l_tt = 2.0 * math.sqrt(max(1.0 - h * h * a * a, 0.0)) / cos_t
            t0 += w * math.exp(e_tt - s0 * l_tt)
            t1 += w * math.exp(e_tt - s1 * l_tt)
            t2 += w * math.exp(e_tt - s2 * l_tt)
        xt = x - 4.0 * tilt
        e_trt = -0.25 * g * xt * xt + 17.0 * cos_phi - 16.78
        if e_trt > LOBE_CUT and p_trt > 0.0:
            f_trt = _schlick(f0, 0.5 * cos_d)
            w = p_trt * 0.5 * norm * (1.0 - f_trt) * (1.0 - f_trt) * f_trt
            l_trt = 4.0 * math.sqrt(1.0 - 0.75 * a * a) / cos_t
            t0 += w * math.exp(e_trt - s0 * l_trt)
            t1 += w * math.exp(e_trt - s1 * l_trt)
            t2 += w * math.exp(e_trt - s2 * l_trt)
        wrap = min(max((dot(Nf, L) + 1.0) * 0.25, 0.0), 1.0)
        w = 1.0 - abs(sin_i)
        scatter = 0.75 * p_scatter * (wrap + (w - wrap) * 0.33)
        vis = math.pi * (key if i == 0 else 1.0)
        sr += lrad[i, 0] * vis * t0
        sg += lrad[i, 1] * vis * t1
        sb += lrad[i, 2] * vis * t2
        if i == 0:
            r += lrad[i, 0] * c0 * scatter * k0
            gr += lrad[i, 1] * c1 * scatter * k1
            b += lrad[i, 2] * c2 * scatter * k2
        else:
            r += lrad[i, 0] * c0 * scatter
            gr += lrad[i, 1] * c1 * scatter
            b += lrad[i, 2] * c2 * scatter
    # the fibre lets this share of what is behind it through: its opacity is scaled by
    # 1 − share (render.frame.hair_vertices), so its own light (single scattering) is
    # divided by 1 − share; the volume's (ambient, multiple scattering) is blended as is,
    # the hair behind showing through adding the rest of it
    d0 = translucency * clear * math.exp(-chord * s0)
    d1 = translucency * clear * math.exp(-chord * s1)
    d2 = translucency * clear * math.exp(-chord * s2)
    share = 0.2126 * d0 + 0.7152 * d1 + 0.0722 * d2
    keep = 1.0 / max(1.0 - share, 1e-3)
    # the hair behind, seen through the fibre, is filtered by its colour (d per channel),
    # where the blend lets the grey share through: the volume's light stands in for it
    v0 = max(1.0 + (d0 - share) * keep, 0.0)
    v1 = max(1.0 + (d1 - share) * keep, 0.0)
    v2 = max(1.0 + (d2 - share) * keep, 0.0)
    return (r * v0 + sr * keep, gr * v1 + sg * keep, b * v2 + sb * keep)


# ----------------------------------------------------------------------------- shadows
@kernel(inline="always")
def _dom_opacity(first, layers, qx, qy, z, layer_depth):
    """Hair opacity in front of light depth z at texel (qx, qy), counted linearly
    across each of the four layers (lights.glsl, dom_opacity)."""
    x = (z - first[qy, qx]) / layer_depth
    total = 0.0
    for k in range(4):
        total += layers[qy, qx, k] * min(max(x - k, 0.0), 1.0)
    return total


@kernel(inline="always")
def _skin_lit(skin, stx, sty, z, r):
    """lights.glsl skin_lit: the skin's shadow test over a box 2r + 1 texels wide around
    (stx, sty), each texel weighted by its overlap (r = 0: the 2x2 bilinear PCF); the
    corners and centre answer alone where they agree."""
    hi = skin.shape[0] - 1
    qx = int(math.floor(stx))
    qy = int(math.floor(sty))
    fx = stx - qx
    fy = sty - qy
    if r > 0:
        c = _lit(skin, qx, qy, z, hi)
        corners = (
            _lit(skin, qx - r, qy - r, z, hi)
            + _lit(skin, qx + r + 1, qy - r, z, hi)
            + _lit(skin, qx - r, qy + r + 1, z, hi)
            + _lit(skin, qx + r + 1, qy + r + 1, z, hi)
        )
        if corners == 4.0 * c:
            return c
    total = 0.0
    for j in range(-r, r + 2):
        wy = 1.0 - fy if j == -r else (fy if j == r + 1 else 1.0)
        row = 0.0
        for i in range(-r, r + 2):
            wx = 1.0 - fx if i == -r else (fx if i == r + 1 else 1.0)
            row += wx * _lit(skin, qx + i, qy + j, z, hi)
        total += wy * row
    width = 2.0 * r + 1.0
    return total / (width * width)


@kernel(inline="always")
def _lit(skin, x, y, z, hi):
    return 1.0 if z <= skin[min(max(y, 0), hi), min(max(x, 0), hi)] else 0.0


@kernel(inline="always")
def key_visibility(p, lift, soft, lvp, first, layers, skin, sh):
    """Share of the key light reaching world point p: the deep opacity maps' hair
    transmittance exp(−κ·opacity), bilinear over the four nearest texels, times the
    skin shadow map's test filtered 2·soft + 1 texels wide (:func:`_skin_lit`). The
    lookup moves ``lift`` metres plus 1.5 texels towards the light (no self-shadowing)."""
    if sh[0] == 0.0:
        return 1.0
    sx = (lvp[0, 0] * p[0] + lvp[0, 1] * p[1] + lvp[0, 2] * p[2] + lvp[0, 3]) * 0.5 + 0.5
    sy = (lvp[1, 0] * p[0] + lvp[1, 1] * p[1] + lvp[1, 2] * p[2] + lvp[1, 3]) * 0.5 + 0.5
    sz = (lvp[2, 0] * p[0] + lvp[2, 1] * p[1] + lvp[2, 2] * p[2] + lvp[2, 3]) * 0.5 + 0.5
    if sx < 0.0 or sy < 0.0 or sx > 1.0 or sy > 1.0:
        return 1.0
    z = sz - (lift + 1.5 * sh[3]) * sh[2]
    size = first.shape[0]
    stx = sx * size - 0.5
    sty = sy * size - 0.5
    fx0 = math.floor(stx)
    fy0 = math.floor(sty)
    fx = stx - fx0
    fy = sty - fy0
    hi = size - 1
    x0 = min(max(int(fx0), 0), hi)
    x1 = min(max(int(fx0) + 1, 0), hi)
    y0 = min(max(int(fy0), 0), hi)
    y1 = min(max(int(fy0) + 1, 0), hi)
    ld = sh[1]
    o00 = _dom_opacity(first, layers, x0, y0, z, ld)
    o10 = _dom_opacity(first, layers, x1, y0, z, ld)
    o01 = _dom_opacity(first, layers, x0, y1, z, ld)
    o11 = _dom_opacity(first, layers, x1, y1, z, ld)
    a = o00 + (o10 - o00) * fx
    b = o01 + (o11 - o01) * fx
    opacity = a + (b - a) * fy
    return _skin_lit(skin, stx, sty, z, soft) * math.exp(-sh[4] * opacity)


# ----------------------------------------------------------------------------- radiance
@kernel(inline="always")
def hair_radiance(
    model, prm, powers, common, P, T, N, E, base, t, seed, width, v2, nl, ldir, lrad, amb,
    lvp, first, layers, skin, sh,
):  # fmt: skip
    """hair_radiance.glsl: the model under the key light's shadow, darkened towards the
    root (``common[0]``, root_occlusion) and the ribbon's edges (``common[1]``,
    roundness; v2 the mean of v² over the shaded area). Then the shadow lookup's light
    matrix, first depths, layers, skin depths and :func:`pack_shadow` — as separate
    arguments: a tuple of arrays handed to an inlined function costs reference counts
    per call, measured at 100 ns, most of a step's shading."""
    key = key_visibility(P, width, 0, lvp, first, layers, skin, sh)
    if model == 2:
        rgb = _shade_marschner(prm, T, E, base, key, nl, ldir, lrad, amb)
    elif model == 3:
        rgb = _shade_physical(prm, T, E, base, key, nl, ldir, lrad, amb)
    else:
        rgb = _shade_tangent(model, prm, powers, T, N, E, base, t, seed, key, nl, ldir, lrad, amb)
    tt = 1.0 - min(max(t, 0.0), 1.0)
    s = (1.0 - common[0] * tt * math.sqrt(tt)) * (1.0 - common[1] * v2)
    return (rgb[0] * s, rgb[1] * s, rgb[2] * s)


@kernel(inline="always")
def skin_radiance(P, N, E, color, wrap, nl, ldir, lrad, amb, lvp, first, layers, skin, sh):
    """mesh_fs.glsl: two-sided Lambert of ``color`` with a wrap-around term, the key
    light shadowed by hair and skin (the lookup's arguments as :func:`hair_radiance`'s),
    looked up two texels off the surface and nearer the light by the filter's width
    times the surface's slope (no acne), the skin's own shadow filtered ``sh[5]``
    texels about."""
    if dot(N, E) < 0.0:
        N = scaled(N, -1.0)
    lift = 2.0 * sh[3]
    q = added(P, scaled(N, lift))
    # the filter's width in depth as the surface slopes away from the key light
    soft = int(sh[5])
    c = max(abs(N[0] * ldir[0, 0] + N[1] * ldir[0, 1] + N[2] * ldir[0, 2]), 0.2)
    slope = (soft + 1.0) * sh[3] * math.sqrt(1.0 - c * c) / c
    key = key_visibility(q, slope, soft, lvp, first, layers, skin, sh)
    r = amb[0]
    g = amb[1]
    b = amb[2]
    for i in range(nl):
        L = (float(ldir[i, 0]), float(ldir[i, 1]), float(ldir[i, 2]))
        rad = _light(lrad, i, key)
        s = max((dot(N, L) + wrap) / (1.0 + wrap), 0.0)
        r += rad[0] * s
        g += rad[1] * s
        b += rad[2] * s
    return (color[0] * r, color[1] * g, color[2] * b)
