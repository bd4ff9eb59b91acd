"""What the guarded reading server and the readers it runs share: the refusal a reader
raises and the limit on animation reads.

A reader module (:mod:`follicle.io.usd_stage`, :mod:`follicle.io.usd_mesh`,
:mod:`follicle.io.alembic_archive`) runs inside :mod:`follicle.io.guard_server`'s forked
children and imports this, not the server, so that the server names its readers
(by string, imported on first request) without the readers importing it back.
"""

from __future__ import annotations

__all__ = ["Refused", "MAX_ANIMATION_POINTS"]

# the most points (samples × points a sample) a skin animation read may hold: 480 MB as
# float64 (follicle.io.skin_animation)
MAX_ANIMATION_POINTS = 20_000_000


class Refused(Exception):
    """The file cannot be read as asked; the message, one line naming it, says why."""
