"""save_mesh: every mesh suffix it names is written as one file that reads back; and the
mesh registries agree: every suffix written as a mesh reads back through MESH_READERS."""

from __future__ import annotations

import numpy as np
import pytest

import follicle
from follicle.io.dispatch import MESH_READERS, MESH_WRITERS
from follicle.io.mesh_load import MESH_EXTENSIONS
from follicle.io.mesh_save import MESH_WRITE_EXTENSIONS, save_mesh
from follicle.mesh.skin import SkinMesh


def _square() -> SkinMesh:
    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
    faces = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
    return SkinMesh(vertices, faces, uvs=vertices[:, :2].copy())


def _corners(mesh: SkinMesh) -> np.ndarray:
    """The distinct positions of ``mesh``'s triangle corners, sorted: STL keeps no shared
    vertices, so positions are compared, in any order."""
    return np.unique(np.round(mesh.rest_vertices[mesh.faces].reshape(-1, 3), 6), axis=0)


@pytest.mark.parametrize("suffix", MESH_WRITE_EXTENSIONS)
def test_save_mesh_writes_one_file_that_reads_back(tmp_path, suffix):
    # .gltf once failed: trimesh's glTF export is {file name: bytes}, not bytes
    mesh = _square()
    path = save_mesh(mesh, tmp_path / f"square{suffix}")
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"square{suffix}"]
    again = save_mesh(mesh, tmp_path / f"again{suffix}")
    assert path.read_bytes() == again.read_bytes()
    back = follicle.load_mesh(path)
    np.testing.assert_allclose(_corners(back), np.unique(mesh.rest_vertices, axis=0), atol=1e-6)
    assert len(back.faces) == len(mesh.faces)


def test_the_mesh_readers_are_the_suffixes_load_mesh_names_and_the_writers_have():
    """load_mesh names the table's suffixes (in its errors too), and what a skin can be
    written as it can be read from."""
    assert MESH_EXTENSIONS == tuple(MESH_READERS)
    assert MESH_EXTENSIONS == (
        *(".obj", ".ply", ".glb", ".gltf", ".stl", ".off"),
        *(".abc", ".usd", ".usda", ".usdc", ".usdz"),
    )
    assert set(MESH_READERS) == set(MESH_WRITERS)


@pytest.mark.parametrize("suffix", sorted(MESH_WRITERS))
def test_each_mesh_writer_reads_back_through_its_reader(tmp_path, suffix):
    """What MESH_WRITERS writes for a suffix, MESH_READERS's entry for it reads back: the
    same vertices (STL's unshared: 3 a triangle) and corners, in metres and times
    ``mpu``."""
    mesh = _square()
    path = MESH_WRITERS[suffix](mesh, tmp_path / f"square{suffix}", "generic")
    for mpu in (1.0, 0.01):
        back = MESH_READERS[suffix](path, mpu)
        assert back.vertex_count == (6 if suffix == ".stl" else mesh.vertex_count)
        assert len(back.faces) == len(mesh.faces)
        np.testing.assert_allclose(
            _corners(back), np.unique(mesh.rest_vertices * mpu, axis=0), atol=1e-6
        )
