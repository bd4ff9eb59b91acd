"""Settling the demo's long hair (``[groom].settle``, issue 43): its time beside a
baseline measured in the same run, growing the same groom's 20,000 hairs, as a ratio,
and what the settle ends with (stretch, penetration, kinetic energy, how far the tips
fell). Run alone: ``.venv/bin/python benchmarks/settle.py [--repeat 3]``; each
figure is the best of the repeats, after one warm-up run of each (numba compiles).
"""

from __future__ import annotations

import argparse

import numpy as np

from common import best_of
from follicle.cli import _DEMO_SETTLE
from follicle.pipeline import groom_inputs, groom_scene
from follicle.scene import parse_scene
from follicle.sim.settle import settle


def best(run, repeat: int) -> float:
    """The shortest of ``repeat`` timed calls of ``run``, after one untimed (numba)."""
    run()
    return best_of(run, repeat)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    tables = {"groom": {"count": 20_000}}
    scene = parse_scene(tables, "benchmark")  # the demo's scene (the bust) with settle 0
    inputs = groom_inputs(scene)
    groom = groom_scene(scene, inputs)
    grow = best(groom.generate, args.repeat)
    done = settle(inputs.guides, scene.sim, _DEMO_SETTLE)
    seconds = best(lambda: settle(inputs.guides, scene.sim, _DEMO_SETTLE), args.repeat)
    g = inputs.guides
    before = g.rest_shapes(g.vertex_count)[:, -1, 1] + g.root_positions[:, 1]
    s = done.guides
    after = s.rest_shapes(s.vertex_count)[:, -1, 1] + s.root_positions[:, 1]
    print(
        f"settle {_DEMO_SETTLE:g} s of {g.count} guides × {g.vertex_count} vertices:"
        f" {seconds:.2f} s; grow {scene.groom.count:,} hairs: {grow:.2f} s;"
        f" ratio {seconds / grow:.2f}"
    )
    st = done.stats
    print(
        f"max stretch {st['max_stretch']:.2e}, max penetration"
        f" {st['max_penetration'] * 1000:.3f} mm, kinetic energy {st['kinetic_energy']:.2e};"
        f" tips fell {np.mean(before - after) * 100:.2f} cm on average"
        f" ({np.mean(before > after):.0%} of them lower)"
    )


if __name__ == "__main__":
    main()
