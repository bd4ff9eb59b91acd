"""Renderer options: defaults, and validation of sizes, colours, shading and meshes."""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike

from ..errors import InputError
from ..melanin import absorption_scale
from ..validate import number, whole

__all__ = [
    "SHADINGS",
    "MAX_SUBDIVISIONS",
    "MAX_LIGHTS",
    "MAX_SIZE",
    "DEFAULT_HAIR_COLOR",
    "DEFAULT_HAIR_WIDTH",
    "DEFAULT_HAIR_OPACITY",
    "DEFAULT_SKIN_COLOR",
    "DEFAULT_SCALP_TINT",
    "DEFAULT_BACKGROUND",
    "COMMON_PARAMS",
    "MODEL_PARAMS",
    "ANGLE_PARAMS",
    "MAX_SHADOW_SIZE",
    "MAX_STEP_PX",
    "DEFAULT_SHADOW_SIZE",
    "shading_params_for",
    "model_uniforms",
    "color3",
    "parse_background",
    "background_rows",
    "parse_size",
    "parse_shading",
    "see_through",
    "see_through_fit",
    "scalar_param",
    "ShadingValue",
    "check_mesh",
    "RASTER_ENGINES",
    "ENGINE_NAMES",
    "MAX_SPP",
    "point_attr",
]

RASTER_ENGINES = ("auto", "opengl", "cpu")  # follicle.render.engines: stills, frames, the viewer
ENGINE_NAMES = (*RASTER_ENGINES, "mitsuba")  # every engine (follicle.render.backends.ENGINES)
MAX_SPP = 1 << 16  # samples per pixel a path tracer may take
SHADINGS = ("kajiya-kay", "scheuermann", "marschner", "physical")
MAX_SUBDIVISIONS = 16
MAX_LIGHTS = 8
MAX_SIZE = 8192
MAX_SHADOW_SIZE = 4096
DEFAULT_SHADOW_SIZE = 512  # texels per side of the key light's shadow maps
# longest Catmull-Rom step on screen, pixels: shading is interpolated along a step
MAX_STEP_PX = 8.0

DEFAULT_HAIR_COLOR = (0.16, 0.09, 0.045)  # linear RGB, a mid brown
DEFAULT_HAIR_WIDTH = 80e-6  # diameter, metres
DEFAULT_HAIR_OPACITY = 1.0
DEFAULT_SKIN_COLOR = (0.42, 0.25, 0.18)  # linear RGB
DEFAULT_SCALP_TINT = 0.8  # the skin under the hair this far towards the roots' colour
# (top, bottom) of the gradient, linear RGB: every render's and [render].background_*'s
DEFAULT_BACKGROUND = ((0.33, 0.36, 0.41), (0.08, 0.085, 0.1))

# name: (default, low, high, meaning); a tuple default is a linear RGB colour.
# Lobe shifts follow Marschner et al. 2003: a lobe "towards the root" peaks where the
# half vector leans towards the root (θh < 0, α < 0, or a positive tangent shift along
# the ribbon normal); on a head seen from the light's side that puts the band nearer the
# tips. The primary (R) lobe goes towards the root, the tinted one (TRT) towards the tip.
# A shading parameter's value: a number, or a colour (r, g, b) when the default is one.
ShadingValue = float | tuple[float, ...]
Spec = tuple[ShadingValue, float, float, str]
# dark hair keeps its colour where the primary lobe is seen at grazing angles
SPECULAR_TINT: Spec = (
    0.6,
    0.0,
    1.0,
    "primary highlight's colour towards the hair's hue: 0 specular_color, 1 its hue",
)
COMMON_PARAMS: dict[str, Spec] = {
    "root_occlusion": (0.65, 0.0, 1.0, "darkening towards the root, 0 .. 1"),
    "roundness": (0.35, 0.0, 1.0, "darkening towards the ribbon edges (hair over 1 px wide)"),
    "skin_wrap": (0.1, 0.0, 1.0, "wrap-around term of the skin's Lambert shading"),
    "shadow_density": (0.7, 0.0, 100.0, "κ of the hair shadow transmittance exp(−κ·opacity)"),
    "skin_softness": (
        0.01,
        0.0,
        0.1,
        "width of the skin's own shadow edges, m (a box filter over the shadow map; 0: a texel)",
    ),
    "shadow_layer": (
        0.0,
        0.0,
        10.0,
        "deep opacity map layer thickness, m; 0: the hair's bounding-box diagonal / 100",
    ),
    "oit_sharpness": (
        40.0,
        0.0,
        1000.0,
        "OIT weight exp(−k·Δdepth/depth): how much nearer hair outweighs farther",
    ),
}
MODEL_PARAMS: dict[str, dict[str, Spec]] = {
    "kajiya-kay": {
        "diffuse": (0.6, 0.0, 10.0, "K_d, eq. 3.8"),
        "specular": (0.4, 0.0, 10.0, "K_s, eq. 3.9: the primary highlight"),
        "shininess": (120.0, 0.1, 10000.0, "p, eq. 3.9"),
        "specular_color": ((1.0, 0.97, 0.92), 0.0, 100.0, "primary highlight colour"),
        "specular2": (0.5, 0.0, 10.0, "second highlight, tinted by the hair (0: off)"),
        "shininess2": (30.0, 0.1, 10000.0, "second highlight exponent"),
        "shift": (
            0.08,
            -1.0,
            1.0,
            "primary tangent shift along the ribbon normal (> 0: the lobe tilts towards the root)",
        ),
        "shift2": (-0.12, -1.0, 1.0, "second highlight tangent shift"),
        "specular_tint": SPECULAR_TINT,
    },
    "scheuermann": {
        "diffuse": (0.6, 0.0, 10.0, "K_d of max(0, 0.75 N·L + 0.25) (Almeida 2014 Alg. 6)"),
        "specular": (0.5, 0.0, 10.0, "primary highlight"),
        "shininess": (128.0, 0.1, 10000.0, "primary exponent (Alg. 6: 128)"),
        "specular_color": ((1.0, 0.97, 0.92), 0.0, 100.0, "primary highlight colour"),
        "specular2": (1.0, 0.0, 10.0, "secondary highlight, tinted by the hair colour"),
        "shininess2": (48.0, 0.1, 10000.0, "secondary exponent (Alg. 6: 90)"),
        "shift": (
            0.1,
            -1.0,
            1.0,
            "primary tangent shift along the ribbon normal (> 0: lobe towards the root)",
        ),
        "shift2": (-0.12, -1.0, 1.0, "secondary tangent shift (< 0: towards the tip)"),
        "specular_tint": SPECULAR_TINT,
        "shift_noise": (0.3, 0.0, 2.0, "± noise added to both shifts along each strand"),
        "sparkle": (0.6, 0.0, 1.0, "how much noise masks the secondary highlight"),
        "noise_frequency": (12.0, 0.0, 1000.0, "noise cycles per hair length"),
    },
    "marschner": {
        "alpha": (-7.0, -30.0, 30.0, "R lobe shift α, degrees (TT: −α/2, TRT: −3α/2)"),
        "beta": (5.0, 0.5, 45.0, "R lobe width β, degrees (TT: β/2, TRT: 2β)"),
        "r": (1.0, 0.0, 100.0, "R (surface reflection) strength (1: a smooth fibre's Fresnel)"),
        "tt": (1.0, 0.0, 100.0, "TT (transmission) strength"),
        "trt": (3.0, 0.0, 100.0, "TRT (internal reflection) strength"),
        "tt_width": (25.0, 1.0, 180.0, "azimuthal width of the TT lobe around φ = π, degrees"),
        "eta": (1.55, 1.0, 3.0, "refractive index of the fibre"),
        "diffuse": (0.6, 0.0, 10.0, "sin(T, L) term standing in for multiple scattering"),
    },
    # the defaults are those of Mitsuba's hair BSDF, which renders the reference
    "physical": {
        "roughness": (
            0.3,
            0.05,
            1.0,
            "longitudinal roughness β_m: R lobe width 0.726β + 0.812β² + 3.7β²⁰ rad,"
            " TT half, TRT twice (Chiang 2016 §4.1)",
        ),
        "cuticle_tilt": (
            2.0,
            -10.0,
            10.0,
            "cuticle scale tilt α, degrees: R shifted by −2α, TT by α, TRT by 4α",
        ),
        "eta": (1.55, 1.0, 3.0, "refractive index of the fibre"),
        "r": (1.0, 0.0, 100.0, "R (surface reflection) strength"),
        "tt": (1.0, 0.0, 100.0, "TT (transmission) strength"),
        "trt": (1.0, 0.0, 100.0, "TRT (internal reflection) strength"),
        "backlit": (
            0.0,
            0.0,
            1.0,
            "TT share of the lights without shadows (all but the key), which would shine"
            " through the head and the hair in front (Karis 2016's Backlit)",
        ),
        "translucency": (
            1.0,
            0.0,
            1.0,
            "share of the light behind a fibre that it lets through, as its absorption"
            " does (TT at normal incidence): light hair shows what is behind it (0:"
            " opaque fibres, as the other models)",
        ),
        "scatter": (
            2.0,
            0.0,
            10.0,
            "multiple scattering strength, the soft look (Karis 2016): 1 returns a white"
            " fibre's light once; 2, light bounced on through the hair volume (nearest"
            " Mitsuba on the gallery)",
        ),
    },
}
ANGLE_PARAMS = ("alpha", "beta", "tt_width", "cuticle_tilt")  # degrees in, radians out


def color3(value: object, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise InputError(f"{name}: expected 3 non-negative linear RGB numbers, got {value!r}")
    return arr


def parse_background(background: object) -> tuple[np.ndarray, np.ndarray]:
    if background is None:
        background = DEFAULT_BACKGROUND
    arr = np.asarray(background, dtype=np.float64)
    if arr.shape == (3,):
        top = bottom = color3(arr, "background")
    elif arr.shape == (2, 3):
        top, bottom = color3(arr[0], "background top"), color3(arr[1], "background bottom")
    else:
        raise InputError(
            "background: expected one linear RGB colour (r, g, b) or a vertical gradient"
            f" ((r, g, b) top, (r, g, b) bottom), got shape {arr.shape}"
        )
    return top, bottom


def background_rows(background: tuple[ArrayLike, ArrayLike], height: int) -> np.ndarray:
    """The background gradient per image row, top row first, (H, 3) float64: ``bottom``
    to ``top`` (:func:`parse_background`'s pair) linear over the pixel centres, as the
    OpenGL engine's full-screen triangle interpolates it."""
    top, bottom = (np.asarray(c, np.float64) for c in background)
    y = 1.0 - (np.arange(height) + 0.5) / height  # 0 at the bottom edge, 1 at the top
    return bottom[None, :] + (top - bottom)[None, :] * y[:, None]


MAX_SOFT = 8  # texels: a skin receiver reads at most (2·8 + 2)² of them, at edges only


def soft_radius(softness: float, texel: float) -> int:
    """The skin receivers' filter radius r in texels: a box (2r + 1) texels wide as near
    ``softness`` metres as whole texels allow, at most :data:`MAX_SOFT`."""
    return min(max(int(round((softness / texel - 1.0) / 2.0)), 0), MAX_SOFT)


def parse_size(size: object) -> tuple[int, int]:
    w: object
    h: object
    try:
        w, h = size  # type: ignore[misc]  # any pair unpacks; anything else raises here
    except (TypeError, ValueError):
        raise InputError(f"size: expected (width, height), got {size!r}") from None
    return (
        whole(w, "size width", 1, MAX_SIZE, what="a whole number of pixels"),
        whole(h, "size height", 1, MAX_SIZE, what="a whole number of pixels"),
    )


def shading_params_for(shading: str) -> dict[str, Spec]:
    """The parameters model ``shading`` accepts: its own and the common ones."""
    if shading not in SHADINGS:
        raise InputError(f"shading: unknown model {shading!r}; allowed: {', '.join(SHADINGS)}")
    return {**MODEL_PARAMS[shading], **COMMON_PARAMS}


def parse_shading(shading: str, params: Mapping[str, object] | None) -> dict[str, ShadingValue]:
    """Defaults of model ``shading`` updated by ``params``, each checked against its range."""
    specs = shading_params_for(shading)
    merged: dict[str, ShadingValue] = {key: spec[0] for key, spec in specs.items()}
    for key, value in (params or {}).items():
        if key not in specs:
            raise InputError(
                f"shading_params: unknown key {key!r} for shading {shading!r};"
                f" allowed: {', '.join(specs)}"
            )
        default, lo, hi, _ = specs[key]
        if isinstance(default, tuple):
            merged[key] = tuple(color3(value, f"shading_params[{key!r}]"))
            continue
        merged[key] = number(value, f"shading_params[{key!r}]", lo=lo, hi=hi)
    return merged


def model_uniforms(shading: str, params: Mapping[str, ShadingValue]) -> dict[str, ShadingValue]:
    """The parameters as the shaders take them: ``p_`` names, angles in radians; the
    physical model also gets ``p_absorption``, k of σ_a = k·(ln C)² (Chiang 2016 §4.2,
    :func:`follicle.melanin.absorption_scale`), the mapping Mitsuba's σ_a comes from."""
    out: dict[str, ShadingValue] = {
        f"p_{k}": (float(np.radians(scalar_param(params, k))) if k in ANGLE_PARAMS else v)
        for k, v in params.items()
    }
    if shading == "physical":
        out["p_absorption"] = absorption_scale()
        out["p_clear"], out["p_chord"] = see_through_fit(scalar_param(params, "eta"))
    return out


LUMINANCE = (0.2126, 0.7152, 0.0722)  # Rec. 709 weights of linear RGB


@lru_cache(maxsize=8)
def see_through_fit(eta: float) -> tuple[float, float]:
    """(c, l) of a fibre's transmittance to light from straight behind it, c·exp(−l·σ_a)
    per channel: the TT attenuation (1 − F(γ))²·exp(−2σ_a cos γ_t) (Marschner et al.
    2003 §4; σ_a per unit radius) averaged over the offsets h = sin γ across a fibre seen
    side on, with Fresnel's unpolarised F of index ``eta``. c is the mean of (1 − F)²
    (0.862 at η 1.55), l the decay of that mean fitted at σ_a = 0.2 (1.863; within 0.5 %
    of the exact mean for σ_a up to 0.8, 1.5 % at 3.2, where it is below 0.003). Kept
    per η: every frame's uniforms and vertex opacities ask for it."""
    h = np.linspace(-1.0, 1.0, 4097)[1:-1]
    cos_i = np.sqrt(1.0 - h * h)
    cos_t = np.sqrt(1.0 - (h / eta) ** 2)
    rs = ((cos_i - eta * cos_t) / (cos_i + eta * cos_t)) ** 2
    rp = ((eta * cos_i - cos_t) / (eta * cos_i + cos_t)) ** 2
    passed = (1.0 - 0.5 * (rs + rp)) ** 2
    clear = float(passed.mean())
    sigma = 0.2
    return clear, float(-np.log((passed * np.exp(-2.0 * sigma * cos_t)).mean() / clear) / sigma)


def see_through(color: np.ndarray, params: Mapping[str, ShadingValue]) -> np.ndarray:
    """The share of the light behind a fibre of linear colour ``color`` (..., 3) that the
    physical model lets through it, Rec. 709 luminance of
    ``translucency``·c·exp(−l·σ_a) (:func:`see_through_fit`), σ_a = k (ln C)² (Chiang
    2016 §4.2): a raster engine draws such a fibre with opacity × (1 − share) and its
    reflected light ÷ (1 − share), so that what lies behind shows through by that share.
    Zero for the other models' params (no ``translucency``)."""
    if "translucency" not in params:
        return np.zeros(np.shape(color)[:-1])
    clear, chord = see_through_fit(scalar_param(params, "eta"))
    c = np.clip(np.asarray(color, dtype=np.float64), 1e-4, 1.0)
    sigma = absorption_scale() * np.log(c) ** 2
    share = scalar_param(params, "translucency") * clear * np.exp(-chord * sigma)
    return share @ np.array(LUMINANCE)


def scalar_param(params: Mapping[str, ShadingValue], key: str) -> float:
    """The number parameter ``key`` of ``params`` (:func:`parse_shading`'s), as a float."""
    value = params[key]
    if isinstance(value, tuple):
        raise TypeError(f"shading parameter {key!r} is a colour, not a number")
    return float(value)


def check_mesh(mesh: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    try:
        vertices = np.asarray(mesh.vertices, dtype=np.float64)  # type: ignore[attr-defined]
        faces = np.asarray(mesh.faces)  # type: ignore[attr-defined]
        normals = np.asarray(mesh.vertex_normals("current"), dtype=np.float64)  # type: ignore[attr-defined]
    except AttributeError as exc:
        raise InputError(
            "mesh: expected a SkinMesh (vertices, faces, vertex_normals),"
            f" got {type(mesh).__name__}"
        ) from exc
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise InputError(
            "mesh: expected vertices (V, 3) and faces (F, 3),"
            f" got {vertices.shape} and {faces.shape}"
        )
    if normals.shape != vertices.shape:
        raise InputError(
            f"mesh: vertex normals have shape {normals.shape}, expected {vertices.shape}"
        )
    if not (np.all(np.isfinite(vertices)) and np.all(np.isfinite(normals))):
        raise InputError("mesh: vertices or normals contain NaN or inf")
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise InputError("mesh: face indices out of range of the vertices")
    return vertices, faces, normals


def point_attr(
    pd: Mapping[str, np.ndarray], key: str, shape: tuple[int, ...], default
) -> np.ndarray:
    if key in pd:
        arr = np.asarray(pd[key], dtype=np.float32)
        if arr.shape != shape:
            raise InputError(f"point_data[{key!r}]: expected shape {shape}, got {arr.shape}")
        return arr
    return np.broadcast_to(np.asarray(default, dtype=np.float32), shape)
