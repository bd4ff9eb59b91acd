"""Threads per dynamics stage: where sharing a stage between threads starts to pay.

Each stage of a substep runs on one thread and on numba's count (two here) over a
range of problem sizes — the default groom's guides on the built-in head, 25 to 10,000
strands × 24 vertices, with the default [sim] (skin SDF, volume friction) — and the
table gives the seconds per call and the ratio, one thread against all, measured in the
same run: the solver's substep kernel and the volume's particle kernels (splat, update)
by vertices, the volume's grid passes (part sums, blur) by grid cells. The grains in
``follicle.sim.simulator`` and ``follicle.sim.volume`` (items per thread below which a
stage keeps to fewer threads) come from the crossovers printed here. The last table is
whole steps/s of the small scene (300 guides × 24) with the grains as they are, against
the same scene pinned to one thread. Run: ``.venv/bin/python benchmarks/sim_threads.py``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numba
import numpy as np

import follicle.sim.simulator as simulator
import follicle.sim.volume as volume
from follicle import Simulator
from follicle.pipeline import groom_scene
from follicle.scene import Scene, SimParams

STRANDS = (25, 50, 100, 300, 1_000, 3_000, 10_000)
VERTICES = 24


def _best(call, repeat: int, count: int) -> float:
    """Median over ``repeat`` runs of the mean seconds of ``count`` calls."""
    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(count):
            call()
        runs.append((time.perf_counter() - start) / count)
    return statistics.median(runs)


def _simulator(strands: int) -> Simulator:
    groom = groom_scene(Scene())
    sim = Simulator(groom.generate(count=strands), groom.mesh, SimParams(vertices=VERTICES))
    for _ in range(24):
        sim.step(sim.params.substep)  # the hair settled a little: contacts, a real volume
    return sim


def _stages(sim: Simulator) -> dict[str, tuple[int, object]]:
    """Stage name → (its size, a call running it once from the current state)."""
    p, state = sim.params, sim.state
    pinned = sim._pinned()
    world = sim._colliders(sim._transform, sim.sdf)
    x, v = state.x.copy(), state.v.copy()
    pts = x.reshape(-1, 3)
    spec = volume._fitted(pts, p.volume_resolution, None, 1 + p.volume_blur)
    grids = np.zeros((1, *spec.shape, 4))
    volume._splat(pts, v.reshape(-1, 3), grids, spec.origin, 1 / spec.voxel)
    sums = volume._part_sums(grids)
    _, flow = volume._resolve(sums, spec.voxel)
    free = sim._free.reshape(-1)

    def substep():
        state.x[:], state.v[:] = x, v
        sim.solver.substep(state, pinned, pinned, 1.0, np.zeros(3), world, 0.0)

    def splat():
        grids[:] = 0.0
        volume._splat(pts, v.reshape(-1, 3), grids, spec.origin, 1 / spec.voxel)

    def grid():
        volume._box_blur(volume._part_sums(grids))

    def update():
        volume._update(
            pts, v.reshape(-1, 3).copy(), free, flow, spec.origin, 1 / spec.voxel, 0.05, 0.0
        )

    cells = int(np.prod(spec.shape))
    return {
        "solver substep": (len(pts), substep),
        "volume splat": (len(pts), splat),
        "volume grid": (cells, grid),
        "volume update": (len(pts), update),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    most = numba.get_num_threads()
    print(f"numba threads: {most} ({numba.threading_layer()} layer)")
    rows: dict[str, list[tuple[int, float, float]]] = {}
    for strands in STRANDS:
        sim = _simulator(strands)
        for name, (size, call) in _stages(sim).items():
            count = max(3, min(200, 2_000_000 // max(size, 1)))
            numba.set_num_threads(1)
            call()
            one = _best(call, args.repeat, count)
            numba.set_num_threads(most)
            call()
            all_ = _best(call, args.repeat, count)
            rows.setdefault(name, []).append((size, one, all_))
    for name, table in rows.items():
        print(f"\n{name}: size, 1 thread, {most} threads, 1 thread / {most}")
        for size, one, all_ in table:
            print(f"  {size:>9,}  {1e6 * one:9.1f} µs  {1e6 * all_:9.1f} µs  ×{one / all_:5.2f}")
    print(
        f"\ngrains: substep {simulator.SUBSTEP_GRAIN:,} vertices, volume particles"
        f" {volume.PARTICLE_GRAIN:,}, volume cells {volume.CELL_GRAIN:,} per thread"
    )
    sim = _simulator(300)
    h = sim.params.substep
    step = lambda: sim.step(h)  # noqa: E731
    numba.set_num_threads(1)
    one = _best(step, args.repeat, 100)
    numba.set_num_threads(most)
    chosen = _best(step, args.repeat, 100)
    print(
        f"small scene, 300 guides × {VERTICES}: {1 / chosen:,.0f} substeps/s with the grains"
        f" on {most} threads, {1 / one:,.0f} on one thread (×{one / chosen:.2f})"
    )


if __name__ == "__main__":
    main()
