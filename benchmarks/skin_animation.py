"""Skin-animation benchmark: what a frame costs when an animated skin drives the roots.

`follicle simulate --skin-animation` poses the skin by its vertices every frame
(``Simulator.set_pose(vertices=…)``): the roots are re-evaluated on the deformed
triangles and the skin SDF follows the deformation, moved rigidly while the skin fits a
rigid motion within ``SDF_REUSE`` voxels and rebuilt otherwise. The workload is the
default scene (the built-in head and its guides) at 24 frames/s, each frame a pose and
one ``step(1/24)``; the rows are the same yaw swing given as a rigid transform (the
baseline: the SDF is only moved), as vertices that turn rigidly, and as vertices that
also squash 5 % (a rebuild every frame). Each row is printed next to the baseline
measured in the same run. Run: ``.venv/bin/python benchmarks/skin_animation.py``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from follicle import Simulator
from follicle.pipeline import groom_scene
from follicle.scene import Scene

FPS = 24


def _turn(t: float, low: float) -> np.ndarray:
    """The yaw swing about the neck (at height ``low``) at ``t`` s, a 4×4 transform."""
    a = 0.35 * np.sin(2 * np.pi * t)
    c, s = np.cos(a), np.sin(a)
    m = np.eye(4)
    m[:3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    m[:3, 3] = [0, low, 0] - m[:3, :3] @ [0, low, 0]
    return m


def _poses(rest: np.ndarray, frames: int, squash: float) -> list[np.ndarray]:
    """Vertices per frame: the swing, and a vertical squash of ``squash`` (non-rigid)."""
    low = float(rest.min(axis=0)[1])
    out = []
    for f in range(1, frames + 1):
        m = _turn(f / FPS, low)
        p = rest @ m[:3, :3].T + m[:3, 3]
        p[:, 1] = low + (p[:, 1] - low) * (1 + squash * np.sin(4 * np.pi * f / FPS))
        out.append(p)
    return out


def _run(pose, frames: int) -> float:
    """Seconds per frame: ``pose(sim, f)`` then one step, after a warm-up frame."""
    groom = groom_scene(Scene())
    sim = Simulator(groom.guides, mesh=groom.mesh)
    pose(sim, 1)
    sim.step(1 / FPS)  # compiles
    start = time.perf_counter()
    for f in range(2, frames + 2):
        pose(sim, f)
        sim.step(1 / FPS)
    return (time.perf_counter() - start) / frames


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    rest = groom_scene(Scene()).mesh.rest_vertices
    low = float(rest.min(axis=0)[1])
    frames = args.frames + 2
    rigid, squashed = _poses(rest, frames, 0.0), _poses(rest, frames, 0.05)
    rows = {
        "transform (baseline)": lambda sim, f: sim.set_pose(transform=_turn(f / FPS, low)),
        "vertices, rigid": lambda sim, f: sim.set_pose(vertices=rigid[f - 1]),
        "vertices, deforming": lambda sim, f: sim.set_pose(vertices=squashed[f - 1]),
    }
    times = {name: [] for name in rows}
    for _ in range(args.repeat):  # interleaved: the machine's noise falls on every row
        for name, pose in rows.items():
            times[name].append(_run(pose, args.frames))
    base = statistics.median(times["transform (baseline)"])
    print(
        f"skin animation, default scene, {args.frames} frames at {FPS} fps"
        f" (median of {args.repeat})"
    )
    for name, t in times.items():
        t = statistics.median(t)
        print(
            f"  {name:22s} {1e3 * t:7.1f} ms/frame  {1 / t:6.1f} frames/s  ×{t / base:.2f} baseline"
        )


if __name__ == "__main__":
    main()
