"""Make docs/own_mesh_fur.png (how-to/own-mesh.md): fur grown on a torus from no guides.

Left, the scene with only ``[mesh]`` (and a count): the guides it gets, generated along
the normals, 8 % of the torus's diagonal long. Right, the same torus with
``[guides] generate = "comb"``: combed along +X, lifted 25°, bent by gravity 0.6.
Both with 30,000 hairs, the CPU engine, the same camera.

Run from the repository root: ``.venv/bin/python docs/make_own_mesh.py``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image

from follicle.pipeline import grow
from follicle.render import render_image
from follicle.render.camera import fit_camera
from follicle.scene import load_scene

ROOT = Path(__file__).resolve().parent
SIZE = (420, 360)
SCENES = {
    "normal": "",
    "comb": '[guides]\ngenerate = "comb"\ncomb = [1.0, 0.0, 0.0]\nlift = 25.0\n'
    "gravity = 0.6\nlength = 0.35\n",
}


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        torus = trimesh.creation.torus(1.0, 0.3, major_sections=64, minor_sections=32)
        torus.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
        torus.export(folder / "torus.obj")  # lying flat: its hole looks up (+Y)
        panels = []
        camera = None
        for name, guides in SCENES.items():
            (folder / f"{name}.toml").write_text(
                f'[mesh]\npath = "torus.obj"\n{guides}[groom]\ncount = 30000\n'
                "root_color = [0.05, 0.03, 0.02]\ntip_color = [0.35, 0.22, 0.12]\n"
                "root_width = 0.004\ntip_width = 0.001\n"
            )
            mesh, curves = grow(load_scene(folder / f"{name}.toml"))
            if camera is None:  # framed on the first: the same view for both
                camera = fit_camera(curves.points[::7], direction=(0.0, 0.8, 1.0), aspect=1.17)
            image = render_image(curves, mesh=mesh, camera=camera, size=SIZE, engine="cpu")
            panels.append(Image.fromarray(image).convert("RGB"))
        out = Image.new("RGB", (SIZE[0] * 2, SIZE[1]))
        for i, panel in enumerate(panels):
            out.paste(panel, (i * SIZE[0], 0))
        out.save(ROOT / "own_mesh_fur.png", optimize=True)


if __name__ == "__main__":
    main()
