"""The rasteriser's floor: the fastest this machine's OpenGL draws line segments at all,
against the primitives a frame of the rendering and viewer benchmarks needs.

Throughput: ``--segments`` line segments (``GL_LINES``, indexed, each about one pixel
long, in strands of 20 joined end to end, spread over a 1280×720 frame) through a
pass-through vertex shader and a constant fragment shader, depth test on, no geometry
shader, no blending: the least work a hair renderer can ask of the rasteriser per
segment. Best of ``--frames`` draws, each ended by reading a pixel back (so the draw
has finished).

Need: the primitives (line segments and triangles) follicle's geometry shaders emit for
one frame of each workload, counted by a ``GL_PRIMITIVES_GENERATED`` query over the
frame's passes (the two deep-opacity shadow passes and the colour pass); and the least
any renderer of that frame must draw: with shadows, our frame without them (the colour
pass at the workload's subdivisions, which we already take adaptively, fewer where a
segment is short on screen, plus the skin's triangles and two full-screen triangles)
and one shadow pass drawing each hair segment once; without, each hair
segment once. The workloads are those of
``benchmarks/render.py`` (the default groom, 16 vertices per hair, on the built-in
head, 5 Catmull-Rom subdivisions taken adaptively, 1280×720) and of the viewer's
figure in the README (1,000 built-in long guides driving 20,000 hairs at 960×540, at
both qualities).

Floor = need / throughput: the time the rasteriser spends on those primitives even if
every one of them were as cheap as the cheapest segment. It is printed next to the
target; a least floor above the target means no renderer drawing that frame on this
rasteriser meets the target, whatever its shaders do. The throughput's baseline is the
same draw through a pass-through geometry shader (what a geometry-shader stage costs
before it does any work), measured in the same run.

Run: ``.venv/bin/python benchmarks/raster_floor.py``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from follicle.groom.builtin_guides import builtin_guides
from follicle.io.dispatch import save
from follicle.io.mesh_load import load_mesh
from follicle.pipeline import groom_scene
from follicle.render import Renderer
from follicle.render.context import get_context
from follicle.render.settings import RenderParams
from follicle.scene import Scene
from follicle.view import Controller

_VS = """#version 330 core
in vec3 p;
void main() { gl_Position = vec4(p, 1.0); }
"""
_GS = """#version 330 core
layout(lines) in;
layout(line_strip, max_vertices = 2) out;
void main() {
    gl_Position = gl_in[0].gl_Position; EmitVertex();
    gl_Position = gl_in[1].gl_Position; EmitVertex();
    EndPrimitive();
}
"""
_FS = """#version 330 core
out vec4 colour;
void main() { colour = vec4(0.4, 0.3, 0.2, 1.0); }
"""
SIZE = (1280, 720)
STEPS = 20  # segments per strand of the throughput test
TARGETS = {100_000: 1.0, 10_000: 1 / 15}  # the render benchmark's, s per frame


def segments_per_second(count: int, frames: int, geometry: bool) -> float:
    """Best throughput of ``count`` one-pixel segments drawn as ``GL_LINES``, joined into
    strands of 20 (hair-like: each segment starts where the last ended)."""
    ctx = get_context()
    rng = np.random.default_rng(0)
    strands, n = count // STEPS, STEPS + 1
    step = rng.normal(size=(strands, n, 3))
    step *= (2.0 / SIZE[1]) / np.linalg.norm(step[..., :2], axis=2, keepdims=True)
    points = rng.uniform(-0.9, 0.9, (strands, 1, 3)) + np.cumsum(step, axis=1)
    index = np.arange(strands * n, dtype="u4").reshape(strands, n)
    pairs = np.stack([index[:, :-1], index[:, 1:]], axis=2)
    prog = ctx.program(
        vertex_shader=_VS, geometry_shader=_GS if geometry else None, fragment_shader=_FS
    )
    vbo = ctx.buffer(points.astype("f4").tobytes())
    ibo = ctx.buffer(pairs.tobytes())
    vao = ctx.vertex_array(prog, [(vbo, "3f", "p")], index_buffer=ibo, index_element_size=4)
    fbo = ctx.framebuffer([ctx.renderbuffer(SIZE, 4)], ctx.depth_renderbuffer(SIZE))
    fbo.use()
    ctx.enable(ctx.DEPTH_TEST)
    best = np.inf
    for _ in range(frames + 1):  # the first draw compiles the shaders' native code
        begin = time.perf_counter()
        fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        vao.render(ctx.LINES)
        fbo.read(viewport=(0, 0, 1, 1))
        best = min(best, time.perf_counter() - begin)
    ctx.disable(ctx.DEPTH_TEST)
    for obj in (vao, vbo, ibo, fbo, prog):
        obj.release()
    return strands * STEPS / best


def primitives(draw: Callable[[], object]) -> int:
    """Primitives generated while ``draw()`` runs (after a first, warming draw)."""
    draw()
    query = get_context().query(primitives=True)
    with query:
        draw()
    return int(query.primitives)


def render_needs(counts: list[int]) -> list[tuple[str, int, int, float]]:
    """(workload, primitives of our frame, the least any frame needs, target s) for the
    render benchmark's frames: the least is our frame without shadows (colour pass, skin,
    full-screen triangles) plus one shadow pass drawing each hair segment once."""
    scene = Scene()
    scene = scene.replace(groom=scene.groom.replace(vertices=16))
    groom = groom_scene(scene)
    out = []
    with Renderer(size=SIZE, msaa=0) as renderer:
        for n in counts:
            hair = groom.generate(count=n)
            frame, colour = (
                primitives(
                    lambda s=s, h=hair: renderer.draw(
                        h, groom.mesh, settings=RenderParams(subdivisions=5, shadows=s)
                    )
                )
                for s in (True, False)
            )
            least = colour + hair.point_count - hair.curve_count
            out.append((f"render: {n:,} hairs × 16, shadows", frame, least, TARGETS[n]))
    return out


def viewer_needs(folder: Path) -> list[tuple[str, int, int, float]]:
    """The same for a frame of the viewer's figure in the README, at both qualities; the
    least is each hair segment drawn once (``fast``: no shadows, one step a segment)."""
    guides = folder / "guides1000.npz"
    save(builtin_guides("long", load_mesh("builtin:head"), count=1000), guides)
    out = []
    for quality in ("full", "fast"):
        scene = Scene(
            guides={"path": str(guides)}, groom={"count": 20_000}, sim={"motion": "shake"}
        )
        ctl = Controller(scene, size=(960, 540), quality=quality)
        ctl.step()
        hair = ctl.hair()
        least = hair.point_count - hair.curve_count
        out.append((f"viewer: 20,000 hairs, {quality}", primitives(ctl.draw), least, 1 / 30))
        ctl.release()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--segments", type=int, default=1_000_000)
    parser.add_argument("--frames", type=int, default=5)
    parser.add_argument("--counts", type=int, nargs="+", default=[100_000, 10_000])
    args = parser.parse_args()
    ctx = get_context()
    print(f"{ctx.info['GL_RENDERER']}, {SIZE[0]}×{SIZE[1]}")
    rate = segments_per_second(args.segments, args.frames, geometry=False)
    base = segments_per_second(args.segments, args.frames, geometry=True)
    print(
        f"throughput: {rate / 1e6:.2f} M segments/s; through a pass-through geometry"
        f" shader {base / 1e6:.2f} M/s (ratio {rate / base:.2f})"
    )
    with tempfile.TemporaryDirectory() as folder:
        needs = render_needs(args.counts) + viewer_needs(Path(folder))
    print(
        f"{'workload':<36} {'ours: primitives':>16} {'floor s':>8} {'least':>10}"
        f" {'floor s':>8} {'target s':>9}"
    )
    for name, frame, least, target in needs:
        verdict = "the least floor is above the target" if least / rate > target else ""
        print(
            f"{name:<36} {frame:>16,} {frame / rate:8.3f} {least:>10,} {least / rate:8.3f}"
            f" {target:9.3f}  {verdict}"
        )


if __name__ == "__main__":
    main()
