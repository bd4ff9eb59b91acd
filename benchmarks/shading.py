"""Shading cost on the CPU engine: seconds per frame of each hair shading model, in the
same run, and their ratio to Kajiya-Kay's (issue 43: the physical model's target is
≤ 1.3× Kajiya-Kay's frame time).

Workload: the gallery scenes (examples/*.toml, their own grooms, cameras and lights) at
640×640, shadows and OIT on, on a reused CpuRenderer; the models' frames alternate, so a
busy neighbour slows them alike, and each figure is the best of ``--frames`` frames
after a warm-up. The split of the frame into stages (the hair's steps are where the
shading runs) is printed beside it.

Run: ``.venv/bin/python benchmarks/shading.py [--scenes wavy curly] [--frames 5]
[--models kajiya-kay physical]``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from follicle.pipeline import grow
from follicle.render import CpuRenderer
from follicle.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
SIZE = (640, 640)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenes", nargs="+", default=["wavy", "curly", "short_fur"])
    parser.add_argument("--models", nargs="+", default=["kajiya-kay", "marschner", "physical"])
    parser.add_argument("--frames", type=int, default=5)
    args = parser.parse_args()
    print(f"CPU engine, {SIZE[0]}×{SIZE[1]}, best of {args.frames} frames (alternating)")
    print(f"{'scene':<20} {'model':<12} {'s/frame':>8} {'× KK':>6}  split (ms)")
    ratios: dict[str, list[float]] = {m: [] for m in args.models}
    with CpuRenderer(size=SIZE) as renderer:
        for name in args.scenes:
            scene = load_scene(ROOT / "examples" / f"{name}.toml")
            mesh, curves = grow(scene)
            settings = {
                m: scene.render.replace(size=SIZE, shading=m, shading_params={})
                for m in args.models
            }
            best = {m: float("inf") for m in args.models}
            split = {}
            for m in args.models:  # warm-up: kernels compiled, buffers made
                renderer.draw(curves, mesh, settings=settings[m])
            for _ in range(args.frames):
                for m in args.models:
                    start = time.perf_counter()
                    renderer.draw(curves, mesh, settings=settings[m])
                    seconds = time.perf_counter() - start
                    if seconds < best[m]:
                        best[m] = seconds
                        split[m] = "  ".join(
                            f"{k} {1000 * v:.0f}" for k, v in renderer.timings.items()
                        )
            base = best.get("kajiya-kay", best[args.models[0]])
            for m in args.models:
                ratios[m].append(best[m] / base)
                print(f"{name:<20} {m:<12} {best[m]:>8.3f} {best[m] / base:>6.2f}  {split[m]}")
    print(
        "\nmean ratio to Kajiya-Kay: "
        + ", ".join(f"{m} {sum(r) / len(r):.2f}×" for m, r in ratios.items())
    )


if __name__ == "__main__":
    main()
