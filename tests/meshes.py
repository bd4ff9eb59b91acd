"""Small meshes shared by the tests."""

from __future__ import annotations

import numpy as np

from follicle.mesh.skin import SkinMesh


def plane(cells: int = 8) -> SkinMesh:
    """The unit square in the XZ plane facing +Y, UV = (x, z), cells×cells quads."""
    g = np.linspace(0.0, 1.0, cells + 1)
    x, z = np.meshgrid(g, g)
    verts = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], axis=1)
    row = cells + 1
    q = [i * row + j for i in range(cells) for j in range(cells)]
    faces = [f for a in q for f in ([a, a + row, a + 1], [a + 1, a + row, a + row + 1])]
    return SkinMesh(verts, faces, uvs=verts[:, [0, 2]], name="plane")
