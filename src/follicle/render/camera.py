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

from ..curves import HairCurves
from ..errors import InputError
from ..frames import normalize
from ..validate import number, positive

__all__ = [
    "Camera",
    "Light",
    "DEFAULT_FOV",
    "default_lights",
    "frame_camera",
    "hair_bounds",
    "scene_bounds",
]

DEFAULT_FOV = 30.0  # vertical field of view, degrees: every camera's and [render].fov's


def _vec3(value: object, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
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


@dataclass(eq=False)
class Camera:
    """A perspective camera at ``eye`` looking at ``target``.

    ``fov_y`` is the vertical field of view in degrees. ``near``/``far`` are the clip
    distances in metres; None lets the renderer fit them to the scene (and
    :meth:`projection_matrix` fall back to 1/100 and 100 × the eye-target distance).
    """

    eye: Sequence[float]
    target: Sequence[float]
    up: Sequence[float] = (0.0, 1.0, 0.0)
    fov_y: float = DEFAULT_FOV
    near: float | None = None
    far: float | None = None

    def __post_init__(self) -> None:
        self.eye = _vec3(self.eye, "camera eye")
        self.target = _vec3(self.target, "camera target")
        self.up = _vec3(self.up, "camera up")
        if np.linalg.norm(self.target - self.eye) <= 0.0:
            raise InputError("camera: eye and target are the same point; move the eye back")
        if np.linalg.norm(self.up) <= 0.0:
            raise InputError("camera up: must not be the zero vector")
        self.fov_y = _fov(self.fov_y, "camera fov_y")
        if self.near is not None:
            self.near = positive(self.near, "camera near", unit="m")
        if self.far is not None:
            self.far = number(self.far, "camera far", unit="m")
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
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
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


def frame_camera(
    lo: object,
    hi: object,
    direction: Sequence[float] = (0.35, 0.15, 1.0),
    fov_y: float = DEFAULT_FOV,
    aspect: float = 1.0,
    margin: float = 1.1,
    up: Sequence[float] = (0.0, 1.0, 0.0),
) -> Camera:
    """A camera looking at the centre of the box ``[lo, hi]`` that fits it to the view.

    ``direction`` points from the box centre towards the eye. The eye distance is the
    smallest at which all eight corners project inside the image shrunk by
    ``margin`` (1.1 leaves ~5 % of free border on each side of the tighter axis);
    near/far bracket the box.
    """
    lo, hi = _vec3(lo, "frame_camera lo"), _vec3(hi, "frame_camera hi")
    if np.any(hi < lo):
        raise InputError(f"frame_camera: hi {hi.tolist()} is below lo {lo.tolist()}")
    d = _vec3(direction, "frame_camera direction")
    if np.linalg.norm(d) <= 0:
        raise InputError("frame_camera direction: must not be the zero vector")
    margin = number(margin, "frame_camera margin", lo=1.0)
    aspect = positive(aspect, "frame_camera aspect")
    fov_y = _fov(fov_y, "frame_camera fov_y")
    centre = 0.5 * (lo + hi)
    # a point (or flat) box still needs some extent to frame
    pad = 1e-3 * max(1.0, float(np.abs(centre).max()))
    half = np.maximum(0.5 * (hi - lo), pad)
    back = normalize(d)  # centre -> eye
    forward = -back
    right = normalize(np.cross(forward, _perpendicular_up(forward, _vec3(up, "frame_camera up"))))
    cam_up = np.cross(right, forward)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    corners = signs * half
    x, y, z = corners @ right, corners @ cam_up, corners @ back
    ty = math.tan(math.radians(fov_y) / 2.0) / margin
    tx = ty * aspect
    # corner depth is D - z; it must satisfy |x| <= tx (D - z) and |y| <= ty (D - z)
    dist = float(np.max(z + np.maximum(np.abs(x) / tx, np.abs(y) / ty)))
    radius = float(np.linalg.norm(half))
    dist = max(dist, radius * 1.001)
    near = max(0.5 * (dist - radius), 1e-3 * dist)
    far = dist + 2.0 * radius
    return Camera(centre + back * dist, centre, up=tuple(up), fov_y=fov_y, near=near, far=far)


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


@dataclass(eq=False)
class Light:
    """A directional light, or an ambient one when ``direction`` is None.

    ``direction`` points **from the scene towards the light** (the usual L vector of
    shading), e.g. ``(0, 1, 0)`` lights from straight above. With ``space="camera"`` it
    is given in the camera frame (x right, y up, z towards the viewer), so the light
    follows the camera; with ``"world"`` it is fixed in the scene. ``color`` is linear
    RGB, scaled by ``intensity``.
    """

    direction: Sequence[float] | None
    color: Sequence[float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0
    space: str = "world"
    radiance: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.direction is not None:
            d = _vec3(self.direction, "light direction")
            if np.linalg.norm(d) <= 0:
                raise InputError("light direction: must not be the zero vector")
            self.direction = normalize(d)
        c = _vec3(self.color, "light color")
        if np.any(c < 0):
            raise InputError(f"light color: must be non-negative, got {c.tolist()}")
        self.intensity = positive(self.intensity, "light intensity", allow_zero=True)
        self.color = c
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
