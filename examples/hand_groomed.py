"""A short groom made by hand with the brushes: combed back, parted, a fringe cut.

    .venv/bin/python examples/hand_groomed.py [LOG]

writes the stroke log ``examples/hand_groomed.strokes.json`` (or ``LOG``): 23 strokes
of :class:`follicle.GuideEditor` on the built-in short guides on the built-in bust, as
an artist would make them with the mouse in ``follicle view`` — here written as paths
over the head, projected to the pixels of a 960 × 540 view through the camera each
stroke is drawn from, so the groom can be read and changed as code. ``follicle groom``
replays the log headless (``examples/make_assets.py`` does, into ``examples/assets/``) and
``examples/hand_groomed.toml`` grows and renders the result:

1. **comb back**: from each side, strokes following the skull from the brow over the
   crown, and over the temples to behind the ears;
2. **part**: a line from the hairline to the crown over the left eye (x = 3.5 cm), seen
   from above — the brush combs the guides away from it and paints two interpolation
   groups, one a side, so no hair crosses it (Šik 2012 §2.2.4);
3. **fringe**: guides added along the front hairline; from high in front, the guides
   right of the parting combed forward and down over the forehead (and the right temple
   combed back again where they caught it), lengthened, then cut straight across at the
   brow.

The same script gives the same log, byte for byte, and the same log the same guides.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from follicle import Camera, GuideEditor
from follicle.groom.guides import load_guides
from follicle.io.mesh_load import load_mesh

HERE = Path(__file__).resolve().parent
LOG = HERE / "hand_groomed.strokes.json"
MESH, GUIDES = "builtin:bust", "builtin:short"
SIZE = (960, 540)  # the viewport the strokes are drawn in, pixels

# where each stroke is drawn from (metres; the head's crown is at y = 0.12, its brow
# at y = 0.03, its face towards +z)
RIGHT_SIDE = Camera(eye=[0.9, 0.1, 0.1], target=[0.0, 0.03, 0.0], fov_y=30)
LEFT_SIDE = Camera(eye=[-0.9, 0.1, 0.1], target=[0.0, 0.03, 0.0], fov_y=30)
ABOVE = Camera(eye=[0.0, 0.9, 0.15], target=[0.0, 0.05, 0.0], fov_y=30)
HIGH_FRONT = Camera(eye=[0.0, 0.6, 0.6], target=[0.0, 0.05, 0.0], fov_y=30)
FRONT = Camera(eye=[0.0, 0.2, 0.85], target=[0.0, 0.04, 0.0], fov_y=30)


def pixels(camera: Camera, points: list[list[float]]) -> list[list[float]]:
    """World points (metres) as the pixels of SIZE they are seen at, to 0.1 px."""
    xy, _ = camera.project(np.asarray(points, np.float64), SIZE)
    return np.round(xy, 1).tolist()


def groom(editor: GuideEditor) -> None:
    """The strokes, in order."""

    def stroke(brush, camera, points, radius, strength=0.5):
        editor.stroke(brush, pixels(camera, points), camera, radius, strength, SIZE)

    # 1. comb back: over the top along the skull's profile, then the sides
    for side, camera in ((1.0, RIGHT_SIDE), (-1.0, LEFT_SIDE)):
        for r in (0.105, 0.095):
            angles = np.radians([45, 70, 90, 115, 140, 170])
            profile = [[0.0, 0.03 + r * np.sin(a), r * np.cos(a)] for a in angles]
            stroke("comb", camera, profile, 26, 0.6)
        for y in (0.06, 0.02):
            temple = [[side * 0.09, y, 0.06], [side * 0.09, y - 0.01, -0.02]]
            stroke("comb", camera, [*temple, [side * 0.09, y - 0.03, -0.08]], 28, 0.6)
    # 2. a side parting over the left eye, from the hairline to the crown
    stroke("part", ABOVE, [[0.035, 0.095, 0.06], [0.035, 0.12, -0.04]], 24, 1.0)
    # 3. the fringe: guides added along the front hairline (the bust's hairs rooted
    # below the built-in guides' lowest roots would take their shape turned down the
    # forehead, ending 2 cm below the cut), combed forward and down over the forehead,
    # the right temple combed back again (the fringe's first strokes catch its front),
    # lengthened low and high (the guides rooted high reach the brow too), cut at the brow
    editor.stroke("add", pixels(FRONT, [[-0.05, 0.086, 0.08], [0.025, 0.086, 0.08]]), FRONT, 15)
    for x in np.linspace(-0.055, 0.025, 9):
        down = [[x, 0.115, 0.0], [x, 0.1, 0.06], [x, 0.07, 0.1], [x, 0.03, 0.13]]
        stroke("comb", HIGH_FRONT, down, 18, 1.0)
    temple = [[-0.09, 0.06, 0.03], [-0.09, 0.05, -0.02], [-0.09, 0.03, -0.08]]
    stroke("comb", LEFT_SIDE, temple, 22, 0.6)
    for y, strength in ((0.06, 0.6), (0.08, 0.3)):
        stroke("length", FRONT, [[-0.06, y, 0.1], [0.03, y, 0.1]], 30, strength)
    editor.stroke("cut", pixels(FRONT, [[-0.06, 0.035, 0.1], [0.04, 0.035, 0.1]]), FRONT, 10)


def main(out: Path = LOG) -> Path:
    editor = GuideEditor(load_guides(GUIDES, load_mesh(MESH)))
    groom(editor)
    return editor.save_strokes(out, mesh=MESH, guides=GUIDES)


if __name__ == "__main__":
    print(main(Path(sys.argv[1]) if len(sys.argv) > 1 else LOG))
