"""Settling: guides simulated under gravity, on a still skin, until they rest; the shape
they come to is a groom's new rest shape (``[groom].settle``, ``follicle settle``).

Guides are grown (or groomed) as they should look, but a grown strand does not know
the body: long hair leaves the head in a stiff cone and ends in the air. Settling runs
the scene's own dynamics ([sim]: gravity, damping, the style hold ``shape_hold``, the
skin's SDF and the ``[[sim.colliders]]``) for a fixed time with the head still, so long
hair falls onto the shoulders (the colliders, or a skin mesh that has them) while short,
styled hair keeps the style the hold gives it (Le Muzic 2012 §5.1.2; Almeida 2014 §3.1).
The pull towards the pose as grown (``[sim].shape_global``) is off while settling: that
pose is what settling replaces, and the settled one is what it pulls towards afterwards.
The settled positions become the guides' rest shapes, bound to the same roots
(:meth:`~follicle.groom.guides.Guides.posed`), so growing, rendering, exporting and
simulating all start from them.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import ResourceError
from ..groom.guides import Guides
from ..progress import Progress
from .settings import SimParams
from .simulator import MAX_SUBSTEPS_PER_CALL, Simulator

__all__ = ["MAX_SETTLE_SUBSTEPS", "Settled", "settle"]

# the most substeps one settle runs: 60 s (the most [groom].settle allows) at 1/120 s
# is 7,200; this leaves room for finer substeps and refuses a settle that would run
# for hours at a tiny [sim].substep
MAX_SETTLE_SUBSTEPS = 100_000
CHUNK = 0.1  # s simulated between two progress reports


@dataclass(frozen=True)
class Settled:
    """The guides after ``seconds`` of settling (their rest shape now), and the
    simulator's :attr:`~follicle.sim.simulator.Simulator.stats` at the end: max and mean
    stretch, max penetration (m) into a collider or the skin, kinetic energy."""

    guides: Guides
    seconds: float
    stats: dict[str, float]


def settle(
    guides: Guides, params: SimParams, seconds: float, progress: Progress | None = None
) -> Settled:
    """``guides`` simulated with ``params`` for ``seconds`` (rounded to whole substeps of
    ``params.substep``) with the skin still in its rest pose, from rest, and no pull
    towards the pose as grown (``shape_global`` 0); the positions they reach become the
    rest shapes of new guides on the same roots, mesh and groups. The head motion and
    skin animation of ``params`` play no part. Deterministic: the
    same guides and params give the same bytes. ``progress(done, total)`` hears each
    0.1 s simulated."""
    h = params.substep
    substeps = round(seconds / h)
    if substeps > MAX_SETTLE_SUBSTEPS:
        raise ResourceError(
            f"[groom].settle: {seconds:g} s needs {substeps:,} substeps of [sim].substep ="
            f" {h:g} s; a settle runs at most {MAX_SETTLE_SUBSTEPS:,}: lower [groom].settle"
            " or raise [sim].substep"
        )
    sim = Simulator(guides, params=params.replace(shape_global=0.0))
    chunk = min(max(round(CHUNK / h), 1), MAX_SUBSTEPS_PER_CALL)
    total = -(-substeps // chunk)
    for done in range(1, total + 1):
        sim.step(min(chunk, substeps - (done - 1) * chunk) * h)
        if progress is not None:
            progress(done, total)
    return Settled(guides.posed(sim.positions), substeps * h, sim.stats)
