"""Shape deformers on hairs in root-local frames: Frizz, Kink (Šik 2012 §2.2.5), Curl
(Almeida 2014 §3.1.2).

Every function works IN PLACE on a chunk ``local`` of n hairs, a C-contiguous, writable
float64 array (n, N, 3): x along the root tangent T, y along the binormal B, z along the
surface normal N; vertex 0 is the root at the origin and is never moved. Call them after
interpolation and scaling, before the transform to world space (Šik 2012 §2.2.2), in the order
``curl`` (a shape), ``frizz``, ``kink`` (Kink samples the vertices as they are then).

Per-hair properties (already global × texture(uv)) are numbers or float64 arrays (n,).
The public functions check every argument once, then call the unchecked ``_frizz``,
``_kink`` and ``_curl``, which the generator calls directly with arrays it made: in
kernel form, float64 C-contiguous per-hair rows, (n,) or (1,) and (n, 3) or (1, 3)
(:func:`follicle.groom.params.per_hair`), and ``t`` (n, N) or (1, N).
The curve parameter of vertex i is the ORIGINAL parametrisation t = i / (N - 1) (Šik 2012
§2.2.8: cutting a hair keeps it); pass ``t`` ((N,) or (n, N), values in [0, 1]) to use
another one, e.g. i / (N_uncut - 1) for cut hairs. Noise is a pure function of rest-pose
positions, so hairs keep their shape on an animated mesh and any chunking gives the
same bytes.
"""

from __future__ import annotations

import numpy as np

from ..arrays import all_finite
from ..errors import InputError
from ..frames import polyline_frames
from ..kernels import kernel, prange
from ..noise import noise3
from ..rng import uniforms
from ..validate import number
from .params import curve_parameter, per_hair, row

__all__ = ["frizz", "kink", "curl", "curl_phase"]

_TWO_PI = 2.0 * np.pi
_RAMP = 0.15  # curl's default ramp: the share of the hair over which the radius grows in
_ROOT_TANGENT = np.array([1.0, 0.0, 0.0])  # local +x: the first normal of the curl frame


# ------------------------------------------------------------------------------- kernels
@kernel(parallel=True, nogil=True)
def _frizz_kernel(local, roots, amp_root, amp_tip, freq, offset, blend, t):
    n_verts = local.shape[1]
    for h in prange(local.shape[0]):
        fr = amp_root[row(amp_root, h)]
        ft = amp_tip[row(amp_tip, h)]
        if fr == 0.0 and ft == 0.0:
            continue
        a = blend[row(blend, h)]
        fq = freq[row(freq, h)]
        rt = roots[row(roots, h)]
        off = offset[row(offset, h)]
        fx = 0.0
        fy = 0.0
        fz = 0.0
        if a != 1.0:  # static F = noise3D(frequency ⊙ rest root)
            sx, sy, sz = noise3(fq[0] * rt[0], fq[1] * rt[1], fq[2] * rt[2])
            fx = (1.0 - a) * sx
            fy = (1.0 - a) * sy
            fz = (1.0 - a) * sz
        if a != 0.0:  # F_dynamic = noise3D(frequency ⊙ (rest root + offset))
            dx, dy, dz = noise3(
                fq[0] * (rt[0] + off[0]), fq[1] * (rt[1] + off[1]), fq[2] * (rt[2] + off[2])
            )
            fx += a * dx
            fy += a * dy
            fz += a * dz
        fz = -abs(fz)  # F_combined.z = -|F_combined.z|: bend towards the skin, never away
        cap = max(fr, ft)
        th = t[row(t, h)]
        for i in range(1, n_verts):
            ti = th[i]
            amp = min(fr * 4.0 * (ti - ti * ti) + ft * ti * ti, cap)
            local[h, i, 0] += fx * amp
            local[h, i, 1] += fy * amp
            z = local[h, i, 2]
            floor = min(z, 0.0)  # a vertex above the skin plane is not pushed below it
            local[h, i, 2] = max(z + fz * amp, floor)


@kernel(parallel=True, nogil=True)
def _kink_kernel(local, roots, tangent, binormal, normal, amp_root, amp_tip, freq, t):
    n_verts = local.shape[1]
    for h in prange(local.shape[0]):
        kr = amp_root[row(amp_root, h)]
        kt = amp_tip[row(amp_tip, h)]
        if kr == 0.0 and kt == 0.0:
            continue
        tg = tangent[row(tangent, h)]
        bn = binormal[row(binormal, h)]
        nm = normal[row(normal, h)]
        th = t[row(t, h)]
        fq = freq[row(freq, h)]
        rt = roots[row(roots, h)]
        for i in range(1, n_verts):
            x = local[h, i, 0]
            y = local[h, i, 1]
            z = local[h, i, 2]
            # the vertex in world space on the rest pose: root + x T + y B + z N
            wx = rt[0] + x * tg[0] + y * bn[0] + z * nm[0]
            wy = rt[1] + x * tg[1] + y * bn[1] + z * nm[1]
            wz = rt[2] + x * tg[2] + y * bn[2] + z * nm[2]
            kx, ky, kz = noise3(fq[0] * wx, fq[1] * wy, fq[2] * wz)
            ti = th[i]
            amp = (1.0 - ti) * kr + ti * kt
            local[h, i, 0] = x + kx * amp
            local[h, i, 1] = y + ky * amp
            local[h, i, 2] = z + kz * amp


@kernel(parallel=True, nogil=True)
def _curl_kernel(local, radius, f_root, f_tip, phase, ramp, t):
    n_verts = local.shape[1]
    for h in prange(local.shape[0]):
        a = radius[row(radius, h)]
        if a == 0.0:
            continue
        tan = np.empty((n_verts, 3))
        nor = np.empty((n_verts, 3))
        bi = np.empty((n_verts, 3))
        polyline_frames(local[h], _ROOT_TANGENT, tan, nor, bi)
        th = t[row(t, h)]
        theta = phase[row(phase, h)]
        f0 = f_root[row(f_root, h)]
        f1 = f_tip[row(f_tip, h)]
        px = local[h, 0, 0]
        py = local[h, 0, 1]
        pz = local[h, 0, 2]
        for i in range(1, n_verts):
            cx = local[h, i, 0]
            cy = local[h, i, 1]
            cz = local[h, i, 2]
            # θ(s) = phase + 2π ∫ f ds along the axis (the input polyline), f linear in t:
            # the midpoint rule is exact on each segment
            seg = np.sqrt((cx - px) ** 2 + (cy - py) ** 2 + (cz - pz) ** 2)
            tm = 0.5 * (th[i - 1] + th[i])
            theta += _TWO_PI * (f0 + (f1 - f0) * tm) * seg
            ti = th[i]
            if ti >= ramp:
                r = a
            else:
                u = ti / ramp
                r = a * u * u * (3.0 - 2.0 * u)  # smoothstep: the radius grows in from 0
            c = r * np.cos(theta)
            s = r * np.sin(theta)
            local[h, i, 0] = cx + c * nor[i, 0] + s * bi[i, 0]
            local[h, i, 1] = cy + c * nor[i, 1] + s * bi[i, 1]
            local[h, i, 2] = cz + c * nor[i, 2] + s * bi[i, 2]
            px = cx
            py = cy
            pz = cz


# ---------------------------------------------------------------------------- validation
def _check_local(local: object) -> np.ndarray:
    if not isinstance(local, np.ndarray) or local.dtype != np.float64:
        kind = local.dtype if isinstance(local, np.ndarray) else type(local).__name__
        raise InputError(f"local: expected a float64 numpy array (changed in place), got {kind}")
    if local.ndim != 3 or local.shape[1] < 1 or local.shape[2] != 3:
        raise InputError(f"local: expected shape (n, N >= 1, 3), got {local.shape}")
    if not (local.flags.c_contiguous and local.flags.writeable):
        raise InputError("local: must be C-contiguous and writeable (it is changed in place)")
    if not all_finite(local):
        raise InputError("local: vertices must be finite (no NaN or inf)")
    return local


def _frame(rest_frame: object, n: int) -> list[np.ndarray]:
    """Rest root frames [T, B, N], each (n, 3); None: the world axes."""
    if rest_frame is None:
        return [per_hair(axis, n, "rest_frame", vector=True) for axis in np.eye(3)]
    if not isinstance(rest_frame, (tuple, list)) or len(rest_frame) != 3:
        raise InputError("rest_frame: expected a tuple (tangent, binormal, normal) of (n, 3)")
    shapes = [np.shape(v) for v in rest_frame]
    if any(shape != (n, 3) for shape in shapes):
        raise InputError(f"rest_frame: expected three arrays of shape ({n}, 3), got {shapes}")
    return [per_hair(v, n, "rest_frame", vector=True) for v in rest_frame]


# ------------------------------------------------------------------- unchecked, in kernel form
def _frizz(local, roots, amp_root, amp_tip, frequency, offset, blend, t) -> None:
    """:func:`frizz` on arguments in kernel form (the module notes); nothing is checked."""
    _frizz_kernel(local, roots, amp_root, amp_tip, frequency, offset, blend, t)


def _kink(local, roots, rest_frame, amp_root, amp_tip, frequency, t) -> None:
    """:func:`kink` on arguments in kernel form, ``rest_frame`` a (T, B, N) sequence of
    per-hair rows; nothing is checked."""
    tangent, binormal, normal = rest_frame
    _kink_kernel(local, roots, tangent, binormal, normal, amp_root, amp_tip, frequency, t)


def _curl(local, radius, f_root, f_tip, phase, ramp, t) -> None:
    """:func:`curl` on arguments in kernel form, ``ramp`` a float in [0, 1]; nothing is
    checked."""
    n, n_verts = local.shape[:2]
    if n == 0 or n_verts < 2:
        return
    _curl_kernel(local, radius, f_root, f_tip, phase, ramp, t)


# --------------------------------------------------------------------------------- public
def frizz(
    local: np.ndarray,
    rest_roots: np.ndarray,
    amp_root: float | np.ndarray,
    amp_tip: float | np.ndarray,
    frequency: np.ndarray,
    offset: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0),
    blend: float | np.ndarray = 0.0,
    t: np.ndarray | None = None,
) -> None:
    """Šik 2012 §2.2.5 Frizz, in place: one noise vector per hair bends the whole hair.

    F = noise3D(frequency ⊙ rest_root) with ``rest_roots`` (n, 3) the roots on the rest
    mesh in world space and ``frequency`` the X/Y/Z frequencies ((3,) or (n, 3)).
    Animated frizz: F_dynamic = noise3D(frequency ⊙ (rest_root + offset)) with
    ``offset`` = Frizz_Anim_Direction · speed · time ((3,) or (n, 3), from the caller),
    and F_combined = (1 - blend) F + blend F_dynamic with ``blend`` the animationFactor
    in [0, 1]. Choice: Šik 2012 writes the dynamic input as frequency · dynamic · root (a
    product), which gives every hair the same vector at time 0 and stretches the noise
    away from the world origin; adding the offset instead slides the pattern over the skin
    along the direction at the given speed (a breeze). Then F_combined.z = -|F_combined.z|
    and every vertex but the root moves by F_combined · min(amp_root · 4(t - t²) +
    amp_tip · t², max(amp_root, amp_tip)) (amplitudes >= 0). Choice: a vertex on or above
    the skin plane z = 0 is not moved below it (its z stops at 0; one below keeps its z),
    so frizz never pushes hair into the skin. F is not normalised (as in Šik 2012).
    """
    local = _check_local(local)
    n, n_verts = local.shape[:2]
    _frizz(
        local,
        per_hair(rest_roots, n, "rest_roots", vector=True),
        per_hair(amp_root, n, "amp_root", lo=0.0),
        per_hair(amp_tip, n, "amp_tip", lo=0.0),
        per_hair(frequency, n, "frequency", vector=True),
        per_hair(offset, n, "offset", vector=True),
        per_hair(blend, n, "blend", lo=0.0, hi=1.0),
        curve_parameter(t, n, n_verts),
    )


def kink(
    local: np.ndarray,
    rest_roots: np.ndarray,
    amp_root: float | np.ndarray,
    amp_tip: float | np.ndarray,
    frequency: np.ndarray,
    rest_frame: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    t: np.ndarray | None = None,
) -> None:
    """Šik 2012 §2.2.5 Kink, in place: a noise vector per vertex crimps the hair.

    Vertex i (all but the root) moves by K_i · ((1 - t) amp_root + t amp_tip), with
    K_i = noise3D(frequency ⊙ w_i) and w_i the vertex as it is now placed in world space on
    the rest pose: rest_root + x T + y B + z N with ``rest_frame`` = (T, B, N), each (n, 3)
    (None: the world axes, i.e. w_i = rest_root + vertex). K_i is added in the local frame,
    as in Šik 2012. Choice: the root vertex stays fixed (the paper's linear profile would
    move it by amp_root · K_0, off the skin).
    """
    local = _check_local(local)
    n, n_verts = local.shape[:2]
    _kink(
        local,
        per_hair(rest_roots, n, "rest_roots", vector=True),
        _frame(rest_frame, n),
        per_hair(amp_root, n, "amp_root", lo=0.0),
        per_hair(amp_tip, n, "amp_tip", lo=0.0),
        per_hair(frequency, n, "frequency", vector=True),
        curve_parameter(t, n, n_verts),
    )


def curl(
    local: np.ndarray,
    radius: float | np.ndarray,
    frequency: float | np.ndarray,
    frequency_tip: float | np.ndarray | None = None,
    phase: float | np.ndarray = 0.0,
    ramp: float = _RAMP,
    t: np.ndarray | None = None,
) -> None:
    """Almeida 2014 §3.1.2 Alg. 3 curly hair, in place: winds each hair into a helix about itself.

    Vertex i moves by r(t_i) (cos θ_i n_i + sin θ_i b_i), with (n_i, b_i) the
    rotation-minimising frame of the hair (Šik 2012 §2.2.8) whose first normal is the root
    tangent T = local x, b = tangent × n. θ = phase + 2π ∫ f ds along the hair's arc
    length s, f = ``frequency`` (turns per unit length; Alg. 3's 1/B) at the root rising
    linearly in t to ``frequency_tip`` (None: constant) at t = 1, like Alg. 3's growing
    angle step; a negative frequency winds the other way. The radius r is ``radius``
    (A, >= 0) except for t < ``ramp`` where it grows in from 0 at the root by smoothstep
    (ramp 0: full radius from vertex 1); the root vertex never moves. The hair's axis
    stays, so the hair gets longer: a segment of length h far from the root becomes
    sqrt(h² + (2A sin(π f h))²) on a straight hair. ``phase`` (radians, per hair) turns
    the helix start; :func:`curl_phase` draws one per hair.
    """
    local = _check_local(local)
    n, n_verts = local.shape[:2]
    radius = per_hair(radius, n, "radius", lo=0.0)
    f_root = per_hair(frequency, n, "frequency")
    f_tip = f_root if frequency_tip is None else per_hair(frequency_tip, n, "frequency_tip")
    phase = per_hair(phase, n, "phase")
    ramp = number(ramp, "ramp", lo=0.0, hi=1.0)
    _curl(local, radius, f_root, f_tip, phase, ramp, curve_parameter(t, n, n_verts))


def curl_phase(seed: int, hair_ids: np.ndarray) -> np.ndarray:
    """Per-hair helix phases 2π u, u in [0, 1) from the (seed, id, "curl_phase") stream."""
    return _TWO_PI * uniforms(seed, hair_ids, "curl_phase", 1)[:, 0]
