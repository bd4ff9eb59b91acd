"""Skin collision of grown hairs: ``[groom].skin_collision`` (Houdini's Hair Generate
calls it the same).

Interpolated hairs follow their guides' shapes turned into their own root frames, so
between guides that clear the skin a hair can still pass through a thin or concave
part of it (the bust's ears, the shoulders under long hair from the front hairline).
After shaping, every hair with a vertex (not its root) inside the skin or nearer to it
than the clearance is rebuilt from its root by follow-the-leader (Müller et al. 2012,
as :func:`follicle.groom.brushes.follow` rebuilds brushed guides): each vertex, in
order from the root, is put back at its original segment's length from the one
before, pushed along the skin SDF's outward normal while it is nearer than the
clearance and put back at that length again, a few times. Lengths stay exact; a
vertex pushed out does not leave the next one pointing into the skin, since that one
is pushed in its turn. Hairs clear of the skin keep their bytes.
"""

from __future__ import annotations

import numpy as np

from ..mesh.sdf import SDF
from .brushes import follow, segment_lengths

__all__ = ["keep_off_skin"]

# push-outs of a vertex before giving up: more than a brush's, as a hair caught in a
# crease (between an ear and the head) climbs out of it over several
_TRIES = 16


def keep_off_skin(
    local: np.ndarray,
    length: np.ndarray,
    rows: np.ndarray,
    frame: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    skin: SDF,
    clearance: float,
) -> None:
    """Hairs ``local`` (m, n, 3), root-local, ``length`` (m,) vertices used each, moved in
    place so that no vertex but the root is within ``clearance`` of ``skin`` (as far as
    a few push-outs per vertex get it), every segment's length kept.

    Hair h sits at row ``rows[h]`` of ``frame`` = (origin, tangent, binormal, normal),
    each (hairs, 3) float64 and orthonormal, the skin frames it is placed on; ``skin`` is
    the SDF of that same pose.
    """
    origin, tangent, binormal, normal = frame
    m, n = local.shape[:2]
    if m == 0 or n < 2:
        return
    axes = np.stack([tangent, binormal, normal], axis=1)[rows]  # (m, 3, 3): rows are axes
    world = origin[rows][:, None] + np.einsum("hik,hkj->hij", local, axes)
    dist = skin.distance(world.reshape(-1, 3)).reshape(m, n)
    used = np.arange(1, n)[None] < length[:, None]
    which = np.flatnonzero(((dist[:, 1:] < clearance) & used).any(axis=1))
    if len(which) == 0:
        return
    hairs = np.ascontiguousarray(world[which])
    follow(hairs, segment_lengths(hairs), skin, clearance, tries=_TRIES)
    local[which] = np.einsum("hij,hkj->hik", hairs - origin[rows[which]][:, None], axes[which])
