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

Run: ``.venv/bin/python benchmarks/render.py [--counts 100000 10000] [--msaa 0 4]``.
"""

from __future__ import annotations

import argparse
import time

from common import best_of
from follicle.pipeline import groom_scene, grow, render_scene, render_scene_mitsuba
from follicle.render import Renderer
from follicle.render.settings import RenderParams
from follicle.scene import Scene

SIZE = (1280, 720)
SUBDIVISIONS = 5
TARGETS = {100_000: ("≤ 1.0 s", 1.0), 10_000: ("≥ 15 frames/s", 1 / 15)}


def seconds_per_frame(renderer: Renderer, curves, mesh, frames: int, **options) -> float:
    """Best of ``frames`` steady-state frames (after one warm-up frame)."""
    settings = RenderParams(subdivisions=SUBDIVISIONS, **options)
    renderer.draw(curves, mesh, settings=settings)
    times = []
    for _ in range(frames):
        start = time.perf_counter()
        renderer.draw(curves, mesh, settings=settings)
        times.append(time.perf_counter() - start)
    return min(times)


def mitsuba_stills(spp: int) -> None:
    """Seconds for a Mitsuba still of the default scene, and the GL still beside it."""
    scene = Scene()
    mesh, curves = grow(scene)
    print(f"{curves.curve_count:,} hairs (default scene), Mitsuba {spp} spp vs OpenGL")
    print(f"{'size':<12} {'Mitsuba s':>10} {'OpenGL s':>9} {'ratio':>7}")
    for size in ((640, 640), (1280, 720)):
        params = scene.render.model_copy(update={"size": size})
        start = time.perf_counter()
        render_scene_mitsuba(curves, mesh, params, spp=spp)
        ours = time.perf_counter() - start
        base = best_of(lambda p=params: render_scene(curves, mesh, p), repeat=2)
        print(f"{size[0]}×{size[1]:<7} {ours:10.1f} {base:9.2f} {ours / base:7.0f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--counts", type=int, nargs="+", default=[100_000, 10_000])
    parser.add_argument("--msaa", type=int, nargs="+", default=[0, 4])
    parser.add_argument("--frames", type=int, default=2)
    parser.add_argument("--mitsuba-spp", type=int, default=64, help="0: no Mitsuba stills")
    args = parser.parse_args()

    scene = Scene()
    scene = scene.replace(groom=scene.groom.replace(vertices=16))
    groom = groom_scene(scene)
    grown = {n: groom.generate(count=n) for n in args.counts}
    for curves in grown.values():
        counts = set(curves.counts.tolist())
        assert counts == {16}, f"expected 16 vertices per hair, got {sorted(counts)}"

    print(f"{SIZE[0]}×{SIZE[1]}, {SUBDIVISIONS} subdivisions, Kajiya-Kay, built-in head")
    print(f"{'figure':<40} {'s/frame':>8} {'frames/s':>9} {'baseline':>9} {'ratio':>6}  target")
    for msaa in args.msaa:
        with Renderer(size=SIZE, msaa=msaa) as renderer:
            for n, curves in grown.items():
                ours = seconds_per_frame(renderer, curves, groom.mesh, args.frames)
                base = seconds_per_frame(
                    renderer, curves, groom.mesh, args.frames, shadows=False, oit=False
                )
                label, limit = TARGETS.get(n, ("", None))
                met = "" if limit is None else (" met" if ours <= limit else " missed")
                name = f"{n:,} hairs × 16, shadows + OIT, msaa {msaa}"
                print(
                    f"{name:<40} {ours:8.3f} {1 / ours:9.2f} {base:9.3f} {ours / base:6.2f}"
                    f"  {label}{met}"
                )

    if args.mitsuba_spp:
        mitsuba_stills(args.mitsuba_spp)


if __name__ == "__main__":
    main()
