"""A skin animation read from a file: the skin's vertices over time, to drive dynamics.

`follicle simulate --skin-animation anim.usd|anim.abc` (``[sim].skin_animation``) pins
the guide roots to an animated skin: a USD Mesh whose ``points`` (or the transforms
above it) have time samples, or an Alembic PolyMesh (or SubD cage) with samples of
``P`` (or of the Xforms above it), as a skinned character's deformation is baked by
Blender, Houdini or Maya. The file's first mesh must be the scene's skin itself: the
same points and polygons (the rest mesh the groom was grown on, typically the same
file or its first frame), so each root follows its triangle through the binding it was
grown with (Šik 2012 §2.2.1) and the hair can be rendered on the deformed skin.

The file is read in the guarded child process of its format (:mod:`follicle.io.usd_guard`,
:mod:`follicle.io.alembic_guard`); its polygons are laid out as the skin's reader lays
them out (:func:`follicle.io.polymesh.polygon_layout`: fanned, seams split), so the
animation's vertices are the SkinMesh's, sample by sample. Between samples the vertices
are interpolated linearly; before the first and after the last they hold.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..arrays import frozen
from ..errors import FileAccessError, FormatError, InputError
from ..inputs import input_file, is_url
from ..mesh.skin import MAX_COORDINATE, SkinMesh
from ..units import Units, units_for
from ..validate import file_path, number
from .polymesh import polygon_layout

__all__ = ["SkinAnimation", "load_skin_animation", "ANIMATION_EXTENSIONS"]

ANIMATION_EXTENSIONS = (".usd", ".usda", ".usdc", ".usdz", ".abc")
SIZE_RATIO = 2.0  # the first sample's size may differ from the rest skin's by this factor


@dataclass(frozen=True, eq=False)
class SkinAnimation:
    """The skin's ``vertices`` (K, V, 3) float64, metres, in the SkinMesh's vertex order,
    at ``times`` (K,) seconds from the first sample (0, increasing); ``source`` names
    the file."""

    times: np.ndarray
    vertices: np.ndarray
    source: str

    @property
    def duration(self) -> float:
        """Seconds from the first sample to the last."""
        return float(self.times[-1])

    def at(self, time: float) -> np.ndarray:
        """The skin's vertices (V, 3) at ``time`` seconds after the first sample: linear
        between samples, held before the first and after the last."""
        t = number(time, "time", unit="s")
        k = int(np.searchsorted(self.times, t, side="right"))
        if k <= 0:
            return self.vertices[0].copy()
        if k >= len(self.times):
            return self.vertices[-1].copy()
        t0, t1 = self.times[k - 1], self.times[k]
        f = (t - t0) / (t1 - t0)
        return (1.0 - f) * self.vertices[k - 1] + f * self.vertices[k]


def _canonical(faces: np.ndarray) -> np.ndarray:
    """Each triangle's corners rotated to start at its lowest vertex (the same triangle,
    wound the same way, whichever corner a writer put first)."""
    faces = np.asarray(faces, dtype=np.int64)
    if faces.ndim != 2 or faces.shape[1] != 3:
        return faces
    shift = np.argmin(faces, axis=1)[:, None]
    return np.take_along_axis(faces, (np.arange(3)[None, :] + shift) % 3, axis=1)


def _read(path: Path) -> dict:
    """The guarded reader's part for the file's first mesh, with its samples."""
    if path.suffix.lower() == ".abc":
        from .alembic_guard import check_archive, read_mesh

        check_archive(path)
        return read_mesh(path, animated=True)
    from .usd_guard import check_container, read_meshes

    check_container(path)
    (part,) = read_meshes(path, animated=True)
    return part


def load_skin_animation(
    path: str | os.PathLike[str], skin: SkinMesh, units: Units = "m"
) -> SkinAnimation:
    """The animation of ``skin`` in the USD or Alembic file at ``path`` (see the module).

    ``units`` are an Alembic file's (they carry none; USD converts its own
    metersPerUnit). FormatError naming the file when it cannot be read, holds no mesh or
    no more than one sample, or its points are not finite; InputError naming it when its
    mesh is not ``skin`` (other points or polygons) or its first sample is more than
    :data:`SIZE_RATIO` times larger or smaller than the skin (other units)."""
    path = file_path(path, "load_skin_animation path")
    p = Path(os.fspath(path))
    if p.suffix.lower() not in ANIMATION_EXTENSIONS:
        raise FormatError(
            f"skin animation '{p}' has extension '{p.suffix}'; give a USD"
            f" ({', '.join(ANIMATION_EXTENSIONS[:4])}) or Alembic (.abc) file with time samples"
        )
    if not is_url(path) and not os.path.lexists(p):
        raise FileAccessError(f"skin animation '{p}' does not exist; check the path")
    p = input_file(path, "skin animation (USD or Alembic)")
    mpu = units_for(p, units) if p.suffix.lower() == ".abc" else 1.0
    part = _read(p)
    times, frames = part["times"], part["frames"]
    if not np.isfinite(frames).all():
        k = int(np.argmin(np.isfinite(frames).reshape(len(frames), -1).all(axis=1)))
        raise FormatError(f"{part['where']}: its points at {times[k]:g} s are not finite")
    if not (np.isfinite(times).all() and (np.diff(times) > 0).all()):
        raise FormatError(f"{part['where']}: its sample times do not increase")
    faces, vertex_source, _ = polygon_layout(part, frames.shape[1])
    rest = skin.rest_vertices
    if len(vertex_source) != len(rest) or not np.array_equal(
        _canonical(faces), _canonical(skin.faces)
    ):
        raise InputError(
            f"{p}: its mesh {part['where'].split(': ', 1)[-1]} has {len(vertex_source):,}"
            f" vertices in {len(faces):,} triangles as follicle lays it out; the scene's"
            f" skin '{skin.name}' has {len(rest):,} in {len(skin.faces):,}: a skin"
            " animation must move the skin mesh itself (export the mesh [mesh].path names,"
            " with its points and polygons as they are)"
        )
    vertices = frames[:, vertex_source] * mpu
    if np.abs(vertices).max() > MAX_COORDINATE:
        raise InputError(f"{p}: its points reach beyond ±{MAX_COORDINATE:g} m")
    size = float(np.linalg.norm(np.ptp(rest, axis=0)))
    first = float(np.linalg.norm(np.ptp(vertices[0], axis=0)))
    if not size / SIZE_RATIO <= first <= size * SIZE_RATIO:
        raise InputError(
            f"{p}: its mesh is {first / size:.3g}× the size of the skin '{skin.name}'"
            f" ({first:.3g} m across against {size:.3g} m); give the file's units"
            " ([mesh].units applies to an Alembic animation too) or export it in the skin's"
        )
    return SkinAnimation(frozen(times - times[0]), frozen(vertices), str(p))
