"""Guide-strand dynamics (Almeida 2014 §3, Le Muzic 2012 §5.1): Model (static), State (per
step), Solver,
and the Simulator facade."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .simulator import Simulator

__all__ = ["Simulator"]


def __getattr__(name: str) -> Any:
    """``Simulator`` on first use, so that importing ``follicle.sim.settings`` (the scene
    does) does not load the solver."""
    if name == "Simulator":
        from .simulator import Simulator

        return Simulator
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
