"""Groom benchmark: follicle's hair generator against a plain NumPy/SciPy baseline, one run.

Workload (the issue's): 1,000,000 hairs × 16 vertices on the built-in head from 1,000
"long" guides, IDW with n = 3 (4 nearest guides), frizz, kink and colour variation; a
second size (100,000 hairs) shows the ratio at two scales, and 200,000 hairs × 5 fibres
× 16 vertices the strand path. Both sides start from the same mesh and guide curves and
include binding the guides. The baseline is ``groom_baseline.grow``; peak memory is
measured in a fresh subprocess. Every figure is printed next to its same-run baseline,
then a summary against the targets. Run: ``.venv/bin/python benchmarks/groom.py``.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import resource
import subprocess
import sys
import time
from dataclasses import asdict, replace

import numpy as np

from common import best_of, yardstick
from follicle.curves import HairCurves
from follicle.groom.builtin_guides import builtin_guides
from follicle.mesh.head import builtin_head
from follicle.mesh.skin import SkinMesh
from groom_baseline import Settings, grow, guide_arrays, mesh_arrays

WORKLOAD = Settings(count=1_000_000)
FIBRES = {
    "strand_count": 5,
    "strand_splay_root": 0.0005,
    "strand_splay_centre": 0.002,
    "strand_splay_tip": 0.001,
}
TARGET_SECONDS = 1.0  # ours at 1 M × 16
TARGET_SPEEDUP = 5.0  # baseline / ours at 1 M × 16
TARGET_MEMORY = 2.0  # peak increase / output arrays
TARGET_FIBRES = 1.5  # ours at 200 k × 5 fibres × 16


def inputs() -> tuple[SkinMesh, HairCurves]:
    """The built-in head and 1,000 built-in long guides (24 vertices each)."""
    head = builtin_head()
    return head, builtin_guides("long", head, count=1000)


def follicle_grow(
    mesh: SkinMesh, curves: HairCurves, settings: Settings, **extra: object
) -> HairCurves:
    """follicle's whole path from mesh and guide curves: bind guides, build the Groom, generate."""
    from follicle.groom.generator import Groom
    from follicle.groom.guides import Guides
    from follicle.scene import GroomParams

    guides = Guides(curves, mesh, vertices=settings.vertices)
    return Groom(mesh, guides, GroomParams(**asdict(settings), **extra)).generate()


def output_bytes(curves: HairCurves) -> int:
    """Bytes of every output array: points, offsets, point data and curve data."""
    arrays = [curves.points, curves.offsets, *curves.point_data.values()]
    return sum(a.nbytes for a in arrays + list(curves.curve_data.values()))


def _rss() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def memory_child(which: str, count: int) -> None:
    """In a fresh process: peak RSS increase of one growth of ``count`` hairs, as JSON."""
    mesh, curves = inputs()
    settings = replace(WORKLOAD, count=count)
    if which == "ours":
        follicle_grow(mesh, curves, replace(settings, count=1000))  # JIT warm-up
        gc.collect()
        before = _rss()
        out = follicle_grow(mesh, curves, settings)
        size = output_bytes(out)
    else:
        m, g = mesh_arrays(mesh), guide_arrays(curves)
        grow(m, g, replace(settings, count=1000))
        gc.collect()
        before = _rss()
        size = sum(a.nbytes for a in grow(m, g, settings).values())
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # KiB on Linux
    print(json.dumps({"before": before, "peak": peak, "output": size}))


def measure_memory(which: str, count: int) -> dict:
    """Run :func:`memory_child` in a subprocess; its figures, or the error it ended with."""
    cmd = [sys.executable, __file__, "--memory-child", which, "--count", str(count)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        return {"error": proc.stderr.strip().splitlines()[-1] if proc.stderr else "failed"}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _bounds(points: np.ndarray) -> str:
    lo, hi = (np.round(v.astype(np.float64), 3).tolist() for v in (points.min(0), points.max(0)))
    return f"{lo} … {hi}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--count", type=int, default=WORKLOAD.count)
    parser.add_argument("--small", type=int, default=100_000)
    parser.add_argument("--fibres", type=int, default=200_000)
    parser.add_argument("--baseline-repeat", type=int, default=2)
    parser.add_argument("--memory-child", choices=("ours", "baseline"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.memory_child:
        memory_child(args.memory_child, args.count)
        return

    mesh, curves = inputs()
    m_arr, g_arr = mesh_arrays(mesh), guide_arrays(curves)
    big, small = replace(WORKLOAD, count=args.count), replace(WORKLOAD, count=args.small)
    fibres = replace(WORKLOAD, count=args.fibres)
    follicle_grow(mesh, curves, replace(WORKLOAD, count=1000))  # JIT warm-up
    follicle_grow(mesh, curves, replace(WORKLOAD, count=1000), **FIBRES)
    grow(m_arr, g_arr, replace(WORKLOAD, count=1000))
    base = yardstick()

    t_big = best_of(lambda: follicle_grow(mesh, curves, big), repeat=5)  # ~1 s each: cheap
    b_big = best_of(lambda: grow(m_arr, g_arr, big), repeat=args.baseline_repeat)
    t_small = best_of(lambda: follicle_grow(mesh, curves, small))
    b_small = best_of(lambda: grow(m_arr, g_arr, small), repeat=2)
    t_fib = best_of(lambda: follicle_grow(mesh, curves, fibres, **FIBRES))
    ours_out = follicle_grow(mesh, curves, small)
    base_out = grow(m_arr, g_arr, small)
    finite = all(np.isfinite(a).all() for a in [ours_out.points, *base_out.values()])
    ours_bounds, base_bounds = _bounds(ours_out.points), _bounds(base_out["points"])
    del ours_out, base_out
    mem = measure_memory("ours", args.count)
    mem_base = measure_memory("baseline", args.count)

    print(
        f"built-in head, 1,000 long guides → {args.count:,} hairs × {big.vertices} vertices,"
        f" IDW n = {big.guide_samples}, frizz, kink, colour variation; {os.cpu_count()} CPUs"
    )
    print(
        f"{args.small:,} hairs: bounds ours {ours_bounds}, baseline {base_bounds};"
        f" all finite: {finite}"
    )
    print(f"{'figure':<32} {'ours (s)':>9} {'baseline':>9} {'speed-up':>9} {'ours hairs/s':>13}")
    for label, n, ours, ref in (
        ("grow", args.count, t_big, b_big),
        ("grow", args.small, t_small, b_small),
    ):
        print(
            f"{f'{label} {n:,} × {big.vertices}':<32} {ours:9.3f} {ref:9.3f} {ref / ours:9.2f}"
            f" {n / ours:13,.0f}"
        )
    print(
        f"{f'fibres {args.fibres:,} × 5 × {big.vertices}':<32} {t_fib:9.3f} {'—':>9} {'':>9}"
        f" {args.fibres / t_fib:13,.0f}"
    )
    print(
        f"{'yardstick: np.sort of 4 M floats':<32} {base:9.4f}"
        f"   (grow {args.count:,} = {t_big / base:.1f} yardsticks)"
    )

    summary: list[tuple[str, str, str, str, bool | None]] = []
    speedup = b_big / t_big
    summary.append(
        (
            f"ours, {args.count:,} × {big.vertices}",
            f"{t_big:.3f} s",
            f"baseline {b_big:.2f} s",
            f"≤ {TARGET_SECONDS} s",
            t_big <= TARGET_SECONDS,
        )
    )
    summary.append(
        (
            "speed-up over the baseline",
            f"{speedup:.1f}×",
            f"{b_big:.2f} / {t_big:.3f} s",
            f"≥ {TARGET_SPEEDUP:.0f}×",
            speedup >= TARGET_SPEEDUP,
        )
    )
    summary.append(
        (
            f"speed-up at {args.small:,}",
            f"{b_small / t_small:.1f}×",
            f"{b_small:.2f} / {t_small:.3f} s",
            "",
            None,
        )
    )
    if "error" in mem:
        summary.append(
            ("peak memory / output arrays", "error", "(see above)", f"≤ {TARGET_MEMORY}×", False)
        )
    else:
        grew = mem["peak"] - mem["before"]
        ratio = grew / mem["output"]
        summary.append(
            (
                "peak memory / output arrays",
                f"{ratio:.2f}×",
                f"{grew / 2**20:.0f} / {mem['output'] / 2**20:.0f} MiB",
                f"≤ {TARGET_MEMORY}×",
                ratio <= TARGET_MEMORY,
            )
        )
    if "error" not in mem_base:
        grew = mem_base["peak"] - mem_base["before"]
        summary.append(
            (
                "baseline peak / its output",
                f"{grew / mem_base['output']:.2f}×",
                f"{grew / 2**20:.0f} / {mem_base['output'] / 2**20:.0f} MiB",
                "",
                None,
            )
        )
    summary.append(
        (
            f"fibres {args.fibres:,} × 5 × {big.vertices}",
            f"{t_fib:.3f} s",
            f"{t_fib / base:.1f} yardsticks",
            f"≤ {TARGET_FIBRES} s",
            t_fib <= TARGET_FIBRES,
        )
    )
    summary.append(("yardstick", f"{base:.4f} s", f"ours = {t_big / base:.1f}×", "", None))

    for which, m in (("follicle", mem), ("baseline", mem_base)):
        if "error" in m:
            print(f"peak memory run of {which} failed: {m['error']}")
    print("\nsummary")
    print(f"{'figure':<30} {'value':>10}  {'against':<24} {'target':<10} result")
    for name, value, ref, target, ok in summary:
        verdict = "" if ok is None else ("PASS" if ok else "MISS")
        print(f"{name:<30} {value:>10}  {ref:<24} {target:<10} {verdict}")


if __name__ == "__main__":
    start = time.perf_counter()
    main()
    if "--memory-child" not in sys.argv:
        print(f"(benchmark ran {time.perf_counter() - start:.0f} s)")
