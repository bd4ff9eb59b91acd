"""Animation-cache writers (Alembic, USD): one signature and one front end for all.

:func:`cache_writer` makes each format's writer, so every one takes the same arguments
in the same order and a table of them (suffix → writer) can call any one. The front
end checks the output's name (the format's own check), looks up the target and checks
the animation (:func:`follicle.io.animation.animation`: the frames as they come, the
fps and first frame, the head motion or deforming skin) before the format writes it,
atomically, as it lays an animation out.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from .animation import Animation, animation
from .targets import Target, get_target

if TYPE_CHECKING:
    from ..curves import HairCurves
    from ..mesh.skin import SkinMesh
    from .sim_cache import SimCache

__all__ = ["CacheWriter", "FormatWriter", "cache_writer"]

# A cache writer: called as the writer cache_writer makes is (frames, path, fps, start,
# mesh, transforms, target, role, skin_vertices), it returns the path it wrote.
CacheWriter = Callable[..., Path]
# A format's own writing: (output, the checked animation, the skin mesh or None, the
# target) to the file, atomically.
FormatWriter = Callable[[Path, Animation, "SkinMesh | None", Target], None]

_SHARED_DOC = """
    ``fps`` defaults to 24, or a SimCache's own. A SimCache writes its guide strands,
    as guides (``role``: "hair" or "guides" says what the frames are; by default guides
    for a SimCache, hair otherwise); for hair, write ``groom.follow(cache.positions[f],
    pose=groom.mesh.posed(transform=cache.transforms[f]))`` for each frame f. ``mesh``
    (a SkinMesh) is written at rest as ``/Groom/Skin``; with ``transforms`` (F, 4, 4),
    one head transform per frame acting on column vectors as a SimCache keeps them (a
    SimCache's own by default), it is ``/Groom/Head/Skin`` under the Xform
    ``/Groom/Head`` sampled per frame, so the skin moves with the (world-space) hair. A
    SimCache of an animated skin (``skin_vertices``) writes ``/Groom/Skin`` with its
    points sampled per frame instead. The file is written atomically.
    """


def cache_writer(
    name: str,
    output: Callable[[str | os.PathLike[str]], Path],
    write: FormatWriter,
    in_units: bool,
    doc: str,
) -> CacheWriter:
    """The cache writer ``name`` of a format: ``output`` checks the path's suffix and
    gives the output, ``write`` writes the checked animation there; ``in_units``: the
    frames and head motion are scaled to the target's units (Alembic declares none), as
    :func:`follicle.io.animation.animation` takes it. ``doc`` says how the format lays
    the animation out; the arguments every writer shares are documented after it."""

    def save(
        frames: Iterable[HairCurves] | SimCache,
        path: str | os.PathLike[str],
        fps: float | None = None,
        start: int = 0,
        mesh: SkinMesh | None = None,
        transforms: object | None = None,
        target: Target | str = "generic",
        role: str | None = None,
        skin_vertices: object | None = None,
    ) -> Path:
        out = output(path)
        tool = get_target(target)
        anim = animation(frames, fps, start, mesh, transforms, tool, in_units, role, skin_vertices)
        write(out, anim, mesh, tool)
        return out

    save.__name__ = save.__qualname__ = name
    save.__module__ = write.__module__
    save.__doc__ = doc.rstrip() + "\n" + _SHARED_DOC
    return save
