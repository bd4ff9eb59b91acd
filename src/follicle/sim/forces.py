"""External accelerations on strand vertices (Le Muzic 2012 §5.1.2): gravity and wind.

Wind follows Le Muzic 2012 eq. 5.2: F = |w × t| / |w| · w, strongest across a segment and zero
along it (wind does not stretch a strand it blows along), with w made turbulent by
``noise3`` scrolled through space over time. Vertex masses are 1, so forces are
accelerations. Drag, −b·v (eq. 5.3), depends on the velocity being solved for, so the
solver takes it implicitly (see :mod:`.solver`) rather than here.
"""

from __future__ import annotations

import math

from ..kernels import kernel
from ..noise import noise3

__all__ = ["acceleration"]


@kernel(inline="always")
def acceleration(px, py, pz, tx, ty, tz, gravity, wind, turbulence, frequency, scroll):
    """Acceleration at a vertex at p with unit tangent t.

    ``gravity``, ``wind`` (3,) m/s²; ``turbulence`` ≥ 0 scales the noise part of the
    wind relative to |wind|; ``frequency`` 1/m; ``scroll`` (3,) the noise offset now
    (wind drift × time, m).
    """
    ax, ay, az = gravity[0], gravity[1], gravity[2]
    strength = math.sqrt(wind[0] * wind[0] + wind[1] * wind[1] + wind[2] * wind[2])
    if strength > 0.0:
        wx, wy, wz = wind[0], wind[1], wind[2]
        if turbulence > 0.0:
            nx, ny, nz = noise3(
                frequency * px + scroll[0], frequency * py + scroll[1], frequency * pz + scroll[2]
            )
            k = turbulence * strength
            wx += k * nx
            wy += k * ny
            wz += k * nz
        w2 = math.sqrt(wx * wx + wy * wy + wz * wz)
        if w2 > 0.0:
            cx = wy * tz - wz * ty
            cy = wz * tx - wx * tz
            cz = wx * ty - wy * tx
            f = math.sqrt(cx * cx + cy * cy + cz * cz) / w2  # |w × t| / |w|
            ax += f * wx
            ay += f * wy
            az += f * wz
    return ax, ay, az
