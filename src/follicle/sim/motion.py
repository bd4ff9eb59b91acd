"""Built-in head animations for `follicle simulate`: turn, nod and shake.

Each motion is a rigid world-from-rest transform of the head about a pivot (the neck by
default), so the skin, its roots and the colliders that follow it move as one. Angles
follow keyframes joined by minimum-jerk segments (Flash & Hogan's model of human
reaching): position, velocity and acceleration are continuous, velocity and
acceleration are zero at every keyframe, so there is no jolt at the start, the head
stops at each extreme like a person's, and after one period it holds still and the
hair can settle. The face looks towards +z and +y is up (the built-in head).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ..errors import InputError
from ..validate import number, positive

__all__ = ["MOTIONS", "head_motion", "motion_angle", "motion_pivot"]

MOTIONS = ("none", "turn", "nod", "shake")  # [sim].motion's Literal lists the same

# (times as fractions of the period, angles as fractions of the amplitude)
_TURN = ((0.0, 0.4, 0.6, 1.0), (0.0, 1.0, 1.0, 0.0))  # out, hold, back
_SHAKE = ((0.0, 0.14, 0.36, 0.58, 0.8, 1.0), (0.0, 1.0, -1.0, 0.6, -0.25, 0.0))  # "no", fading
_KEYS = {"none": ((0.0, 1.0), (0.0, 0.0)), "turn": _TURN, "nod": _TURN, "shake": _SHAKE}
_AXES = {
    "none": (0.0, 1.0, 0.0),
    "turn": (0.0, 1.0, 0.0),
    "nod": (1.0, 0.0, 0.0),
    "shake": (0.0, 1.0, 0.0),
}


def _min_jerk(s: float) -> float:
    """0 → 1 over s in [0, 1] with zero velocity and acceleration at both ends."""
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


def motion_angle(kind: str, t: float, amplitude: float = 40.0, period: float = 2.0) -> float:
    """The head's angle (degrees) at time ``t`` (s): yaw for turn/shake, pitch for nod.

    turn: to +amplitude (towards the head's left, +y rotation) and back; nod: chin down by
    amplitude and back up; shake: a "no" of swings ±amplitude that fade out. Each takes
    ``period`` seconds, then holds at 0. A negative amplitude moves the other way.
    """
    if kind not in _KEYS:
        raise InputError(f"motion: unknown kind {kind!r}; use one of {', '.join(MOTIONS)}")
    t = number(t, "time", lo=0.0, unit="s")
    period = positive(period, "motion period", unit="s")
    amplitude = number(amplitude, "motion amplitude")
    times, angles = _KEYS[kind]
    u = t / period
    if u >= 1.0:
        return amplitude * angles[-1]
    k = int(np.searchsorted(times, u, side="right")) - 1
    s = (u - times[k]) / (times[k + 1] - times[k])
    return amplitude * (angles[k] + (angles[k + 1] - angles[k]) * _min_jerk(s))


def head_motion(
    kind: str,
    t: float,
    amplitude: float = 40.0,
    period: float = 2.0,
    pivot: ArrayLike = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """World-from-rest rigid transform (4, 4) float64 of the head at time ``t`` (s).

    Rotates by :func:`motion_angle` about ``pivot`` (turn and shake about +y, nod
    about +x); the identity at t = 0 and from t = period on.
    """
    angle = math.radians(motion_angle(kind, t, amplitude, period))
    p = np.asarray(pivot, dtype=np.float64) if not isinstance(pivot, str) else np.empty(0)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise InputError(f"motion pivot: expected 3 finite numbers (x, y, z), got {pivot!r}")
    x, y, z = _AXES[kind]
    c, s = math.cos(angle), math.sin(angle)
    # Rodrigues' formula for a unit axis
    rot = np.array(
        [
            [c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s],
            [y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s],
            [z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)],
        ]
    )
    out = np.eye(4)
    out[:3, :3] = rot
    out[:3, 3] = p - rot @ p
    return out


def motion_pivot(mesh: object, pivot: object = None) -> np.ndarray:
    """The pivot (3,) the head turns about: ``pivot`` ([sim].motion_pivot) when given,
    else the bottom centre of the mesh's rest bounds (the neck).

    A given pivot must lie within the mesh's own size of its rest bounds: a head that
    turns about a point far away sweeps through the hair at a speed no step resolves
    (a pivot 1 m off a 0.3 m head moves the skin 3× faster than the hair is long)."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in mesh.bounds("rest"))  # type: ignore[attr-defined]
    if pivot is None:
        return np.array([0.5 * (lo[0] + hi[0]), lo[1], 0.5 * (lo[2] + hi[2])])
    at = np.asarray(pivot, dtype=np.float64)
    size = float(np.linalg.norm(hi - lo))
    away = float(np.linalg.norm(np.maximum(np.maximum(lo - at, at - hi), 0.0)))
    if not away <= size:
        shown = ", ".join(f"{v:g}" for v in at)
        raise InputError(
            f"[sim].motion_pivot [{shown}] lies {away:.3g} m from the mesh; the head turns"
            f" about a point in or near it (the neck): within its size, {size:.3g} m, of"
            " its bounds"
        )
    return at
