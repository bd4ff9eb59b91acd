"""Geometry read from a scene file moved into world space: pure numpy, no C++ binding.

USD and Alembic both write 4×4 matrices that act on row vectors (``p' = p · M``, the
translation in the last row). :func:`to_world` applies one to points and to the
attributes that move with them: widths scale by the cube root of the volume change
(the mean of the three axis scales for a uniform scale, which is what it is on hair),
normals by the inverse transpose. It runs in the guarded reading child
(:mod:`follicle.io.guard_server`), so it imports only numpy.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SpaceError", "to_world"]


class SpaceError(ValueError):
    """A transform that cannot move the geometry; the message names it and the fix."""


def to_world(
    points: np.ndarray, point_data: dict[str, np.ndarray], m: np.ndarray, where: str, fix: str
) -> np.ndarray:
    """``points`` (returned, float32, or float64 if given float64) and ``point_data``'s
    ``width`` and ``normal`` (replaced in the dict) moved by the row-vector matrix ``m``;
    SpaceError naming ``where`` (ending in ``fix``) when normals meet a singular one."""
    if np.allclose(m, np.eye(4), rtol=0, atol=1e-12):
        return points
    linear = m[:3, :3]
    det = float(np.linalg.det(linear))
    if "width" in point_data:
        point_data["width"] = (point_data["width"] * abs(det) ** (1 / 3)).astype(np.float32)
    if "normal" in point_data:
        if not (np.isfinite(det) and abs(det) > 1e-30):
            raise SpaceError(
                f"{where}: its transform is singular (a scale of 0), so its"
                f" normals cannot be transformed; {fix}"
            )
        n = point_data["normal"].astype(np.float64) @ np.linalg.inv(linear).T
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        point_data["normal"] = n.astype(np.float32)
    dtype = np.float64 if points.dtype == np.float64 else np.float32
    return (points.astype(np.float64) @ linear + m[3, :3]).astype(dtype)
