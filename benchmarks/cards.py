"""Hair cards of the demo's groom (issue: hair cards, target ≤ 30 s and ≤ 2 GB): the
20,000 long hairs on the built-in bust, settled as ``follicle demo`` grows them, made
into 3 levels of detail (2,000 / 600 / 150 cards) with a 2048² atlas.

In this process: the seconds of growing the groom (the yardstick, measured in the same
run) and of making and writing its cards, and their ratio. In a fresh process, as a
user runs it: ``follicle cards SCENE -o hair_cards.glb --lods 3 --atlas 2048`` (growing
included) with its peak resident memory. Run alone, once (the machine is shared):
``.venv/bin/python benchmarks/cards.py``.
"""

from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from follicle.cards import CardParams, make_cards, write_cards
from follicle.cli import _DEMO_SETTLE
from follicle.pipeline import grow
from follicle.scene import load_scene

SCENE = f"""[guides]
path = "builtin:long"
[groom]
count = 20000
settle = {_DEMO_SETTLE}
"""


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "scene.toml").write_text(SCENE)
        scene = load_scene(folder / "scene.toml")
        grow(scene.replace(groom=scene.groom.replace(count=500)))  # numba, caches

        start = time.perf_counter()
        mesh, curves = grow(scene)
        grown = time.perf_counter() - start
        start = time.perf_counter()
        made = make_cards(curves, mesh, CardParams(lods=3, atlas=2048))
        write_cards(made, folder / "in_process.glb")
        carded = time.perf_counter() - start

        start = time.perf_counter()
        args = ["cards", "scene.toml", "-o", "hair_cards.glb", "--lods", "3", "--atlas", "2048"]
        subprocess.run([sys.executable, "-m", "follicle.cli", *args], cwd=folder, check=True)
        command = time.perf_counter() - start
        peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # KiB → MiB
        size = (folder / "hair_cards.glb").stat().st_size / 2**20
        same = (folder / "hair_cards.glb").read_bytes() == (folder / "in_process.glb").read_bytes()

    cards = " / ".join(str(len(r)) for r in made.rects)
    print(f"{curves.curve_count:,} hairs, {cards} cards, 2048² atlas")
    print(f"grow (yardstick)    {grown:6.2f} s")
    print(f"cards (make, write) {carded:6.2f} s  = {carded / grown:.2f} × grow")
    print(f"follicle cards      {command:6.2f} s  (a fresh process, growing included)")
    print(f"peak memory         {peak:6.0f} MiB (the follicle cards process)")
    print(f"hair_cards.glb      {size:6.1f} MiB, same bytes as in process: {same}")


if __name__ == "__main__":
    main()
