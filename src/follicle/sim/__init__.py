"""Guide-strand dynamics (001 §3, 002 §5.1): Model (static), State (per step), Solver,
and the Simulator facade."""

from .simulator import Simulator

__all__ = ["Simulator"]
