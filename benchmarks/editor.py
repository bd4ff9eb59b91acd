"""Grooming-by-hand benchmark (issue "Grooming by hand"): one brush stroke over 1,000
guides, and regrowing 20,000 hairs after it, each beside the same-run yardstick
(``common.yardstick``: sorting 4 M floats) as a ratio.

Workload: 1,000 built-in "long" guides × 24 vertices on the built-in head, seen at
960×540 from the front; a stroke 160 pixels long with an 80-pixel brush (9 dabs) for
comb, smooth, puff and length, a cut across the hair, an add of 3 guides. "Warm" is
the viewer's case (the camera has not moved since the last stroke, so the skin's depth
is not drawn again); "cold" draws it. Regrowth: the groom's 20,000 hairs grown from the
edited guides at their rest shape, all of them (``Groom.follow``) and only those on
the guides a 20-pixel piece of a comb drag with a 40-pixel brush changed
(``Groom.regrow``, what the viewer does as the mouse moves).
Run: ``.venv/bin/python benchmarks/editor.py``.
"""

from __future__ import annotations

import time

import numpy as np

from common import yardstick
from follicle import Camera, GuideEditor, Guides
from follicle.groom.builtin_guides import builtin_guides
from follicle.groom.generator import Groom
from follicle.io.mesh_load import load_mesh

SIZE = (960, 540)
PATH = np.array([[400.0, 150.0], [560.0, 160.0]])
STROKES = {
    "comb": (PATH, 80.0, 0.8),
    "smooth": (PATH, 80.0, 0.8),
    "puff": (PATH, 80.0, 0.5),
    "length": (PATH, 80.0, -0.2),
    "cut": (np.array([[300.0, 420.0], [660.0, 420.0]]), 5.0, 0.5),
    "add": (np.array([[460.0, 120.0], [520.0, 120.0]]), 30.0, 0.5),
}
TARGETS = {"stroke": 0.016, "regrow": 0.050}


def mean_ms(fn, repeat: int) -> float:
    start = time.perf_counter()
    for _ in range(repeat):
        fn()
    return 1000.0 * (time.perf_counter() - start) / repeat


def main() -> None:
    mesh = load_mesh("builtin:head")
    guides = Guides(builtin_guides("long", mesh, count=1000), mesh)
    lo, hi = mesh.bounds("rest")
    centre = (lo + hi) / 2
    camera = Camera(eye=centre + np.array([0.0, 0.1, 0.8]), target=centre)
    yard = 1000.0 * yardstick()
    print(f"yardstick (sort 4 M floats): {yard:.1f} ms")
    print(f"{'stroke over 1,000 guides':<28} {'ms':>7} {'÷ yardstick':>12}  target ≤ 16 ms")
    editor = GuideEditor(guides)
    for brush, (path, radius, strength) in STROKES.items():
        editor.stroke(brush, path, camera, radius, strength, SIZE)  # compile, warm the view

        def one(b=brush, p=path, r=radius, s=strength) -> None:
            editor.stroke(b, p, camera, r, s, SIZE)
            editor.undo()

        ms = mean_ms(one, 10)
        verdict = "met" if ms <= 1000 * TARGETS["stroke"] else "missed"
        print(f"{brush + ', warm':<28} {ms:7.1f} {ms / yard:12.3f}  {verdict}")
    fresh = GuideEditor(guides)
    fresh.stroke("comb", PATH, camera, 80.0, 0.8, SIZE)
    moved = Camera(eye=camera.eye + [0.01, 0, 0], target=camera.target)
    ms = mean_ms(lambda: fresh.stroke("comb", PATH, moved, 80.0, 0.8, SIZE), 1)
    print(f"{'comb, cold (new view)':<28} {ms:7.1f} {ms / yard:12.3f}")

    groom = Groom(mesh, guides)
    before = groom.follow(fresh.points, count=20_000)  # compile
    ms = mean_ms(lambda: groom.follow(fresh.points, count=20_000), 5)
    verdict = "met" if ms <= 1000 * TARGETS["regrow"] else "missed"
    print(f"{'regrow 20,000 hairs, all':<28} {ms:7.1f} {ms / yard:12.3f}  target ≤ 50 ms {verdict}")
    # a piece of a drag: the comb moves on 20 px, the hairs on the guides it changed regrow
    piece = np.array([PATH[0], PATH[0] + [20.0, 0.0]])
    changed = fresh.stroke("comb", piece, camera, 40.0, 0.8, SIZE)
    groom.regrow(before, fresh.points, changed)  # compile
    ms = mean_ms(lambda: groom.regrow(before, fresh.points, changed), 5)
    verdict = "met" if ms <= 1000 * TARGETS["regrow"] else "missed"
    share = f"{len(changed)} of 1,000 guides changed"
    print(f"{'regrow, only changed':<28} {ms:7.1f} {ms / yard:12.3f}  ({share}) {verdict}")


if __name__ == "__main__":
    main()
