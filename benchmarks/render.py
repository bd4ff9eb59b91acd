"""Rendering benchmark: seconds per frame of a reused Renderer, next to a same-run baseline.

Workload (issue "Rendering"): the default groom grown to 100,000 hairs × 16 vertices on
the built-in head (and 10,000), 5 Catmull-Rom subdivisions, 1280×720, shadows on (deep
opacity maps), weighted blended OIT, Kajiya-Kay. Each frame is steady state: upload,
draw, read back and encode to sRGB, with the context, programs and framebuffers made
once. Baseline: the same frame with shadows and OIT off, i.e. the foundation's path
(segments sorted back to front on the CPU, "over" blending); the ratio is ours/baseline.

Mitsuba (``--mitsuba-spp``, default 64; 0 skips it): the default scene (20,000 hairs ×
24 vertices, its camera, lights and background) path-traced as one still at 640×640 and
1280×720, timed once (scene set-up, curve file and BVH included), next to the OpenGL
still of the same scene at the same size (best of 2, MSAA 4) as the same-run baseline.

The CPU engine (``--engine cpu``, issue "A strand rasterizer of our own"): the same
frames (100,000 and 10,000 hairs × 16, 1280×720, shadows and OIT, MSAA 4 — the engine's
coverage is analytic, MSAA only supersamples the skin) next to the OpenGL engine on
this machine's GL in the same run (the ratio is OpenGL's seconds over ours: the
speed-up), with the split of a frame into its stages (the key light's maps, the skin,
the hair's steps — projection, subdivision and shading —, binning, rasterization and
the resolve) and the frame's peak of new memory (tracemalloc: the arrays the frame
allocates). Then the viewer's figure: 1,000 built-in long guides driving 20,000 hairs
at 960×540, simulation, regrowth and the full-quality render, frames per second on
each engine, and on the CPU engine holding 15 frames/s by level of detail (the share of
the hairs drawn, after 30 frames to settle).

Run: ``.venv/bin/python benchmarks/render.py [--counts 100000 10000] [--msaa 0 4]
[--cpu-only]``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
import tracemalloc
from pathlib import Path

from common import best_of
from follicle.groom.builtin_guides import builtin_guides
from follicle.io.dispatch import save
from follicle.io.mesh_load import load_mesh
from follicle.pipeline import groom_scene, grow, render_scene
from follicle.render import CpuRenderer, Renderer
from follicle.render.settings import RenderParams
from follicle.scene import Scene
from follicle.view import Controller

SIZE = (1280, 720)
SUBDIVISIONS = 5
TARGETS = {100_000: ("≤ 1.0 s", 1.0), 10_000: ("≥ 15 frames/s", 1 / 15)}
CPU_TARGETS = {100_000: ("≤ 0.5 s, ≥ 7×", 0.5), 10_000: ("≥ 15 frames/s", 1 / 15)}
VIEWER_SIZE = (960, 540)


def seconds_per_frame(renderer, curves, mesh, frames: int, **options) -> float:
    """Best of ``frames`` steady-state frames (after one warm-up frame)."""
    settings = RenderParams(subdivisions=SUBDIVISIONS, **options)
    renderer.draw(curves, mesh, settings=settings)
    times = []
    for _ in range(frames):
        start = time.perf_counter()
        renderer.draw(curves, mesh, settings=settings)
        times.append(time.perf_counter() - start)
    return min(times)


def verdict(targets: dict, n: int, seconds: float) -> str:
    """The target of ``n`` hairs and whether ``seconds`` a frame meets it."""
    label, limit = targets.get(n, ("", None))
    return label if limit is None else f"{label} {'met' if seconds <= limit else 'missed'}"


def cpu_engine(grown: dict, mesh, frames: int) -> None:
    """The CPU engine against the OpenGL engine, same frames, same run."""
    print(f"\nCPU engine vs OpenGL ({SIZE[0]}×{SIZE[1]}, {SUBDIVISIONS} subdivisions, MSAA 4)")
    print(
        f"{'figure':<30} {'cpu s':>7} {'frames/s':>9} {'opengl s':>9} {'speed-up':>9}"
        f" {'new MB':>7}  split (ms)"
    )
    with CpuRenderer(size=SIZE, msaa=4) as cpu, Renderer(size=SIZE, msaa=4) as gl:
        for n, curves in grown.items():
            ours = seconds_per_frame(cpu, curves, mesh, frames)
            split = "  ".join(f"{k} {1000 * v:.0f}" for k, v in cpu.timings.items())
            tracemalloc.start()
            cpu.draw(curves, mesh, settings=RenderParams(subdivisions=SUBDIVISIONS))
            peak = tracemalloc.get_traced_memory()[1] / 2**20
            tracemalloc.stop()
            base = seconds_per_frame(gl, curves, mesh, frames)
            name = f"{n:,} hairs × 16, shadows + OIT"
            print(
                f"{name:<30} {ours:7.3f} {1 / ours:9.2f} {base:9.3f} {base / ours:8.2f}×"
                f" {peak:7.0f}  {split}  target {verdict(CPU_TARGETS, n, ours)}"
            )


def viewer(frames: int) -> None:
    """The viewer's figure: simulation, regrowth and the full-quality render per frame."""
    with tempfile.TemporaryDirectory() as folder:
        guides = Path(folder) / "guides1000.npz"
        save(builtin_guides("long", load_mesh("builtin:head"), count=1000), guides)
        print(f"\nviewer: 1,000 guides → 20,000 hairs, {VIEWER_SIZE[0]}×{VIEWER_SIZE[1]}, full")
        print(
            f"{'engine':<20} {'frames/s':>9} {'step ms':>8} {'groom ms':>9} {'render ms':>10}"
            f" {'drawn':>6}"
        )
        for engine, hold in (("cpu", None), ("opengl", None), ("cpu", 15.0)):
            scene = Scene(
                guides={"path": str(guides)},
                groom={"count": 20_000},
                sim={"motion": "shake"},
                render={"engine": engine},
            )
            ctl = Controller(scene, size=VIEWER_SIZE, quality="full", hold_fps=hold)
            for _ in range(1 if hold is None else 30):  # warm-up; the hold settles
                ctl.step_frame()
            times = []
            for _ in range(frames):
                start = time.perf_counter()
                ctl.step_frame()
                times.append(time.perf_counter() - start)
            t = ctl.timings
            name = engine if hold is None else f"{engine}, hold {hold:g} fps"
            print(
                f"{name:<20} {len(times) / sum(times):9.2f} {1000 * t['step']:8.0f}"
                f" {1000 * t['groom']:9.0f} {1000 * t['render']:10.0f} {ctl.lod:6.0%}"
                + ("  target ≥ 15 frames/s" if engine == "cpu" else "")
            )
            ctl.release()


def mitsuba_stills(spp: int) -> None:
    """Seconds for a Mitsuba still of the default scene, and the GL still beside it."""
    scene = Scene()
    mesh, curves = grow(scene)
    print(f"{curves.curve_count:,} hairs (default scene), Mitsuba {spp} spp vs OpenGL")
    print(f"{'size':<12} {'Mitsuba s':>10} {'OpenGL s':>9} {'ratio':>7}")
    for size in ((640, 640), (1280, 720)):
        params = scene.render.model_copy(update={"size": size})
        start = time.perf_counter()
        render_scene(curves, mesh, params.replace(engine="mitsuba", spp=spp))
        ours = time.perf_counter() - start
        base = best_of(lambda p=params: render_scene(curves, mesh, p), repeat=2)
        print(f"{size[0]}×{size[1]:<7} {ours:10.1f} {base:9.2f} {ours / base:7.0f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--counts", type=int, nargs="+", default=[100_000, 10_000])
    parser.add_argument("--msaa", type=int, nargs="+", default=[0, 4])
    parser.add_argument("--frames", type=int, default=2)
    parser.add_argument("--mitsuba-spp", type=int, default=64, help="0: no Mitsuba stills")
    parser.add_argument(
        "--cpu-only", action="store_true", help="only the CPU engine's figures and the viewer's"
    )
    args = parser.parse_args()

    scene = Scene()
    scene = scene.replace(groom=scene.groom.replace(vertices=16))
    groom = groom_scene(scene)
    grown = {n: groom.generate(count=n) for n in args.counts}
    for curves in grown.values():
        counts = set(curves.counts.tolist())
        assert counts == {16}, f"expected 16 vertices per hair, got {sorted(counts)}"

    cpu_engine(grown, groom.mesh, max(args.frames, 3))
    viewer(10)
    if args.cpu_only:
        return
    print(f"\n{SIZE[0]}×{SIZE[1]}, {SUBDIVISIONS} subdivisions, Kajiya-Kay, built-in head")
    print(f"{'figure':<40} {'s/frame':>8} {'frames/s':>9} {'baseline':>9} {'ratio':>6}  target")
    for msaa in args.msaa:
        with Renderer(size=SIZE, msaa=msaa) as renderer:
            for n, curves in grown.items():
                ours = seconds_per_frame(renderer, curves, groom.mesh, args.frames)
                base = seconds_per_frame(
                    renderer, curves, groom.mesh, args.frames, shadows=False, oit=False
                )
                name = f"{n:,} hairs × 16, shadows + OIT, msaa {msaa}"
                print(
                    f"{name:<40} {ours:8.3f} {1 / ours:9.2f} {base:9.3f} {ours / base:6.2f}"
                    f"  {verdict(TARGETS, n, ours)}"
                )

    if args.mitsuba_spp:
        mitsuba_stills(args.mitsuba_spp)


if __name__ == "__main__":
    main()
