"""save_mesh: every mesh suffix it names is written as one file that reads back."""

from __future__ import annotations

import numpy as np
import pytest

import follicle
from follicle.io.mesh_save import MESH_WRITE_EXTENSIONS, save_mesh
from follicle.mesh.skin import SkinMesh


def _square() -> SkinMesh:
    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
    faces = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
    return SkinMesh(vertices, faces, uvs=vertices[:, :2].copy())


@pytest.mark.parametrize("suffix", MESH_WRITE_EXTENSIONS)
def test_save_mesh_writes_one_file_that_reads_back(tmp_path, suffix):
    # .gltf once failed: trimesh's glTF export is {file name: bytes}, not bytes
    mesh = _square()
    path = save_mesh(mesh, tmp_path / f"square{suffix}")
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"square{suffix}"]
    again = save_mesh(mesh, tmp_path / f"again{suffix}")
    assert path.read_bytes() == again.read_bytes()
    back = follicle.load_mesh(path)
    # STL keeps no shared vertices: compare the corners' positions, in any order
    corners = np.unique(
        np.round(np.asarray(back.rest_vertices)[back.faces].reshape(-1, 3), 6), axis=0
    )
    np.testing.assert_allclose(corners, np.unique(mesh.rest_vertices, axis=0), atol=1e-6)
    assert len(back.faces) == len(mesh.faces)
