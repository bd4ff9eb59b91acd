"""Hair cards: textured strips that stand for many hairs, the levels of detail game
engines draw at a distance (:func:`cards`).

Hairs are clustered into cards (:mod:`.clusters`), each card a strip along its
cluster's centre curve (:mod:`.strips`), the cards' rectangles packed into an atlas
with a region per level (:mod:`.atlas`), every card's hairs drawn into its rectangle by
the CPU strand rasterizer (:mod:`.bake`), and the levels written as glTF binary
(:mod:`.gltf`).
"""

from __future__ import annotations

import sys
import types
from pathlib import Path

from ..curves import HairCurves
from .make import HairCards, card_path, make_cards, write_cards
from .settings import CardParams

__all__ = ["CardParams", "HairCards", "card_path", "cards", "make_cards", "write_cards"]


def cards(
    curves: HairCurves,
    mesh: object | None = None,
    out: str | Path | None = None,
    params: CardParams | None = None,
    **settings: object,
) -> HairCards:
    """Hair cards of ``curves`` for each level of detail, with their atlas; written to
    ``out`` (.glb) when given.

    ``mesh`` is the skin the hair grew on (its normals lay the cards flat on it);
    ``settings`` change keys of ``params`` (:class:`CardParams`: ``lods``, ``counts``,
    ``atlas``, ``padding``, ``segments``, ``reserve``, ``alpha_cutoff``, ``seed``)."""
    if out is not None:  # before any work
        card_path(out)
    params = params if params is not None else CardParams()
    if settings:
        params = params.replace("cards", **settings)
    made = make_cards(curves, mesh, params)
    if out is not None:
        write_cards(made, out)
    return made


class _CallableModule(types.ModuleType):
    """This package, callable as :func:`cards`: importing ``follicle.cards`` makes the
    package attribute ``follicle.cards`` this module (the import system sets it), and
    ``follicle.cards(...)`` must still make cards."""

    def __call__(self, *args: object, **kwargs: object) -> HairCards:
        return cards(*args, **kwargs)  # type: ignore[arg-type]


sys.modules[__name__].__class__ = _CallableModule
