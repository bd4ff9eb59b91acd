"""A spiky groom, for the tests and figures of styles that hold (issue: styles that hold).

Built-in grooms hang: gravity pulls the same way as their shape. A spiked mohawk does
not: its strands rise from the top of the head against gravity and only the dynamics'
shape constraints (Almeida 2014 §3.3; TressFX's local and global shape constraints)
keep them up. :func:`spiky_guides` makes such guides on the built-in head: roots in a
band along the top of the scalp (|x| < ``half_width``, where the skin faces upwards),
each strand a straight spike of 5–15 cm (uniform) along the skin normal leaned
``lift`` of the way towards +y and tilted by a few degrees at random, with
``vertices`` points whose segment lengths vary ×0.5–2 along the strand (as an
exported asset's do; the simulator resamples them by arc length). Run as a script it
prints the figures the README quotes (:func:`hold_figures`):
``.venv/bin/python benchmarks/spiky_guides.py``.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import follicle
from follicle import HairCurves
from follicle.mesh.sampling import DensitySampler

SHORTEST, LONGEST = 0.05, 0.15  # spike lengths, m
SPREAD = 2.0  # segment lengths within a strand vary ×1/SPREAD … ×SPREAD
TILT = np.radians(8.0)  # the largest random lean of a spike off its direction
FPS = 24


def spiky_guides(
    seed: int = 0,
    mesh: object = None,
    count: int = 150,
    vertices: int = 12,
    half_width: float = 0.025,
    lift: float = 0.5,
) -> HairCurves:
    """``count`` spikes of ``vertices`` points on ``mesh`` (default: the built-in head),
    rooted in the band |x| < ``half_width`` m where the skin normal has y > 0.3 (see the
    module); the same ``seed`` gives the same guides."""
    rng = np.random.default_rng(seed)
    mesh = mesh if mesh is not None else follicle.load_mesh("builtin:head")
    tri, bary = DensitySampler(mesh).sample(40 * count, seed=seed, sequence="halton")
    at = mesh.evaluate(tri, bary)
    band = np.flatnonzero((np.abs(at.position[:, 0]) < half_width) & (at.normal[:, 1] > 0.3))
    if len(band) < count:
        raise ValueError(f"spiky_guides: only {len(band)} roots in the band; widen half_width")
    band = band[:count]
    root, normal = at.position[band], at.normal[band]
    direction = normal + lift * (np.array([0.0, 1.0, 0.0]) - normal)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    # a random lean of up to TILT: towards a random perpendicular
    side = np.cross(direction, rng.normal(size=(count, 3)))
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    lean = np.tan(rng.uniform(0.0, TILT, count))[:, None]
    direction = direction + lean * side
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    lengths = rng.uniform(SHORTEST, LONGEST, count)
    steps = np.exp(rng.uniform(-np.log(SPREAD), np.log(SPREAD), (count, vertices - 1)))
    s = np.concatenate([np.zeros((count, 1)), np.cumsum(steps, axis=1)], axis=1)
    s *= (lengths / s[:, -1])[:, None]
    points = root[:, None, :] + s[:, :, None] * direction[:, None, :]
    binding = {"root_triangle": tri[band], "root_bary": bary[band]}
    return HairCurves.from_array(points, curve_data=binding)


def rest_now(sim: follicle.Simulator) -> np.ndarray:
    """The rest pose skinned to the pose the roots are pinned to now (S, N, 3): what a
    style that holds stays near, and what global shape matching pulls towards."""
    roots, frames = sim._pinned()
    local = sim.model.rest_local.astype(np.float64)
    return roots[:, None] + np.einsum("snk,ska->sna", local, frames)


def deviation(sim: follicle.Simulator, tips: bool = False) -> float:
    """RMS distance (m) of every vertex (``tips``: of the tips only) from :func:`rest_now`."""
    d = sim.positions - rest_now(sim)
    if tips:
        d = d[:, -1:]
    return float(np.sqrt(np.mean(np.sum(d * d, axis=2))))


def _shaken(sim: follicle.Simulator, mesh: object, rest: float, after: float) -> dict:
    """``rest`` s at rest, the built-in 2 s head shake (±40°, then still), ``after`` s
    still: the figures :func:`hold_figures` reports for one groom."""
    from follicle.sim.motion import head_motion, motion_pivot

    pivot = motion_pivot(mesh, None)
    for _ in range(round(rest * FPS)):
        sim.step(1 / FPS)
    at_rest = deviation(sim)
    during, tips = [], []
    for f in range(1, 2 * FPS + 1):  # the shake ends at 0° with the head still
        sim.set_pose(head_motion("shake", f / FPS, 40.0, 2.0, pivot))
        sim.step(1 / FPS)
        during.append(deviation(sim))
        tips.append(deviation(sim, tips=True))
    settle = []
    for _ in range(round(after * FPS)):
        sim.step(1 / FPS)
        settle.append(deviation(sim))
    over = np.flatnonzero(np.array(settle) > HOLD)
    back = 0.0 if len(over) == 0 else (int(over[-1]) + 1) / FPS
    return {
        "rest": at_rest,
        "shake_peak": max(during),
        "shake_tip": float(np.sqrt(np.mean(np.square(tips)))),
        "back": math.inf if settle[-1] > HOLD else back,
        "settled": settle[-1],
    }


HOLD = 0.01  # m: the RMS deviation a style that holds stays within (issue: styles that hold)


def long_guides(mesh: object = None, every: int = 4) -> HairCurves:
    """Every ``every``-th strand of the built-in long groom (27–33 cm, hanging)."""
    mesh = mesh if mesh is not None else follicle.load_mesh("builtin:head")
    base = follicle.load_guides("builtin:long", mesh).curves
    points = base.points.reshape(base.curve_count, -1, 3)[::every]
    return HairCurves.from_array(points)


def hold_figures(
    seed: int = 0,
    count: int = 150,
    params: object = None,
    rest: float = 5.0,
    after: float = 3.0,
) -> dict[str, dict[str, float]]:
    """With ``params`` (default: the default SimParams, skin collision on), for the
    spiky groom (:func:`spiky_guides`) and the built-in long groom (every 4th strand),
    on the built-in head at 24 fps: ``rest`` — RMS deviation (m) from the rest pose
    after ``rest`` s at rest; then the built-in head shake (±40°, 2 s, ending still):
    ``shake_peak`` — the largest RMS deviation after a frame of it, ``shake_tip`` — the
    tips' RMS deviation over its frames (how far the hair swings relative to the head);
    then ``after`` s still: ``back`` — how long after the head stops the RMS deviation
    is above HOLD (1 cm) for the last time (0: never; inf: still above at the end, as
    hanging hair, which sags from its groomed pose, is), ``settled`` — the RMS at the end."""
    from follicle.groom.guides import Guides
    from follicle.sim.settings import SimParams

    mesh = follicle.load_mesh("builtin:head")
    params = params if params is not None else SimParams()
    out = {}
    for name, curves in (
        ("spiky", spiky_guides(seed, mesh, count)),
        ("long", long_guides(mesh)),
    ):
        sim = follicle.Simulator(Guides(curves, mesh), params=params)
        out[name] = _shaken(sim, mesh, rest, after)
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--count", type=int, default=150, help="spikes")
    args = parser.parse_args()
    figures = hold_figures(args.seed, args.count)
    print(f"default [sim], skin collision on, {FPS} fps, built-in head shake ±40° over 2 s")
    print(f"{'groom':<8}{'rest 5 s':>10}{'shake peak':>12}{'tip swing':>11}{'back':>8}")
    for name, f in figures.items():
        print(
            f"{name:<8}{f['rest'] * 100:>8.2f}cm{f['shake_peak'] * 100:>10.2f}cm"
            f"{f['shake_tip'] * 100:>9.2f}cm"
            + (f"{f['back']:>7.2f}s" if math.isfinite(f["back"]) else f"{'—':>8}")
        )
