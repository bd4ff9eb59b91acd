"""The dynamics targets as a CPU budget per vertex, against what the parts of a step cost.

Budget: the issue's targets (30 steps/s at 1 M vertices, 150 at 220 k) on this
machine's cores leave ``cores × 1 s / (rate × vertices)`` of CPU time per vertex-step.

Cost, on one thread (``time.process_time``, best of ``--repeat``), per vertex-step, on
the state of ``benchmarks/sim.py``'s 1 M-vertex workload after 12 substeps:

* the whole step (``Simulator.step`` of one substep, everything on), and the same on
  every core as wall time per vertex: their ratio is how well the step scales (about
  the core count when the step is bound by arithmetic, not by memory);
* each constraint pass of one iteration alone — distance, bending, local shape, global
  shape — over a few blocks of the state that stay in cache (the pass's arithmetic and
  nothing else: no gathering, no memory traffic), times the workload's iterations;
* the hair volume alone (``volume_step``: bounds, splat, blur, update) on the whole
  state, at the workload's grid resolution and at a quarter of it, whose grid fits
  the second-level cache (about equal costs: its work is arithmetic per particle, not
  grid traffic);
* the skin collisions: the whole step without them, subtracted.

A sum of parts above the budget means the step cannot meet the target with these
parts, however the rest of it (integration, strain limit, gathering, velocities)
is done. Run: ``.venv/bin/python benchmarks/sim_budget.py``.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numba
import numpy as np
from numba import njit

from follicle.scene import SimParams
from follicle.sim import constraints as C
from follicle.sim.solver import BLOCK, _blocked
from follicle.sim.volume import volume_step
from sim import FULL, TARGETS, _simulator

STRANDS = 32_768  # the 1 M-vertex workload
CACHED_BLOCKS = 4  # blocks of strands the constraint passes run over, again and again
PASSES = ("distance", "bending", "local shape", "global shape")


@njit(cache=True)
def _run_pass(
    which, reps, X, W, L, R, static, target, rest_dir, row, k, profile, scale, attenuation
):
    """Pass ``which`` (an index of PASSES) over every block of X, ``reps`` times."""
    for _ in range(reps):
        for b in range(X.shape[0]):
            if which == 0:
                C.distance_pass(X[b], W[b], L[b], k[0], row, BLOCK)
            elif which == 1:
                C.bend_pass(X[b], W[b], static[b], R[b], scale, k[1], attenuation, BLOCK)
            elif which == 2:
                C.local_shape_pass(X[b], W[b], target[b], rest_dir[b], k[2], row, BLOCK)
            else:
                C.global_shape_pass(X[b], W[b], target[b], profile, BLOCK)


def _best(run: Callable[[], None], repeat: int) -> float:
    """Fewest CPU seconds of ``repeat`` calls of ``run``."""
    best = float("inf")
    for _ in range(repeat):
        start = time.process_time()
        run()
        best = min(best, time.process_time() - start)
    return best


def _step_ns(sim, start, params: SimParams, steps: int, repeat: int, clock) -> float:
    """Best ns per vertex-step of ``steps`` substeps from ``start`` under ``params``, by
    ``clock`` (process time on one thread, wall time on all)."""
    kept, sdf = sim.params, sim.sdf
    sim.params = sim.solver.params = params
    if not params.skin_collision:
        sim.sdf = None
    best = float("inf")
    for _ in range(repeat):
        sim.state = start.copy()
        t = clock()
        for _ in range(steps):
            sim.step(params.substep)
        best = min(best, clock() - t)
    sim.params = sim.solver.params = kept
    sim.sdf = sdf
    return 1e9 * best / (steps * sim.model.strands * sim.model.vertices)


def _pass_ns(sim, repeat: int) -> dict[str, float]:
    """ns per vertex of one iteration of each constraint pass, alone, in cache."""
    n, st, solver = sim.model.vertices, sim.state, sim.solver
    take = slice(0, CACHED_BLOCKS * BLOCK)
    strands, c = solver.constants()
    W, L, local, R = (a[:CACHED_BLOCKS] for a in strands[:4])
    roots, frames = st.roots[take], st.frames[take]
    static = roots + np.einsum("sk,ska->sa", sim.model.static_local[take], frames)
    target = np.empty((CACHED_BLOCKS, n, 3, BLOCK))
    rest_dir = np.empty_like(target)
    root_rows, frame_rows = _blocked(roots, 3), _blocked(frames, 3)
    for b in range(CACHED_BLOCKS):  # the skinned rest pose, as the solver makes it
        C.rest_pose(root_rows[b], frame_rows[b], local[b], target[b], rest_dir[b], BLOCK)
    p = sim.params
    args = (
        W,
        L,
        R,
        _blocked(static, 3),
        target,
        rest_dir,
        np.empty((3, BLOCK)),
        np.array([c.k_stretch, c.k_bend, c.k_local]),
        c.k_global,
        c.bend_scale,
        c.attenuation,
    )
    reps, out = 64, {}
    for which, name in enumerate(PASSES):
        X = _blocked(st.x[take], n)
        _run_pass(which, 1, X, *args)  # compile
        took = _best(lambda w=which, X=X: _run_pass(w, reps, X, *args), repeat)
        out[name] = 1e9 * took / (reps * CACHED_BLOCKS * BLOCK * n) * p.iterations
    return out


def _volume_ns(sim, resolution: int, repeat: int) -> float:
    """ns per vertex of one volume exchange over the whole state."""
    p, st = sim.params, sim.state
    v = st.v.copy()

    def run() -> None:
        v[:] = st.v
        volume_step(
            st.x,
            v,
            sim._free,
            p.substep,
            p.volume_friction,
            p.volume_repulsion,
            p.volume_blur,
            resolution,
        )

    run()
    return 1e9 * _best(run, repeat) / st.x[..., 0].size


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per figure")
    args = parser.parse_args()
    cores = numba.config.NUMBA_NUM_THREADS
    sim = _simulator(STRANDS, FULL)
    vertices = sim.model.strands * sim.model.vertices
    print(
        f"{sim.model.strands:,} strands × {sim.model.vertices} = {vertices:,} vertices,"
        f" {sim.params.iterations} iterations; {cores} cores"
    )
    for _ in range(12):  # compile, and leave the exact rest pose
        sim.step(sim.params.substep)
    start, full = sim.state.copy(), SimParams(**FULL)

    print("\nbudget: CPU ns per vertex-step the targets leave on these cores")
    budgets = {}
    for strands, rate in TARGETS.items():
        n = strands * sim.model.vertices
        budgets[n] = cores * 1e9 / (rate * n)
        print(f"  {n:>9,} vertices at {rate:g} steps/s: {budgets[n]:6.1f} ns")

    numba.set_num_threads(1)
    whole = _step_ns(sim, start, full, 10, args.repeat, time.process_time)
    bare = _step_ns(
        sim,
        start,
        SimParams(**{**FULL, "skin_collision": False}),
        10,
        args.repeat,
        time.process_time,
    )
    passes = _pass_ns(sim, args.repeat)
    volume = _volume_ns(sim, sim.params.volume_resolution, args.repeat)
    coarse = _volume_ns(sim, sim.params.volume_resolution // 4, args.repeat)
    numba.set_num_threads(cores)
    wall = _step_ns(sim, start, full, 10, args.repeat, time.perf_counter)

    print(f"\ncost: CPU ns per vertex-step on one thread (best of {args.repeat})")
    print(f"  whole step                                   {whole:6.1f}")
    print(
        f"  whole step on {cores} threads (wall × {cores})            {wall * cores:6.1f}"
        f"   (scaling {whole / wall:.2f} of {cores})"
    )
    for name, ns in passes.items():
        print(f"  {name + f' pass × {sim.params.iterations}, in cache':44s} {ns:6.1f}")
    parts = sum(passes.values())
    print(
        f"  {'volume (grid ' + str(sim.params.volume_resolution) + ')':44s} {volume:6.1f}"
        f"   (grid {sim.params.volume_resolution // 4}: {coarse:.1f})"
    )
    print(f"  {'skin collisions (whole step − without)':44s} {whole - bare:6.1f}")
    total = parts + volume + (whole - bare)
    print(
        f"\nconstraint passes + volume + collisions: {total:.1f} ns (of the whole step's"
        f" {whole:.1f})"
    )
    for n, budget in budgets.items():
        print(
            f"  against {n:,} vertices' budget {budget:.1f} ns: {total / budget:.2f}×"
            f" ({'over' if total > budget else 'within'})"
        )


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
