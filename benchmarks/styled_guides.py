"""A production-like styled groom read from a centimetre file, for the tests and figures of
styled hair that holds (issue 41).

:mod:`benchmarks.spiky_guides` makes a tidy mohawk: every spike rises steeply from the
top of the head, in metres, with one vertex count. A groom from a DCC is less kind, and
its hardest strands are the ones that barely rise: :func:`styled_guides` makes, on the
built-in head (+y up, the face towards +z), ``count`` strands in three groups
(:data:`GROUPS`): ``top`` — spikes of 6–15 cm from the top of the head, 45–80° above
level, leaning back; ``front`` — 5–10 cm from the hairline, swept back 15–35° above
level; ``back`` — 5–12 cm from the back of the head, sticking straight out backwards,
0–5° above level. Each strand has 6–24 vertices, segment lengths ×1/3–3 of each other
(log-uniform) and 2 % of its vertices put on their predecessor (coincident, as a
tool's duplicated point). :func:`load_centimetres` writes the head and the groom in
centimetres (an OBJ and a cyHair file) and reads them back with ``units = "cm"``, as a
production file is read. The rise of a strand is its tip's height above its root
against gravity (:func:`rise`); :func:`rise_change` is the groom's rise after a time
under gravity over its rise at rest. Run as a script it prints the figures the README
quotes: ``.venv/bin/python benchmarks/styled_guides.py``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh

import follicle
from follicle import HairCurves
from follicle.io.cyhair import save_cyhair
from follicle.mesh.sampling import DensitySampler

# group: (length range m, elevation range degrees above level); the direction leans back (−z)
GROUPS = {
    "top": ((0.06, 0.15), (45.0, 80.0)),
    "front": ((0.05, 0.10), (15.0, 35.0)),
    "back": ((0.05, 0.12), (0.0, 5.0)),
}
FEWEST, MOST = 6, 24  # vertices per strand
SPREAD = 3.0  # segment lengths within a strand vary ×1/SPREAD … ×SPREAD
COINCIDENT = 0.02  # share of vertices put on their predecessor
FPS = 24


def _roots(
    mesh: follicle.SkinMesh, seed: int, count: int, names: tuple[str, ...]
) -> dict[str, np.ndarray]:
    """Each group's root positions: ``top`` where the skin faces up (normal y > 0.8),
    ``front`` on the upper forehead (z > 0.06, y > 0.05), ``back`` on the back of the
    head (z < −0.07, −0.03 < y < 0.06)."""
    tri, bary = DensitySampler(mesh).sample(60 * count, seed=seed, sequence="halton")
    at = mesh.evaluate(tri, bary)
    p, n = at.position, at.normal
    where = {
        "top": n[:, 1] > 0.8,
        "front": (p[:, 2] > 0.06) & (p[:, 1] > 0.05) & (n[:, 1] < 0.8),
        "back": (p[:, 2] < -0.07) & (p[:, 1] > -0.03) & (p[:, 1] < 0.06),
    }
    share = count // len(names)
    out = {}
    for name in names:
        chosen = np.flatnonzero(where[name])[:share]
        if len(chosen) < share:
            raise ValueError(f"styled_guides: only {len(chosen)} {name} roots; lower count")
        out[name] = p[chosen]
    return out


def styled_guides(
    seed: int = 0,
    mesh: follicle.SkinMesh | None = None,
    count: int = 120,
    groups: dict[str, tuple[tuple[float, float], tuple[float, float]]] = GROUPS,
) -> tuple[HairCurves, np.ndarray]:
    """The styled groom of the module (metres) and each strand's group (its index in
    ``groups``: name → (length range m, elevation range degrees), names from GROUPS);
    the same ``seed`` gives the same groom."""
    rng = np.random.default_rng(seed)
    mesh = mesh if mesh is not None else follicle.load_mesh("builtin:head")
    strands, group = [], []
    for g, (name, roots) in enumerate(_roots(mesh, seed, count, tuple(groups)).items()):
        (short, long), (low, high) = groups[name]
        for root in roots:
            up = np.radians(rng.uniform(low, high))
            side = np.radians(rng.uniform(-20.0, 20.0))  # spread left and right
            direction = np.array(
                [np.cos(up) * np.sin(side), np.sin(up), -np.cos(up) * np.cos(side)]
            )
            n = int(rng.integers(FEWEST, MOST + 1))
            steps = np.exp(rng.uniform(-np.log(SPREAD), np.log(SPREAD), n - 1))
            s = np.concatenate([[0.0], np.cumsum(steps)])
            s *= rng.uniform(short, long) / s[-1]
            points = root + s[:, None] * direction
            for i in np.flatnonzero(rng.random(n - 1) < COINCIDENT) + 1:
                points[i] = points[i - 1]
            strands.append(points)
            group.append(g)
    return HairCurves.from_polylines(strands), np.array(group)


def load_centimetres(curves: HairCurves, mesh: follicle.SkinMesh, folder: Path) -> follicle.Guides:
    """``curves`` on ``mesh`` written in centimetres (``head.obj``, ``styled.hair`` in
    ``folder``) and read back with units = "cm", as a production groom is read."""
    obj = Path(folder) / "head.obj"
    trimesh.Trimesh(mesh.rest_vertices * 100.0, mesh.faces, process=False).export(obj)
    cm = HairCurves(curves.points.astype(np.float64) * 100.0, curves.offsets)
    hair = save_cyhair(iter([cm]), Path(folder) / "styled.hair")
    return follicle.load_guides(str(hair), follicle.load_mesh(str(obj), units="cm"), units="cm")


def rise(sim: follicle.Simulator) -> np.ndarray:
    """Each strand's rise (m): its tip's height above its root against gravity."""
    g = np.asarray(sim.params.gravity, np.float64)
    up = -g / np.linalg.norm(g)
    x = sim.positions.astype(np.float64)
    return (x[:, -1] - x[:, 0]) @ up


def rise_change(sim: follicle.Simulator, seconds: float = 2.0) -> np.ndarray:
    """Each strand's rise after ``seconds`` at rest under gravity (24 fps steps, the head
    still) minus its rise at rest, over its length: what it lost, as a share of its
    length (0: kept, negative: sank). ``sim`` is stepped."""
    before = rise(sim)
    length = sim.model.rest_length.astype(np.float64).sum(axis=1)
    for _ in range(round(seconds * FPS)):
        sim.step(1 / FPS)
    return (rise(sim) - before) / length


def figures(
    params: object = None, seed: int = 0, count: int = 120, folder: Path | None = None
) -> dict[str, float]:
    """With ``params`` (default SimParams, skin on), the styled groom read in centimetres
    after 2 s at rest: ``kept`` — the groom's summed rise over its rise at rest (every
    strand rises at rest, the back spikes barely), ``kept_<group>`` — the same per group;
    ``back`` — the back spikes' mean drop, as a share of their length; and, for the
    built-in long groom (every 4th strand, hanging) through the built-in 2 s head
    shake, ``long_tip`` — its tips' RMS swing relative to the head."""
    import tempfile

    from benchmarks.spiky_guides import _shaken, long_guides
    from follicle.groom.guides import Guides
    from follicle.sim.settings import SimParams

    params = params if params is not None else SimParams()
    mesh = follicle.load_mesh("builtin:head")
    curves, group = styled_guides(seed, mesh, count)
    with tempfile.TemporaryDirectory() as tmp:
        guides = load_centimetres(curves, mesh, Path(folder or tmp))
    sim = follicle.Simulator(guides, params=params)
    start = rise(sim)
    lost = rise_change(sim)
    now = rise(sim)
    out = {"kept": float(now.sum() / start.sum()), "back": float(-lost[group == 2].mean())}
    for g, name in enumerate(GROUPS):
        out[f"kept_{name}"] = float(now[group == g].sum() / start[group == g].sum())
    long = follicle.Simulator(Guides(long_guides(mesh), mesh), params=params)
    out["long_tip"] = _shaken(long, mesh, 0.0, 0.5)["shake_tip"]
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--count", type=int, default=120, help="strands")
    args = parser.parse_args()
    f = figures(seed=args.seed, count=args.count)
    print("default [sim], skin on, 2 s at rest under gravity (24 fps)")
    print(f"the groom keeps {f['kept']:.2f} of its rise", end="")
    print(" (" + ", ".join(f"{g} {f['kept_' + g]:.2f}" for g in GROUPS) + ")")
    print(f"back spikes drop {f['back']:.2f} of their length")
    print(f"long groom tips swing {f['long_tip'] * 100:.1f} cm RMS through the head shake")
