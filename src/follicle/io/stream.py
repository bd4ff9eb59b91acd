"""Chunk streams: every writer takes hair as an iterator of HairCurves chunks.

A whole groom is one chunk; ``Groom.chunks`` yields a groom of any size in pieces, so
a writer that handles one chunk at a time keeps memory bounded by a chunk.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

from ..curves import HairCurves
from ..errors import InputError
from .attributes import conventional

__all__ = ["Curves", "as_chunks"]

Curves = HairCurves | Iterable[HairCurves]


def as_chunks(curves: Curves) -> Iterator[HairCurves]:
    """Yield the chunks of ``curves`` (one HairCurves, or an iterable of them), checking
    each is a HairCurves, with colour, opacity and width in follicle's shapes
    (:func:`~follicle.io.attributes.conventional`); an empty stream raises InputError
    before anything is written."""
    if isinstance(curves, HairCurves):
        yield conventional(curves)
        return
    if isinstance(curves, (str, bytes)) or not isinstance(curves, Iterable):
        raise InputError(
            f"curves: expected HairCurves or an iterable of them, got {type(curves).__name__}"
        )
    empty = True
    for i, chunk in enumerate(curves):
        if not isinstance(chunk, HairCurves):
            raise InputError(f"curves: chunk {i} is a {type(chunk).__name__}, not HairCurves")
        empty = False
        yield conventional(chunk)
    if empty:
        raise InputError("curves: the chunk stream is empty; nothing to write")
