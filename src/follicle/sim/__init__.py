"""Guide-strand dynamics (Almeida 2014 §3, Le Muzic 2012 §5.1): Model (static), State (per
step), Solver,
and the Simulator facade."""

from .simulator import Simulator

__all__ = ["Simulator"]
