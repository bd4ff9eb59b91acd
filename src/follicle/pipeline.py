"""Scene-level stages: what `follicle grow` and `follicle render` run, callable from Python."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .curves import HairCurves
from .groom.generator import Groom, load_texture, resolve_density
from .groom.groups import InterpolationGroups
from .groom.guides import load_guides
from .mesh.load import load_mesh
from .mesh.skin import SkinMesh
from .render import Camera, render
from .scene import RenderParams, Scene

__all__ = ["groom_scene", "grow", "render_scene"]


def groom_scene(scene: Scene) -> Groom:
    """The mesh, guides and groom parameters of ``scene``, ready to grow."""
    mesh = load_mesh(scene.resolve(scene.mesh.path))
    spec = scene.groom.groups
    groups = InterpolationGroups(
        load_texture(spec, scene.resolve) if spec else None, scene.groom.group_vertices
    )
    guides = load_guides(scene.resolve(scene.guides.path), mesh, groups=groups)
    density = resolve_density(mesh, scene.groom.density, scene.resolve)
    displacement = scene.mesh.displacement
    return Groom(
        mesh, guides, scene.groom, density=density,
        displacement=load_texture(displacement, scene.resolve) if displacement else None,
        displacement_scale=scene.mesh.displacement_scale, resolve_path=scene.resolve,
    )


def grow(
    scene: Scene | None = None, progress: Callable[[int, int], None] | None = None
) -> tuple[SkinMesh, HairCurves]:
    """Grow the hair of ``scene`` (the default scene when None): (mesh, curves)."""
    groom = groom_scene(scene if scene is not None else Scene())
    return groom.mesh, groom.generate(progress=progress)


def render_scene(
    curves: HairCurves | None, mesh: SkinMesh | None, params: RenderParams, out: str | None = None
) -> np.ndarray:
    """Render hair and mesh with a scene's [render] settings; writes PNG when ``out``."""
    camera = None  # framed automatically on hair and mesh at params.fov
    if params.eye is not None and params.target is not None:
        camera = Camera(eye=params.eye, target=params.target, fov_y=params.fov)
    return render(
        curves,
        mesh=mesh,
        camera=camera,
        size=params.size,
        shading=params.shading,
        out=out,
        msaa=params.msaa,
        subdivisions=params.subdivisions,
        background=(params.background_top, params.background_bottom),
        fov=params.fov,
    )
