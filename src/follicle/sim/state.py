"""State: what changes every step (positions, velocities, time, the skin's roots)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["State"]


@dataclass
class State:
    """Strand positions and velocities (S, N, 3) float64, root first (float32 would leave
    a relative stretch of ~1e-6 on millimetre segments from rounding alone); simulated time (s);
    the roots (S, 3) and root frames (S, 3, 3) the strands were last pinned to; ``clear``
    (S, N) how far each vertex may still move before it can touch a collider (negative:
    unknown, look it up), carried from substep to substep so a vertex far from the skin
    is not looked up again every substep."""

    x: np.ndarray
    v: np.ndarray
    time: float
    roots: np.ndarray
    frames: np.ndarray
    clear: np.ndarray

    def copy(self) -> State:
        return State(
            self.x.copy(),
            self.v.copy(),
            self.time,
            self.roots.copy(),
            self.frames.copy(),
            self.clear.copy(),
        )
