"""Shader programs (GLSL stages assembled from the files in ``shaders/``, compiled once
per context) and the little GL state the passes set.

Every stage is ``#version 330 core``, its ``#define`` lines, then the named files in
order: the hair shading models are plain functions (``hair_shade``) in files of their
own, compiled into the hair geometry shader (hair thinner than a pixel, drawn as lines
and shaded per Catmull-Rom step), the line vertex shader (the same lines at one step a
segment, without a geometry shader) or the hair fragment shader (ribbons, shaded per
fragment).
"""

from __future__ import annotations

from importlib import resources
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import moderngl

__all__ = ["MODEL_FILES", "get_program", "set_uniforms", "use_framebuffer"]

MODEL_FILES = {
    "kajiya-kay": "shade_kajiya_kay.glsl",
    "scheuermann": "shade_scheuermann.glsl",
    "marschner": "shade_marschner.glsl",
    "physical": "shade_physical.glsl",
}
_GS_OUT = ("VARYING out", "VARYING_NAME gs_out")
_FS_IN = ("VARYING in", "VARYING_NAME fs_in")

_cache: dict[tuple[int, str], moderngl.Program] = {}


def _read(name: str) -> str:
    """The shader file ``name``, a data file of this package (``__package__``)."""
    return resources.files(__package__).joinpath("shaders").joinpath(name).read_text("utf-8")


def _stage(defines: tuple[str, ...], files: list[str]) -> str:
    head = "#version 330 core\n" + "".join(f"#define {d}\n" for d in defines)
    return head + "\n".join(_read(f) for f in files)


def _hair_shading(model: str) -> list[str]:
    return ["lights.glsl", "hair_common.glsl", MODEL_FILES[model], "hair_radiance.glsl"]


def _sources(name: str) -> tuple[str, str | None, str]:
    """(vertex, geometry or None, fragment) source of program ``name``."""
    kind, _, model = name.partition(":")
    thin = kind.endswith("_thin")  # hair thinner than a pixel: lines, not ribbons
    kind = kind.removesuffix("_thin")
    lines = ("LINES",) if thin else ()
    hair_vs = _stage((), ["hair_vs.glsl"])
    step = ["hair_varyings.glsl", "hair_step.glsl"]  # a point facing the viewer
    shaded_fs = _stage(("SHADED", *_FS_IN), ["hair_varyings.glsl", "hair_fs.glsl"])
    if kind == "hair_line":  # thin hair at one step a segment, shaded per vertex
        return (
            _stage(
                ("SHADE", "LINES", *_GS_OUT), [*_hair_shading(model), *step, "hair_line_vs.glsl"]
            ),
            None,
            shaded_fs,
        )
    if kind == "hair":  # the colour pass of model `model`
        shading = _hair_shading(model)
        if thin:  # shaded per Catmull-Rom step, in the geometry shader
            return (
                hair_vs,
                _stage(("SHADE", *lines, *_GS_OUT), [*shading, *step, "hair_gs.glsl"]),
                shaded_fs,
            )
        return (
            hair_vs,
            _stage(_GS_OUT, [*step, "hair_gs.glsl"]),
            _stage(_FS_IN, [*shading, "hair_varyings.glsl", "hair_fs.glsl"]),
        )
    if kind in ("hair_depth", "hair_opacity"):  # the deep opacity map passes
        depth = ("DEPTH",) if kind == "hair_depth" else ()
        return (
            hair_vs,
            _stage((*lines, *_GS_OUT), [*step, "hair_gs.glsl"]),
            _stage((*depth, *_FS_IN), ["hair_varyings.glsl", "hair_shadow_fs.glsl"]),
        )
    fullscreen = _stage((), ["background_vs.glsl"])
    return {
        "mesh": (_stage((), ["mesh_vs.glsl"]), None, _stage((), ["lights.glsl", "mesh_fs.glsl"])),
        "mesh_depth": (_stage((), ["mesh_vs.glsl"]), None, _stage((), ["depth_fs.glsl"])),
        "background": (fullscreen, None, _stage((), ["background_fs.glsl"])),
        "composite": (fullscreen, None, _stage((), ["composite_fs.glsl"])),
        "composite_msaa": (fullscreen, None, _stage(("MSAA",), ["composite_fs.glsl"])),
    }[name]


def get_program(ctx: moderngl.Context, name: str) -> moderngl.Program:
    """Program ``name`` for ``ctx``: ``hair:<model>``, ``hair_depth``, ``hair_opacity``
    (ribbons; each also as ``..._thin``: lines for hair thinner than a pixel),
    ``hair_line:<model>`` (thin hair at one step a segment, no geometry shader), ``mesh``,
    ``mesh_depth``, ``background``, ``composite`` or ``composite_msaa``."""
    key = (id(ctx), name)
    prog = _cache.get(key)
    if prog is None:
        vs, gs, fs = _sources(name)
        prog = ctx.program(vertex_shader=vs, geometry_shader=gs, fragment_shader=fs)
        _cache[key] = prog
    return prog


def set_uniforms(prog: moderngl.Program, values: dict[str, object]) -> None:
    """Set the uniforms ``prog`` has; the compiler drops the unused ones, so others are
    skipped. Numbers and tuples go by ``value``; bytes (arrays) by ``write``."""
    import moderngl  # loaded already: ``prog`` exists

    for name, value in values.items():
        member = prog.get(name, None)
        if not isinstance(member, moderngl.Uniform):  # dropped, or not a uniform
            continue
        if isinstance(value, bytes):
            member.write(value)
        else:
            member.value = value


def use_framebuffer(fbo: moderngl.Framebuffer) -> None:
    """Bind ``fbo`` with its whole area as viewport. moderngl keeps a viewport per
    framebuffer, and ``ctx.viewport = ...`` (here or in a caller sharing the context,
    such as a window) changes the bound one's: always set it, never rely on it."""
    fbo.viewport = (0, 0, *fbo.size)
    fbo.use()
