"""Wind gusts on demand: a burst of wind that rises and falls smoothly over a while of
simulated time, added to the scene's [sim] wind without changing the scene."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..sim.simulator import Simulator

if TYPE_CHECKING:
    from ..curves import HairCurves
    from ..groom.guides import Guides
    from ..sim.settings import SimParams

__all__ = ["Gust", "GustySimulator"]


class Gust(NamedTuple):
    """``vector`` (m/s², like [sim].wind) at its peak, mid-way through ``duration``
    seconds of simulated time from ``start``: vector · sin²(π s), s the fraction gone,
    so the burst starts and ends with no jolt."""

    start: float
    duration: float
    vector: np.ndarray

    def at(self, time: float) -> np.ndarray:
        """The gust's wind at simulated ``time`` (zero outside its span)."""
        s = (time - self.start) / self.duration
        return self.vector * (math.sin(math.pi * s) ** 2 if 0.0 < s < 1.0 else 0.0)

    def over(self, time: float) -> bool:
        return time >= self.start + self.duration


class GustySimulator(Simulator):
    """A :class:`Simulator` whose wind is the [sim] wind plus ``gusts`` (a list the
    the viewer owns and adds to)."""

    def __init__(
        self, guides: Guides | HairCurves, params: SimParams | None, gusts: list[Gust]
    ) -> None:
        super().__init__(guides, params=params)
        self.gusts = gusts

    def wind(self, time: float) -> np.ndarray:
        return sum((g.at(time) for g in self.gusts), super().wind(time))
