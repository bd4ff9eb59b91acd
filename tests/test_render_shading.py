"""Hair shading models against their formulas evaluated here in Python, per fragment
(wide ribbons) and per Catmull-Rom step (thin hair); parameters and their errors."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.curves import HairCurves
from follicle.errors import InputError
from follicle.render import Camera, Light, render_image
from follicle.render.image import linear_to_srgb
from follicle.render.options import SHADINGS, parse_shading

pytestmark = pytest.mark.usefixtures("each_engine")  # each test on both engines

# an odd size puts the centre of pixel (100, 100) on the optical axis
SIZE = (201, 201)
FRONT = Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0), fov_y=35.0)
BASE = np.array([0.5, 0.3, 0.15])
PLAIN = {"root_occlusion": 0.0, "roundness": 0.0}
NO_NOISE = {"scheuermann": {"shift_noise": 0.0, "sparkle": 0.0}}


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def smoothstep(e0: float, e1: float, x: float) -> float:
    s = min(max((x - e0) / (e1 - e0), 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


# ---------------------------------------------------------------- the formulas
def primary_color(base, p) -> np.ndarray:
    """The primary lobe's colour: specular_color towards the hair's hue by specular_tint."""
    hue = base / max(base.max(), 1e-6)
    return np.asarray(p["specular_color"]) * (1 + (hue - 1) * p["specular_tint"])


def kajiya_kay(T, N, E, L, base, p) -> np.ndarray:
    """Almeida 2014 eq. 3.8 (diffuse sin(T, L)) and 3.9 (specular), two shifted lobes."""

    def cone(tangent, exponent):
        tl, te = tangent @ L, tangent @ E
        c = np.sqrt(max(0.0, 1 - tl * tl)) * np.sqrt(max(0.0, 1 - te * te)) - tl * te
        return max(c, 0.0) ** exponent

    t1, t2 = unit(T + p["shift"] * N), unit(T + p["shift2"] * N)
    spec = p["specular"] * primary_color(base, p) * cone(t1, p["shininess"])
    spec2 = p["specular2"] * base * cone(t2, p["shininess2"])
    return base * p["diffuse"] * np.sqrt(max(0.0, 1 - (T @ L) ** 2)) + spec + spec2


def scheuermann(T, N, E, L, base, p) -> np.ndarray:
    """Almeida 2014 Alg. 6 without noise: diffuse 0.75 N.L + 0.25, sin(T', H)^p lobes."""
    H = unit(L + E)

    def lobe(tangent, exponent):
        th = tangent @ H
        return smoothstep(-1.0, 0.0, th) * np.sqrt(max(0.0, 1 - th * th)) ** exponent

    t1, t2 = unit(T + p["shift"] * N), unit(T + p["shift2"] * N)
    spec = p["specular"] * primary_color(base, p) * lobe(t1, p["shininess"])
    spec2 = p["specular2"] * base * lobe(t2, p["shininess2"])
    return base * p["diffuse"] * max(0.0, 0.75 * (N @ L) + 0.25) + spec + spec2


def marschner(T, N, E, L, base, p) -> np.ndarray:
    """R, TT, TRT: M_p(θh) N_p(φ) / cos²θd · cos θi, plus the sin(T, L) diffuse term."""
    alpha, beta = np.radians(p["alpha"]), np.radians(p["beta"])
    eta = p["eta"]

    def gauss(width, x):
        return np.exp(-0.5 * x * x / width**2) / (width * np.sqrt(2 * np.pi))

    def fresnel(c):
        sin_t2 = (1 - c * c) / eta**2
        if sin_t2 >= 1:
            return 1.0
        ct = np.sqrt(1 - sin_t2)
        rs, rp = (c - eta * ct) / (c + eta * ct), (eta * c - ct) / (eta * c + ct)
        return 0.5 * (rs * rs + rp * rp)

    sigma = -np.log(np.clip(base, 1e-4, 1.0))  # absorption per fibre diameter
    sin_i, sin_r = T @ L, T @ E
    theta_i, theta_r = np.arcsin(sin_i), np.arcsin(sin_r)
    theta_h, theta_d = 0.5 * (theta_i + theta_r), 0.5 * (theta_r - theta_i)
    cos_d = max(np.cos(theta_d), 0.2)
    lp, ep = L - sin_i * T, E - sin_r * T
    phi = np.arccos(np.clip(lp @ ep / np.sqrt(max((lp @ lp) * (ep @ ep), 1e-12)), -1, 1))
    sin_d = np.sin(theta_d)
    cos_t = np.sqrt(1 - sin_d**2 / eta**2)
    eta_2d = np.sqrt(eta**2 - sin_d**2) / cos_d
    f_centre = fresnel(cos_d)
    n_r = 0.25 * np.cos(phi / 2) * fresnel(cos_d * np.cos(phi / 2))
    n_tt = (
        (1 - f_centre) ** 2 * np.exp(-sigma / cos_t) * gauss(np.radians(p["tt_width"]), np.pi - phi)
    )
    f_trt = fresnel(0.5 * cos_d)
    cos_gt = np.sqrt(1 - 0.75 / eta_2d**2)
    n_trt = 0.25 * (1 - f_trt) ** 2 * f_trt * np.exp(-sigma * 2 * cos_gt / cos_t)
    s = (
        p["r"] * gauss(beta, theta_h - alpha) * n_r
        + p["tt"] * gauss(beta / 2, theta_h + alpha / 2) * n_tt
        + p["trt"] * gauss(2 * beta, theta_h + 1.5 * alpha) * n_trt
    ) / cos_d**2
    cos_i = np.sqrt(1 - sin_i**2)
    return s * cos_i + p["diffuse"] * base * cos_i


def physical_lobes(T, E, L, base, p) -> dict[str, np.ndarray]:
    """Karis 2016's R, TT, TRT as S_p = M_p A_p N_p (per unit irradiance) and the multiple
    scattering term (per unit radiance, unshadowed), with σa from the colour by Chiang
    2016 §4.2 evaluated here: σa = (ln C / P(0.3))², P the paper's polynomial."""
    poly = 5.969 - 0.215 * 0.3 + 2.532 * 0.3**2 - 10.73 * 0.3**3 + 5.574 * 0.3**4 + 0.245 * 0.3**5
    c = np.clip(base, 1e-4, 1.0)
    sigma = (np.log(c) / poly) ** 2
    rho, alpha, eta = p["roughness"], np.radians(p["cuticle_tilt"]), p["eta"]
    beta = 0.726 * rho + 0.812 * rho**2 + 3.7 * rho**20  # Chiang 2016 §4.1, √v

    def gauss(width, x):
        return np.exp(-0.5 * x * x / width**2) / (width * np.sqrt(2 * np.pi))

    def schlick(cos):
        f0 = ((1 - eta) / (1 + eta)) ** 2
        return f0 + (1 - f0) * (1 - cos) ** 5

    theta_i, theta_r = np.arcsin(T @ L), np.arcsin(T @ E)
    cos_d = max(np.cos(0.5 * (theta_r - theta_i)), 0.2)
    lp, ep = L - (T @ L) * T, E - (T @ E) * T
    cos_phi = np.clip(lp @ ep / np.sqrt(max((lp @ lp) * (ep @ ep), 1e-12)), -1, 1)
    phi = np.arccos(cos_phi)
    x = np.sin(theta_i) + np.sin(theta_r)
    eta_prime = np.sqrt(eta**2 - np.sin(0.5 * (theta_r - theta_i)) ** 2) / cos_d  # Bravais
    cos_t = np.sqrt(1 - (1 - cos_d**2) / eta**2)
    r = gauss(beta, x + 2 * alpha) * np.cos(phi / 2) / 4 * schlick(np.sqrt((1 + L @ E) / 2))
    h = np.cos(phi / 2) * (1 + (0.6 - 0.8 * cos_phi) / eta_prime)  # Karis's h(φ) fit
    gamma_t = np.arcsin(min(h / eta_prime, 1.0))
    f = schlick(cos_d * np.sqrt(max(1 - h * h, 0.0)))
    tt = (
        gauss(beta / 2, x - alpha)
        * np.exp(-3.65 * cos_phi - 3.98)
        * (1 - f) ** 2
        * np.exp(-sigma * 2 * np.cos(gamma_t) / cos_t)
    )
    f = schlick(cos_d / 2)
    gamma_t = np.arcsin(np.sqrt(3) / 2 / eta_prime)
    trt = (
        gauss(2 * beta, x - 4 * alpha)
        * np.exp(17 * cos_phi - 16.78)
        * (1 - f) ** 2
        * f
        * np.exp(-sigma * 4 * np.cos(gamma_t) / cos_t)
    )
    facing = unit(ep)  # the fibre's normal facing the eye
    wrap = np.clip((facing @ L + 1) / 4, 0, 1)
    # ∫ (0.67 wrap + 0.33 (1 − |T·L|)) dω = 0.67π + 0.33·2π: 3/4 of it makes it π
    scatter = 0.75 * c * (0.67 * wrap + 0.33 * (1 - abs(T @ L)))
    return {"r": np.full(3, r), "tt": tt, "trt": trt, "scatter": scatter}


def physical(T, N, E, L, base, p) -> np.ndarray:
    """π·(R + TT + TRT), the irradiance of a unit-radiance light being π, + scatter, as
    the strand shows over black: a fibre lets the share s of what is behind it through
    (opacity 1 − s), so the single scattering is whole and the scatter term, the
    volume's, is blended by 1 − s and tinted by the fibre's filter per channel, d_c =
    c·exp(−l σa,c), as 1 + (d_c − s)/(1 − s). c, l: the mean of (1 − F)² and the decay of
    exp(−2σa cos γt) over the offsets across the fibre (exact Fresnel, integrated here)."""
    lobes = physical_lobes(T, E, L, base, p)
    single = sum(p[k] * lobes[k] for k in ("r", "tt", "trt"))
    eta = p["eta"]
    h = (np.arange(20000) + 0.5) / 20000
    ci, ct = np.sqrt(1 - h * h), np.sqrt(1 - (h / eta) ** 2)
    rs = ((ci - eta * ct) / (ci + eta * ct)) ** 2
    rp = ((eta * ci - ct) / (eta * ci + ct)) ** 2
    passed = (1 - (rs + rp) / 2) ** 2
    clear = passed.mean()
    chord = -np.log((passed * np.exp(-0.4 * ct)).mean() / clear) / 0.2
    poly = 5.969 - 0.215 * 0.3 + 2.532 * 0.3**2 - 10.73 * 0.3**3 + 5.574 * 0.3**4 + 0.245 * 0.3**5
    d = p["translucency"] * clear * np.exp(-chord * (np.log(np.clip(base, 1e-4, 1)) / poly) ** 2)
    s = d @ (0.2126, 0.7152, 0.0722)
    tint = np.maximum(1 + (d - s) / (1 - s), 0)
    return np.pi * single + (1 - s) * tint * p["scatter"] * lobes["scatter"]


FORMULAS = {
    "kajiya-kay": kajiya_kay,
    "scheuermann": scheuermann,
    "marschner": marschner,
    "physical": physical,
}


def horizontal_strand(width: float) -> HairCurves:
    """Along +x through the origin: at the image centre T = x, N = E = z, t = 0.5."""
    pts = np.linspace([-0.15, 0.0, 0.0], [0.15, 0.0, 0.0], 8)
    return HairCurves.from_array(pts[None], point_data={"width": np.full(8, width)})


def centre_pixel(model: str, light_dir, width: float, params=None, shadows=True) -> np.ndarray:
    img = render_image(
        horizontal_strand(width),
        camera=FRONT,
        size=SIZE,
        background=(0, 0, 0),
        msaa=0,
        hair_color=BASE,
        lights=[Light(light_dir)],
        shading=model,
        shading_params={**PLAIN, **NO_NOISE.get(model, {}), **(params or {})},
        shadows=shadows,
    )
    return img[100, 100, :3].astype(int)


# ---------------------------------------------------------------- no GL
def test_each_model_has_its_parameters_and_shared_ones():
    for model in SHADINGS:
        params = parse_shading(model, None)
        assert {"root_occlusion", "shadow_density", "shadow_layer", "oit_sharpness"} <= set(params)
    assert "alpha" in parse_shading("marschner", {"alpha": -10})
    assert parse_shading("scheuermann", {"specular_color": [1, 0.5, 0]})["specular_color"] == (
        1.0,
        0.5,
        0.0,
    )


@pytest.mark.parametrize(
    ("model", "params", "message"),
    [
        ("marschner", {"specular": 0.3}, r"unknown key 'specular' for shading 'marschner'.*alpha"),
        ("kajiya-kay", {"shininess": 0}, r"shading_params\['shininess'\]: must be in \[0.1,"),
        ("scheuermann", {"sparkle": "lots"}, r"shading_params\['sparkle'\]: expected a number"),
        ("marschner", {"beta": float("nan")}, r"shading_params\['beta'\]: must be finite and in"),
        ("kajiya-kay", {"specular_color": (1, 1)}, r"shading_params\['specular_color'\]"),
        ("kajiya-kay", {"shadow_density": True}, r"expected a number"),
        ("phong", None, r"shading: unknown model 'phong'; allowed: kajiya-kay, scheuermann"),
        ("physical", {"alpha": 1}, r"unknown key 'alpha' for shading 'physical'.*roughness"),
        ("physical", {"roughness": 2.0}, r"shading_params\['roughness'\]: must be in \[0.05,"),
        ("physical", {"cuticle_tilt": -20}, r"shading_params\['cuticle_tilt'\]: must be in"),
    ],
)
def test_bad_shading_params_name_the_field(model, params, message):
    with pytest.raises(InputError, match=message):
        parse_shading(model, params)


# ---------------------------------------------------------------- GL
@pytest.mark.parametrize("model", SHADINGS)
@pytest.mark.parametrize("light_dir", [(0.0, 0.6, 0.8), (0.3, 0.5, 0.81), (0.0, 0.3, -1.0)])
@pytest.mark.parametrize("width_px", [6.0, 0.3])  # per fragment / per step (and faded)
def test_single_strand_matches_the_formula(model, light_dir, width_px):
    width = width_px * FRONT.pixel_scale(SIZE[1])  # at depth 1
    got = centre_pixel(model, light_dir, width)
    T, N, E = np.array([1.0, 0, 0]), np.array([0, 0, 1.0]), np.array([0, 0, 1.0])
    params = parse_shading(model, {**PLAIN, **NO_NOISE.get(model, {})})
    radiance = FORMULAS[model](T, N, E, unit(light_dir), BASE, params)
    coverage = min(width_px, 1.0)  # thinner hair is drawn 1 px wide, faded by its width
    want = np.round(linear_to_srgb(radiance * coverage) * 255)
    assert np.all(np.abs(got - want) <= 2), (got, want)
    assert got.max() > 20  # the light reaches the strand: a real comparison


def test_marschner_tt_lobe_brightens_a_back_lit_strand():
    back, front = (0.0, 0.25, -1.0), (0.0, 0.25, 1.0)  # behind the hair / behind the camera
    width = 6.0 * FRONT.pixel_scale(SIZE[1])
    lit = centre_pixel("marschner", back, width)
    no_tt = centre_pixel("marschner", back, width, {"tt": 0.0})
    assert lit.sum() > no_tt.sum() + 150, (lit, no_tt)
    assert lit[0] > lit[1] > lit[2]  # tinted by the hair colour: exp(-σa · path)
    # lit from the front, transmission adds (almost) nothing
    assert (
        np.abs(
            centre_pixel("marschner", front, width)
            - centre_pixel("marschner", front, width, {"tt": 0.0})
        ).max()
        <= 2
    )


def test_scheuermann_noise_varies_the_highlight_along_the_strand():
    """Shift noise and the sparkle mask vary along the strand, the same way every time."""
    strand = horizontal_strand(6.0 * FRONT.pixel_scale(SIZE[1]))
    kw = dict(
        camera=FRONT,
        size=SIZE,
        background=(0, 0, 0),
        msaa=0,
        hair_color=BASE,
        lights=[Light((0.0, 0.6, 0.8))],
        shading="scheuermann",
        shading_params=PLAIN,
    )
    row = render_image(strand, **kw)[100, 60:141, :3].astype(int)
    again = render_image(strand, **kw)[100, 60:141, :3].astype(int)
    smooth = render_image(strand, **{**kw, "shading_params": {**PLAIN, **NO_NOISE["scheuermann"]}})
    np.testing.assert_array_equal(row, again)

    def turns(values):  # local extrema: how often the brightness changes direction
        steps = np.sign(np.diff(values.sum(axis=1)))
        steps = steps[steps != 0]
        return int(np.sum(steps[1:] != steps[:-1]))

    assert turns(row) >= 4 and turns(smooth[100, 60:141, :3].astype(int)) <= 1


@pytest.mark.parametrize("model", SHADINGS)
def test_every_model_renders_plausible_hair(model):
    """A small brown groom: hair pixels differ from the background, are brown-tinted,
    neither black nor blown out."""
    rng = np.random.default_rng(3)
    roots = rng.normal(size=(400, 3))
    roots = 0.08 * roots / np.linalg.norm(roots, axis=1, keepdims=True)
    grow = roots / 0.08 * 0.05 + np.array([0.0, -0.03, 0.0])
    pts = roots[:, None] + np.linspace(0, 1, 8)[None, :, None] * grow[:, None]
    curves = HairCurves.from_array(pts, point_data={"width": np.full(pts.shape[0] * 8, 4e-4)})
    bg = np.array([0.02, 0.02, 0.02])
    img = render_image(
        curves, size=(96, 96), shading=model, background=bg, hair_color=(0.3, 0.15, 0.06)
    )
    rgb = img[..., :3].astype(int)
    hair = np.abs(rgb - rgb[0, 0]).sum(axis=2) > 12
    assert 0.1 < hair.mean() < 0.9
    mean = rgb[hair].mean(axis=0)
    assert 25 < mean.mean() < 220, mean
    assert mean[0] > mean[2]  # warm, like the hair colour
