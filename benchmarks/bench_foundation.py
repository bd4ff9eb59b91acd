"""Foundation benchmark: grow and render the demo groom, next to a same-run yardstick.

Each figure is printed with a baseline measured in the same process (a fixed numpy
workload: sorting 4 M floats), so the ratio stays comparable on a shared, noisy
machine. Run: ``.venv/bin/python benchmarks/bench_foundation.py [--count N]``.
"""

from __future__ import annotations

import argparse

import follicle
from common import best_of, yardstick
from follicle.pipeline import render_scene
from follicle.scene import Scene


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--count", type=int, default=20000)
    parser.add_argument("--size", type=int, default=960)
    args = parser.parse_args()

    mesh = follicle.load_mesh("builtin:head")
    guides = follicle.load_guides("builtin:long", mesh)
    groom = follicle.Groom(mesh, guides)
    groom.generate(count=100)  # JIT warm-up (cached after the first run)
    base = yardstick()

    rows = []
    t_grow = best_of(lambda: groom.generate(count=args.count))
    rows.append((f"grow {args.count:,} hairs × 24 vertices", t_grow))
    curves = groom.generate(count=args.count)
    scene = Scene()
    scene = scene.replace(render=scene.render.replace(size=(args.size, args.size)))
    render_scene(curves, mesh, scene.render)  # context and shader warm-up
    t_render = best_of(lambda: render_scene(curves, mesh, scene.render), repeat=2)
    rows.append((f"render {args.count:,} hairs at {args.size}² msaa 4", t_render))

    print(f"{'figure':<44} {'seconds':>9} {'baseline':>9} {'ratio':>8}")
    print(f"{'baseline: np.sort of 4 M floats':<44} {base:9.4f} {base:9.4f} {1.0:8.2f}")
    for name, t in rows:
        print(f"{name:<44} {t:9.4f} {base:9.4f} {t / base:8.2f}")
    rate = args.count / t_grow
    print(f"growth rate: {rate:,.0f} hairs/s")


if __name__ == "__main__":
    main()
