"""The texture atlas: a region of rows reserved for each level of detail, as Unreal's card
generator reserves a share of the atlas for the coarser levels ("ReserveTextureSpaceLOD"),
and each region's cards packed into it on shelves (next-fit decreasing height) at the
largest texel density that fits, with ``padding`` empty texels around every card, so
that mip-mapping does not blend one card's hairs into its neighbour's.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["MIN_TEXELS", "lod_bands", "pack"]

MIN_TEXELS = 2  # a card's least width and length in texels


def lod_bands(size: int, lods: int, reserve: float) -> list[tuple[int, int]]:
    """Rows [y0, y1) of each level's region of a ``size``-row atlas: each level takes
    1 − ``reserve`` of the rows left and leaves the rest to the coarser ones; the last
    takes all that is left."""
    bands = []
    top = 0
    for lod in range(lods):
        rows = size - top if lod == lods - 1 else int(round((size - top) * (1.0 - reserve)))
        bands.append((top, top + rows))
        top += rows
    return bands


def _shelves(w: np.ndarray, h: np.ndarray, width: int, padding: int) -> tuple:
    """Place cells of w × h texels (each grown by ``padding`` a side) on shelves across
    ``width`` texels, tallest first; returns their x, y (of the texels, inside the
    padding) and the rows used."""
    order = np.lexsort((np.arange(len(h)), -h))
    x = np.empty(len(w), np.int64)
    y = np.empty(len(w), np.int64)
    cx = shelf_y = shelf_h = 0
    for i in order:
        cw, ch = int(w[i]) + 2 * padding, int(h[i]) + 2 * padding
        if cx + cw > width and cx > 0:
            shelf_y += shelf_h
            cx = shelf_h = 0
        if cw > width:
            return x, y, np.iinfo(np.int64).max
        x[i], y[i] = cx + padding, shelf_y + padding
        cx += cw
        shelf_h = max(shelf_h, ch)
    return x, y, shelf_y + shelf_h


def _cells(
    width_m: np.ndarray, length_m: np.ndarray, density: float
) -> tuple[np.ndarray, np.ndarray]:
    """Cards' texel sizes at ``density`` texels a metre, at least :data:`MIN_TEXELS`."""
    w = np.maximum(np.ceil(width_m * density), MIN_TEXELS).astype(np.int64)
    h = np.maximum(np.ceil(length_m * density), MIN_TEXELS).astype(np.int64)
    return w, h


def pack(
    width_m: np.ndarray,
    length_m: np.ndarray,
    size: int,
    band: tuple[int, int],
    padding: int,
    lod: int,
) -> np.ndarray:
    """Rectangles (K, 4: x, y, w, h texels) in rows ``band`` of a ``size``² atlas for
    cards of ``width_m`` × ``length_m`` metres, all at one texel density, the largest
    (to 1 %) at which the shelves fit; an InputError naming ``atlas`` when they do not
    fit even at :data:`MIN_TEXELS` a side."""
    rows = band[1] - band[0]
    area = float(np.sum(width_m * length_m))
    hi = np.sqrt(size * rows / max(area, 1e-30))  # every texel used: no denser fits
    w, h = _cells(width_m, length_m, 0.0)
    x, y, used = _shelves(w, h, size, padding)
    if used > rows:
        raise InputError(
            f"atlas (--atlas) {size}: the {len(w):,} cards of LOD {lod} do not fit its "
            f"{size}×{rows} region even at {MIN_TEXELS}×{MIN_TEXELS} texels with {padding} "
            f"texels of padding; use a larger atlas (--atlas {2 * size}) or fewer cards "
            "(--counts)"
        )
    lo = 0.0
    while hi - lo > 0.01 * hi:
        mid = 0.5 * (lo + hi)
        w, h = _cells(width_m, length_m, mid)
        if _shelves(w, h, size, padding)[2] <= rows:
            lo = mid
        else:
            hi = mid
    w, h = _cells(width_m, length_m, lo)
    x, y, _ = _shelves(w, h, size, padding)
    return np.stack([x, y + band[0], w, h], axis=1)
