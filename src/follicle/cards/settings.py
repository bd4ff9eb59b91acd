"""The settings of a cards build, an immutable value (:class:`CardParams`)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from ..errors import ConfigError
from ..settings import StrictSection, measured_in

__all__ = ["DEFAULT_COUNTS", "CardParams", "default_counts"]

DEFAULT_COUNTS = (2000, 600, 150)  # cards of LOD 0, 1, 2; each further level a quarter


def default_counts(lods: int, hairs: int) -> tuple[int, ...]:
    """Cards per level for ``lods`` levels of ``hairs`` hairs: :data:`DEFAULT_COUNTS`,
    then a quarter more each further level, each at most a quarter of the hairs at the
    finest level and half as many again each coarser one (at least 1), so a small groom
    gets cards of a few hairs each rather than an error."""
    counts = list(DEFAULT_COUNTS[:lods])
    while len(counts) < lods:
        counts.append(max(counts[-1] // 4, 1))
    return tuple(min(c, max(hairs >> (2 + lod), 1)) for lod, c in enumerate(counts))


class CardParams(StrictSection):
    """How hair becomes cards: levels of detail and their card counts, the atlas's size
    and padding, the strips' segments, the hairs' least width in the atlas, the alpha
    test's cutoff, and the seed of the clustering.

    A hair is drawn into the atlas at least ``strand_texels`` wide at its root (and
    tapering as it does towards the tip), as Unreal's card generator draws strands at a
    width of its own unless told to take the groom's: a card's texel stands for a couple
    of millimetres, so hairs drawn at their own tenth of a millimetre would leave the
    coverage too thin for the alpha test to keep. The defaults — 0.4 texel, the alpha
    test at ½ (glTF's own default cutoff), 2 texels of padding, 35 % of the atlas left to
    the coarser levels — are those at which the finest level's silhouette, rendered by
    Blender's Cycles, best matches the strands' of the default 20,000-hair groom
    (intersection over union 0.937, 0.945 and 0.931 from the front, the side and the top,
    tests/test_blender_cards.py; 0.85–0.89 at 1 texel, a cutoff of 0.2, 4 texels and ½,
    where cards drew their tips and partings too full and LOD 0 had fewer texels). Less
    padding leaves the finest level more texels: it guards mip levels 0 and 1, the ones a
    level of detail is seen at before the next, coarser one takes over. A sparse groom
    (a handful of hairs a card) seen through mip-mapped textures takes a lower
    ``alpha_cutoff`` (docs: Hair cards)."""

    _section = "cards"

    lods: int = Field(3, ge=1, le=8, description="levels of detail")
    counts: tuple[Annotated[int, Field(ge=1, le=1_000_000)], ...] | None = Field(
        None,
        strict=False,
        description="cards per level (default 2000, 600, 150, ..., at most a quarter of the"
        " hairs at LOD 0, an eighth at LOD 1 ...)",
    )
    atlas: int = Field(
        2048,
        ge=64,
        le=16384,
        description="the atlas's side",
        json_schema_extra=measured_in("texels"),
    )
    padding: int = Field(
        2,
        ge=0,
        le=64,
        description="empty texels around each card",
        json_schema_extra=measured_in("texels"),
    )
    segments: int = Field(6, ge=1, le=64, description="quads along a card")
    reserve: float = Field(
        0.35, ge=0.0, le=0.75, description="share of the atlas left to the coarser levels"
    )
    strand_texels: float = Field(
        0.4,
        ge=0.0,
        le=16.0,
        description="least width of a hair's root drawn into the atlas, the rest"
        " tapering as the hair does (0: its own width)",
        json_schema_extra=measured_in("texels"),
    )
    alpha_cutoff: float = Field(
        0.5, ge=0.0, le=1.0, description="coverage below which a card texel is not drawn"
    )
    target: Literal["generic", "unreal"] = Field(
        "generic",
        description="the textures' layout: generic (the glTF material and maps) or unreal"
        " (also a PNG for each of the groom cards' texture slots beside the file)",
    )
    seed: int = Field(0, ge=0, le=2**31 - 1, description="seed of the clustering")

    @model_validator(mode="after")
    def _counts_per_level(self) -> CardParams:
        if self.counts is not None and len(self.counts) != self.lods:
            raise ConfigError(
                f"cards: counts (--counts) gives {len(self.counts)} levels for lods (--lods)"
                f" {self.lods}; give one count per level, e.g. --counts 2000,600,150"
            )
        return self

    def card_counts(self, hairs: int) -> tuple[int, ...]:
        """The cards of each level for ``hairs`` hairs: ``counts``, or
        :func:`default_counts`."""
        return self.counts if self.counts is not None else default_counts(self.lods, hairs)
