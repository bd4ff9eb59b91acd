"""Dynamics benchmark: follicle's guide-strand solver against a NumPy PBD, one run.

Workload (the issue's): strands grown on the built-in head by the default groom, each
resampled to 32 vertices — 32,768 strands (≈ 1 M vertices) and 6,875 (220 k) — under
PBD with 4 iterations of distance, bending, local and global shape matching and skin-SDF
collision, the strain limit, then hair-hair volume friction and repulsion. A *step* is
one substep of the solver (1/120 s) with all of that. The baseline is
``sim_baseline.BaselinePBD`` (NumPy, vectorised over strands) on the same model, state
and SDF. The per-stage split adds one stage at a time to the same simulation. Every
figure is printed next to its same-run baseline. Then the small scene (the default: 300
guides × 24 vertices, default [sim]) on numba's threads against one thread, and
production-shaped guides against the baseline. Run: ``.venv/bin/python benchmarks/sim.py``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numba
import numpy as np

from follicle import Simulator
from follicle.pipeline import groom_scene
from follicle.scene import Scene, SimParams
from sim_baseline import BaselinePBD

FULL = dict(
    vertices=32,
    iterations=4,
    bend_stiffness=0.3,
    shape_local=0.2,
    shape_global=0.1,
    shape_hold=0.0,  # the NumPy baseline has no hold: the same work on both sides
    volume_friction=0.1,
    volume_repulsion=0.05,
)
# the per-stage split: each row adds its stage to the ones above
STAGES = [
    (
        "integrate, distance, strain limit",
        dict(
            bend_stiffness=0.0,
            shape_local=0.0,
            shape_global=0.0,
            skin_collision=False,
            volume_friction=0.0,
            volume_repulsion=0.0,
        ),
    ),
    (
        "+ bending",
        dict(
            shape_local=0.0,
            shape_global=0.0,
            skin_collision=False,
            volume_friction=0.0,
            volume_repulsion=0.0,
        ),
    ),
    (
        "+ local and global shape",
        dict(skin_collision=False, volume_friction=0.0, volume_repulsion=0.0),
    ),
    ("+ skin SDF collision", dict(volume_friction=0.0, volume_repulsion=0.0)),
    ("+ volume friction and repulsion (all)", {}),
]
TARGETS = {32_768: 30.0, 6_875: 150.0}  # steps/s
RATIO_TARGET = 20.0


def _times(step, count: int, repeat: int) -> list[float]:
    """Seconds per step of ``repeat`` runs of ``count`` steps each."""
    out = []
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(count):
            step()
        out.append((time.perf_counter() - start) / count)
    return out


def _simulator(strands: int, settings: dict) -> Simulator:
    groom = groom_scene(Scene())
    hair = groom.generate(count=strands)
    return Simulator(hair, groom.mesh, SimParams(**settings))


def _ours(sim: Simulator, repeat: int) -> tuple[float, float]:
    """Best and median seconds per step of the full solver, from its current state."""
    h = sim.params.substep
    t = _times(lambda: sim.step(h), 10, repeat)
    return min(t), statistics.median(t)


def _stages(sim: Simulator, repeat: int) -> list[tuple[str, float]]:
    """Best seconds per step with the stages added one at a time, each timed from the
    same state (hair that fell through the head without collisions would load them)."""
    sdf, start, out = sim.sdf, sim.state.copy(), []
    for label, off in STAGES:
        params = SimParams(**{**FULL, **off})
        sim.params = sim.solver.params = params
        sim.sdf = sdf if params.skin_collision else None
        runs, h = [], params.substep
        for _ in range(repeat):  # each run from the same state
            sim.state = start.copy()
            runs.append(min(_times(lambda h=h: sim.step(h), 10, 1)))
        out.append((label, min(runs)))
    sim.params = sim.solver.params = SimParams(**FULL)
    sim.sdf = sdf
    return out


def _baseline(sim: Simulator, repeat: int) -> tuple[float, dict[str, float]]:
    """Best seconds per substep of the NumPy baseline on the same state, and its split."""
    p = sim.params
    base = BaselinePBD(sim.model, p, sim.sdf, (p.volume_friction, p.volume_repulsion))
    x, v = sim.state.x.copy(), sim.state.v.copy()
    roots, frames = sim.state.roots, sim.state.frames
    base.substep(x, v, roots, frames, p.substep)  # warm the buffers
    best, split = float("inf"), {}
    for _ in range(repeat):
        base.times = {}
        start = time.perf_counter()
        base.substep(x, v, roots, frames, p.substep)
        took = time.perf_counter() - start
        if took < best:
            best, split = took, dict(base.times)
    return best, split


def _small(repeat: int) -> None:
    """The small scene (the default: 300 guides × 24 vertices, default [sim]) in
    substeps/s as the grains share it out on numba's threads, next to the same scene
    pinned to one thread; and production-shaped guides (benchmarks/production_guides.py)
    at the default [sim] next to the NumPy baseline on the same model."""
    from production_guides import production_guides

    most = numba.get_num_threads()
    groom = groom_scene(Scene())
    sim = Simulator(groom.guides, groom.mesh)
    h = sim.params.substep
    for _ in range(12):
        sim.step(h)
    numba.set_num_threads(1)
    one = min(_times(lambda: sim.step(h), 50, repeat))
    numba.set_num_threads(most)
    ours = min(_times(lambda: sim.step(h), 50, repeat))
    print(
        f"\nsmall scene, {sim.model.strands} guides × {sim.model.vertices}:"
        f" {1 / ours:6.0f} substeps/s on {most} threads ({1 / (5 * ours):.0f} frames/s at"
        f" 24), {1 / one:6.0f} on 1 thread: ×{one / ours:.2f} (target ≥ 100 substeps/s,"
        " and no slower than one thread)"
    )
    sim = Simulator(production_guides(0, groom.mesh), groom.mesh)
    for _ in range(12):
        sim.step(h)
    best, _ = _ours(sim, repeat)
    base, _ = _baseline(sim, repeat)
    print(
        f"production-shaped guides, {sim.model.strands} strands × {sim.model.vertices}"
        f" (4–48 vertices resampled, 2 mm–60 cm): {1 / best:6.0f} substeps/s, NumPy"
        f" PBD {1 / base:6.0f}: follicle {base / best:.1f}× faster; max stretch"
        f" {sim.stats['max_stretch']:.1e}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per figure")
    parser.add_argument("--quick", action="store_true", help="220 k vertices only")
    args = parser.parse_args()
    sizes = [6_875] if args.quick else [32_768, 6_875]
    summary = []
    for strands in sizes:
        sim = _simulator(strands, FULL)
        vertices = strands * sim.model.vertices
        print(
            f"\n{strands:,} strands × {sim.model.vertices} = {vertices:,} vertices"
            f" (skin SDF {sim.sdf})"
        )
        for _ in range(12):  # compile, and let the hair leave its exact rest pose
            sim.step(sim.params.substep)
        best, median = _ours(sim, args.repeat)
        base, split = _baseline(sim, args.repeat)
        print(
            f"  follicle    {1000 * best:8.1f} ms/step  ({1 / best:6.1f} steps/s;"
            f" median {1000 * median:.1f} ms)"
        )
        print(
            f"  NumPy PBD   {1000 * base:8.1f} ms/step  ({1 / base:6.1f} steps/s)"
            f"  → follicle is {base / best:.1f}× faster"
        )
        print("  baseline split: " + ", ".join(f"{k} {1000 * t:.0f} ms" for k, t in split.items()))
        print("  follicle per-stage split (each row adds a stage; best ms/step):")
        previous = 0.0
        for label, took in _stages(sim, args.repeat):
            print(f"    {label:40s} {1000 * took:7.1f}  (+{1000 * (took - previous):.1f})")
            previous = took
        stats = sim.stats
        print(
            f"  after the run: max stretch {stats['max_stretch']:.2e}, mean"
            f" {stats['mean_stretch']:.2e}, max penetration"
            f" {1000 * stats['max_penetration']:.2f} mm"
        )
        summary.append((strands, vertices, 1 / best, base / best))
    _small(args.repeat)
    print("\nsummary (targets: ≥ 30 steps/s at 1 M, ≥ 150 at 220 k, ≥ 20× the baseline)")
    for strands, vertices, rate, ratio in summary:
        target = TARGETS[strands]
        print(
            f"  {vertices:>9,} vertices: {rate:6.1f} steps/s (target {target:g}:"
            f" {'met' if rate >= target else 'MISSED'}), {ratio:5.1f}× the baseline"
            f" ({'met' if ratio >= RATIO_TARGET else 'MISSED'})"
        )


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
