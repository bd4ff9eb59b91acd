"""Make docs/cards_atlas.png and docs/cards_lods.png (how-to/cards.md): the demo's groom
(20,000 long hairs on the bust, settled) made into hair cards with the defaults (2,000
/ 600 / 150 cards, 2048² atlas), its atlas, and the cards of each level rendered by
Blender (its glTF importer, Cycles: ``tests/blender_scripts/render_cards.py``) beside
follicle's strand render through the same camera.

Run from the repository root with Blender's Python in FOLLICLE_BLENDER_PYTHON (or
.venv-blender, made by the Blender tests): ``.venv/bin/python docs/make_cards.py``.
"""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from follicle.cards import make_cards, write_cards
from follicle.cli import _DEMO_SETTLE
from follicle.pipeline import grow
from follicle.render.camera import fit_camera
from follicle.render.cpu import CpuRenderer
from follicle.render.image import encode_srgb8, srgb_to_linear
from follicle.scene import parse_scene

ROOT = Path(__file__).resolve().parent.parent
SIZE = 360
BACKGROUND = (0.24, 0.29, 0.36)  # sRGB of the pictures' backdrop


def _over(image: Image.Image) -> Image.Image:
    """An RGBA picture over the backdrop."""
    back = Image.new("RGBA", image.size, tuple(int(255 * c) for c in BACKGROUND) + (255,))
    return Image.alpha_composite(back, image.convert("RGBA")).convert("RGB")


def main() -> None:
    scene = parse_scene({"groom": {"count": 20_000, "settle": _DEMO_SETTLE}}, "docs")
    mesh, curves = grow(scene)
    made = make_cards(curves, mesh)
    python = os.environ.get("FOLLICLE_BLENDER_PYTHON", str(ROOT / ".venv-blender/bin/python"))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        glb = write_cards(made, folder / "hair_cards.glb")
        camera = fit_camera(curves.points[::10], direction=(0.35, 0.15, 1.0))
        views = [
            {
                "name": f"lod{lod}",
                "lod": lod,
                "eye": camera.eye.tolist(),
                "target": camera.target.tolist(),
                "up": camera.up.tolist(),
                "fov_y": camera.fov_y,
                "size": SIZE,
            }
            for lod in range(3)
        ]
        (folder / "views.json").write_text(json.dumps(views))
        script = ROOT / "tests/blender_scripts/render_cards.py"
        args = [glb, folder / "views.json", folder, folder / "found.json"]
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        subprocess.run([python, str(script), *map(str, args)], check=True, env=env)
        found = json.loads((folder / "found.json").read_text())
        lods = [_over(Image.open(found["renders"][f"lod{lod}"])) for lod in range(3)]
    linear = tuple(float(c) for c in srgb_to_linear(np.array(BACKGROUND)))
    strands = CpuRenderer((SIZE, SIZE), background=linear).draw(curves, None, camera)
    row = [Image.fromarray(strands[..., :3]), *lods]
    picture = Image.new("RGB", (SIZE * 4, SIZE))
    for i, image in enumerate(row):
        picture.paste(image, (i * SIZE, 0))
    picture.save(ROOT / "docs/cards_lods.png", optimize=True)

    cov = made.maps["coverage"]
    rgb = encode_srgb8(np.concatenate([made.maps["color"], np.ones_like(cov)[..., None]], axis=2))
    rgba = np.concatenate([rgb[..., :3], np.round(cov * 255).astype(np.uint8)[..., None]], axis=2)
    atlas = _over(Image.fromarray(rgba))
    side = 720
    whole = atlas.resize((side, side), Image.Resampling.LANCZOS)
    x, y, w, h = made.rects[0][0]  # a close look at the first card of LOD 0 and its row
    crop = atlas.crop((0, max(y - 8, 0), side // 3, max(y - 8, 0) + side // 3))
    out = Image.new("RGB", (2 * side, side))
    out.paste(whole, (0, 0))
    out.paste(crop.resize((side, side), Image.Resampling.NEAREST), (side, 0))
    out.save(ROOT / "docs/cards_atlas.png", optimize=True)


if __name__ == "__main__":
    main()
