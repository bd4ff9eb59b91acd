"""Pinhole camera, directional lights and automatic framing.

Matrices follow OpenGL conventions and are returned row-major for column vectors
(``clip = P @ V @ [x, y, z, 1]``); upload them with ``matrix.T.astype("f4").tobytes()``.
Pixel coordinates from :meth:`Camera.project` put (0, 0) at the top-left corner of
the image, x to the right, y downwards; pixel ``(i, j)`` (row, column) covers
``[j, j + 1) × [i, i + 1)``, so the image centre is ``(w / 2, h / 2)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ..arrays import all_finite, as_array, point_bounds
from ..curves import HairCurves
from ..errors import InputError
from ..frames import normalize
from ..kernels import kernel
from ..validate import number, positive

__all__ = [
    "Camera",
    "Light",
    "DEFAULT_FOV",
    "default_lights",
    "fit_camera",
    "frame_camera",
    "frame_scene",
    "hair_bounds",
    "scene_bounds",
    "scene_points",
]

DEFAULT_FOV = 30.0  # vertical field of view, degrees: every camera's and [render].fov's


def _vec3(value: object, name: str) -> np.ndarray:
    arr = as_array(value, name, np.float64)
    if arr.shape != (3,):
        raise InputError(f"{name}: expected 3 numbers, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: must be finite, got {arr.tolist()}")
    return arr


def _fov(value: object, name: str) -> float:
    """A vertical field of view in (0, 180) degrees."""
    return number(value, name, lo=0.0, hi=180.0, lo_open=True, hi_open=True, unit="degrees")


def _perpendicular_up(forward: np.ndarray, up: np.ndarray) -> np.ndarray:
    """``up`` unless it is (nearly) parallel to ``forward``; then the most perpendicular axis."""
    if np.linalg.norm(np.cross(forward, normalize(up))) > 1e-6:
        return up
    axes = np.eye(3)
    return axes[int(np.argmin(np.abs(axes @ forward)))]


@dataclass(eq=False, init=False)
class Camera:
    """A perspective camera at ``eye`` looking at ``target``.

    ``fov_y`` is the vertical field of view in degrees. ``near``/``far`` are the clip
    distances in metres; None lets the renderer fit them to the scene (and
    :meth:`projection_matrix` fall back to 1/100 and 100 × the eye-target distance).
    ``eye``, ``target`` and ``up`` take any three numbers and are stored as (3,) float64
    arrays.
    """

    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray
    fov_y: float
    near: float | None
    far: float | None

    def __init__(
        self,
        eye: ArrayLike,
        target: ArrayLike,
        up: ArrayLike = (0.0, 1.0, 0.0),
        fov_y: float = DEFAULT_FOV,
        near: float | None = None,
        far: float | None = None,
    ) -> None:
        self.eye = _vec3(eye, "camera eye")
        self.target = _vec3(target, "camera target")
        self.up = _vec3(up, "camera up")
        if np.linalg.norm(self.target - self.eye) <= 0.0:
            raise InputError("camera: eye and target are the same point; move the eye back")
        if np.linalg.norm(self.up) <= 0.0:
            raise InputError("camera up: must not be the zero vector")
        self.fov_y = _fov(fov_y, "camera fov_y")
        self.near = None if near is None else positive(near, "camera near", unit="m")
        self.far = None if far is None else number(far, "camera far", unit="m")
        if self.near is not None and self.far is not None and self.far <= self.near:
            raise InputError(f"camera: far ({self.far}) must exceed near ({self.near})")

    # ------------------------------------------------------------------ frame
    @property
    def distance(self) -> float:
        """Distance from eye to target."""
        return float(np.linalg.norm(self.target - self.eye))

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unit (right, up, forward) vectors of the camera in world space."""
        forward = normalize(self.target - self.eye)
        right = normalize(np.cross(forward, _perpendicular_up(forward, self.up)))
        return right, np.cross(right, forward), forward

    def view_matrix(self) -> np.ndarray:
        """World → eye space (OpenGL look-at: the camera looks down -Z), (4, 4) float64."""
        right, up, forward = self.basis()
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = right, up, -forward
        m[:3, 3] = -(m[:3, :3] @ self.eye)
        return m

    def clip_range(
        self, near: float | None = None, far: float | None = None
    ) -> tuple[float, float]:
        """The (near, far) used: explicit arguments, then the camera's, then defaults."""
        near = near if near is not None else self.near
        far = far if far is not None else self.far
        if near is None:
            near = self.distance * 0.01
        if far is None:
            far = max(self.distance * 100.0, near * 10.0)
        return float(near), float(far)

    def projection_matrix(
        self, aspect: float, near: float | None = None, far: float | None = None
    ) -> np.ndarray:
        """OpenGL perspective projection (depth to [-1, 1]) for width/height ``aspect``."""
        aspect = positive(aspect, "aspect")
        n, f = self.clip_range(near, far)
        t = 1.0 / math.tan(math.radians(self.fov_y) / 2.0)
        m = np.zeros((4, 4))
        m[0, 0], m[1, 1] = t / aspect, t
        m[2, 2], m[2, 3] = (f + n) / (n - f), 2.0 * f * n / (n - f)
        m[3, 2] = -1.0
        return m

    def project(self, points: object, size: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (n, 2) as (x, y) from the top-left corner, and view depth (n,).

        The depth is the distance in front of the camera along its viewing axis
        (negative behind it). ``size`` is (width, height) in pixels.
        """
        pts = as_array(points, "project points", np.float64).reshape(-1, 3)
        w, h = (float(s) for s in size)
        right, up, forward = self.basis()
        rel = pts - self.eye
        depth = rel @ forward
        t = math.tan(math.radians(self.fov_y) / 2.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            ndc_x = (rel @ right) / (depth * t * (w / h))
            ndc_y = (rel @ up) / (depth * t)
        xy = np.stack([(ndc_x + 1.0) * 0.5 * w, (1.0 - ndc_y) * 0.5 * h], axis=1)
        return xy, depth

    def pixel_scale(self, height: int) -> float:
        """World size of one pixel per metre of view depth, for an image ``height`` tall."""
        return 2.0 * math.tan(math.radians(self.fov_y) / 2.0) / float(height)


def fit_camera(
    points: object,
    direction: Sequence[float] = (0.35, 0.15, 1.0),
    fov_y: float = DEFAULT_FOV,
    aspect: float = 1.0,
    margin: float = 1.1,
    up: Sequence[float] = (0.0, 1.0, 0.0),
    radius: float = 0.0,
) -> Camera:
    """The closest camera looking along ``-direction`` that sees every point of ``points``
    (N, 3), each grown to a ball of ``radius``, inside the image shrunk by ``margin``
    (1.1 leaves ~5 % of free border on each side of the fuller axis), the points'
    picture centred; near/far bracket them.

    For a fixed view direction this has a closed form: with (x, y, z) the points along
    the camera's right, up and back axes, the eye at ``o_x, o_y, D`` and tx = tan(fov/2)
    · aspect / margin, every point needs |x − o_x| + r·√(1 + tx²) ≤ tx·(D − z) (and the
    same in y). Both sides hold for all points iff max(x + tx·z) − min(x − tx·z) + 2r√(1
    + tx²) ≤ 2·tx·D, so D is the larger of the two axes' bounds and o is the midpoint of
    each axis's feasible range (then centred in the picture). Unlike fitting a bounding
    box's corners, this frames a round head as tightly as its silhouette allows.
    """
    pts = as_array(points, "fit_camera points")
    if pts.dtype.kind != "f":
        pts = pts.astype(np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0:
        raise InputError(f"fit_camera points: expected an (N, 3) array, N > 0, got {pts.shape}")
    lo, hi = point_bounds(pts)
    if not all_finite(pts):
        raise InputError("fit_camera points: must be finite")
    d = _vec3(direction, "fit_camera direction")
    if np.linalg.norm(d) <= 0:
        raise InputError("fit_camera direction: must not be the zero vector")
    margin = number(margin, "fit_camera margin", lo=1.0)
    aspect = positive(aspect, "fit_camera aspect")
    fov_y = _fov(fov_y, "fit_camera fov_y")
    radius = number(radius, "fit_camera radius", lo=0.0)
    centre = 0.5 * (lo + hi)
    # a point (or flat) set still needs some extent to frame
    pad = 1e-3 * max(1.0, float(np.abs(centre).max()))
    if float(np.max(hi - lo)) + 2.0 * radius < 2.0 * pad:
        radius = pad
    back = normalize(d)  # centre -> eye
    forward = -back
    right = normalize(np.cross(forward, _perpendicular_up(forward, _vec3(up, "fit_camera up"))))
    cam_up = np.cross(right, forward)
    ty = math.tan(math.radians(fov_y) / 2.0) / margin
    tx = ty * aspect
    basis = np.stack([right, cam_up, back], axis=1)  # columns: the camera's axes
    local = (pts - centre.astype(pts.dtype)) @ basis.astype(pts.dtype)
    x, y, z = (local[:, k].astype(np.float64) for k in range(3))
    dist, offset = 0.0, [0.0, 0.0]
    for k, (c, t) in enumerate(((x, tx), (y, ty))):
        grow = radius * math.sqrt(1.0 + t * t)
        above, below = _bounds(c, z, t)
        above, below = above + grow, below - grow  # o ≥ above − t·D, o ≤ below + t·D
        dist = max(dist, (above - below) / (2.0 * t))
        offset[k] = 0.5 * (above + below)
    extent = float(np.linalg.norm(hi - lo)) + 2.0 * radius
    nearest, farthest = float(z.max()), float(z.min())
    dist = max(dist, nearest + 1e-2 * extent)  # the eye stays in front of every point
    inv = 1.0 / (dist - z)
    for k, c in enumerate((x, y)):
        # the midpoint of the feasible range centres the fuller axis exactly; Newton
        # steps on (max + min of the projected picture) centre the other one too
        for _ in range(4):
            offset[k] += _centring_step(c, inv, offset[k])
    target = centre + offset[0] * right + offset[1] * cam_up
    near = max(0.5 * (dist - nearest - radius), 1e-3 * dist)
    far = dist - farthest + radius + 0.1 * extent
    return Camera(target + back * dist, target, up=tuple(up), fov_y=fov_y, near=near, far=far)


@kernel
def _bounds(c: np.ndarray, z: np.ndarray, t: float) -> tuple[float, float]:
    """max(c + t·z) and min(c − t·z) in one pass, no temporaries."""
    above, below = -np.inf, np.inf
    for k in range(len(c)):
        above = max(above, c[k] + t * z[k])
        below = min(below, c[k] - t * z[k])
    return above, below


@kernel
def _centring_step(c: np.ndarray, inv: np.ndarray, o: float) -> float:
    """One Newton step on max + min of the projected picture u = (c − o)·inv: one pass,
    no temporaries (the numpy form took 100 ms a frame for 1.6 M hair points)."""
    hi, lo = -np.inf, np.inf
    i = j = 0
    for k in range(len(c)):
        u = (c[k] - o) * inv[k]
        if u > hi:
            hi, i = u, k
        if u < lo:
            lo, j = u, k
    return (hi + lo) / (inv[i] + inv[j])


def frame_camera(
    lo: object,
    hi: object,
    direction: Sequence[float] = (0.35, 0.15, 1.0),
    fov_y: float = DEFAULT_FOV,
    aspect: float = 1.0,
    margin: float = 1.1,
    up: Sequence[float] = (0.0, 1.0, 0.0),
) -> Camera:
    """:func:`fit_camera` on the eight corners of the box ``[lo, hi]``: the box centred
    and fitted to the view. ``direction`` points from the box centre towards the eye."""
    lo, hi = _vec3(lo, "frame_camera lo"), _vec3(hi, "frame_camera hi")
    if np.any(hi < lo):
        raise InputError(f"frame_camera: hi {hi.tolist()} is below lo {lo.tolist()}")
    corners = np.array([[a[0], b[1], c[2]] for a in (lo, hi) for b in (lo, hi) for c in (lo, hi)])
    return fit_camera(corners, direction, fov_y, aspect, margin, up)


def scene_points(curves: HairCurves | None, mesh: object | None) -> tuple[np.ndarray, float]:
    """What :func:`fit_camera` frames when a renderer gets no camera: the hair's points
    and the mesh's vertices in its current pose (N, 3), and the ball radius (half the
    widest hair)."""
    parts: list[np.ndarray] = []
    radius = 0.0
    if curves is not None and curves.point_count:
        parts.append(curves.points)
        if "width" in curves.point_data:
            radius = float(np.max(curves.point_data["width"])) / 2
    if mesh is not None:
        dtype = parts[0].dtype if parts else np.float64
        used = np.unique(np.asarray(mesh.faces))  # type: ignore[attr-defined]
        parts.append(np.asarray(mesh.vertices, dtype)[used])  # type: ignore[attr-defined]
    if not parts:
        raise InputError("scene_points: nothing to frame; give curves with points or a mesh")
    return (parts[0] if len(parts) == 1 else np.concatenate(parts)), radius


def frame_scene(
    curves: HairCurves | None, mesh: object | None, fov_y: float, aspect: float
) -> Camera:
    """The camera a renderer uses when it gets none: :func:`fit_camera` on the hair and
    the mesh (:func:`scene_points`) from the default direction."""
    points, radius = scene_points(curves, mesh)
    return fit_camera(points, fov_y=fov_y, aspect=aspect, radius=radius)


def hair_bounds(curves: HairCurves) -> tuple[np.ndarray, np.ndarray]:
    """Bounding box of the curves' points, grown by half the widest ``width``."""
    lo, hi = curves.bounds()
    pad = float(np.max(curves.point_data["width"])) / 2 if "width" in curves.point_data else 0.0
    return lo - pad, hi + pad


def scene_bounds(
    curves: HairCurves | None,
    mesh: object | None,
    hair_box: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Bounding box of the hair (:func:`hair_bounds`, when it has points; ``hair_box``
    when the caller has it already) and the mesh's current pose: what
    :func:`frame_camera` frames when a renderer gets no camera."""
    boxes = []
    if hair_box is not None:
        boxes.append(hair_box)
    elif curves is not None and curves.point_count:
        boxes.append(hair_bounds(curves))
    if mesh is not None:
        lo, hi = mesh.bounds("current")  # type: ignore[attr-defined]
        boxes.append((np.asarray(lo, np.float64), np.asarray(hi, np.float64)))
    return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)


@dataclass(eq=False, init=False)
class Light:
    """A directional light, or an ambient one when ``direction`` is None.

    ``direction`` points **from the scene towards the light** (the usual L vector of
    shading), e.g. ``(0, 1, 0)`` lights from straight above. With ``space="camera"`` it
    is given in the camera frame (x right, y up, z towards the viewer), so the light
    follows the camera; with ``"world"`` it is fixed in the scene. ``color`` is linear
    RGB, scaled by ``intensity``.
    """

    direction: np.ndarray | None
    color: np.ndarray
    intensity: float
    space: str
    radiance: np.ndarray = field(init=False, repr=False)

    def __init__(
        self,
        direction: ArrayLike | None,
        color: ArrayLike = (1.0, 1.0, 1.0),
        intensity: float = 1.0,
        space: str = "world",
    ) -> None:
        self.direction = None
        if direction is not None:
            d = _vec3(direction, "light direction")
            if np.linalg.norm(d) <= 0:
                raise InputError("light direction: must not be the zero vector")
            self.direction = normalize(d)
        c = _vec3(color, "light color")
        if np.any(c < 0):
            raise InputError(f"light color: must be non-negative, got {c.tolist()}")
        self.intensity = positive(intensity, "light intensity", allow_zero=True)
        self.color = c
        self.space = space
        if self.space not in ("world", "camera"):
            raise InputError(f"light space: expected 'world' or 'camera', got {self.space!r}")
        self.radiance = c * float(self.intensity)

    @classmethod
    def ambient(cls, color: Sequence[float] = (1.0, 1.0, 1.0), intensity: float = 0.1) -> Light:
        """Uniform light from every direction."""
        return cls(None, color, intensity)

    @property
    def is_ambient(self) -> bool:
        return self.direction is None

    def world_direction(self, camera: Camera) -> np.ndarray:
        """Unit direction towards the light in world space."""
        if self.direction is None:
            raise InputError("an ambient light has no direction")
        if self.space == "world":
            return np.asarray(self.direction)
        right, up, forward = camera.basis()
        x, y, z = self.direction
        return normalize(x * right + y * up - z * forward)


def default_lights() -> list[Light]:
    """Three-point lighting that follows the camera, plus a little ambient.

    A warm key from the upper front-right, a cool fill from the left, a rim light
    from behind and above, and ambient.
    """
    return [
        Light((0.75, 0.7, 0.6), (1.0, 0.96, 0.9), 1.0, space="camera"),  # key
        Light((-0.9, 0.15, 0.45), (0.85, 0.9, 1.0), 0.25, space="camera"),  # fill
        Light((0.2, 0.55, -1.0), (1.0, 1.0, 1.0), 0.3, space="camera"),  # rim / back
        Light.ambient((0.9, 0.95, 1.0), 0.06),
    ]
