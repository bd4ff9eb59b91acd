"""The public surface: ``import follicle`` and the names its stub lists, the render
package apart from the render function, and the format registry's lazy entries."""

from __future__ import annotations

import ast
import inspect
import warnings
from pathlib import Path

import numpy as np
import pytest

import follicle
from follicle.errors import FormatError, InputError
from follicle.io import dispatch
from imports import HEAVY, modules_after

STUB = Path(follicle.__file__).with_suffix(".pyi")


def test_saving_and_reading_npz_loads_no_usd_alembic_or_numba(tmp_path):
    """The registry imports a format's module when a file of it is written or read:
    .npz through follicle.save and load_curves needs numpy alone."""
    path = tmp_path / "h.npz"
    code = (
        "import numpy as np, follicle\n"
        "c = follicle.HairCurves(np.zeros((6, 3), np.float32), np.array([0, 3, 6]))\n"
        f"follicle.save(c, {str(path)!r})\n"
        f"assert follicle.load_curves({str(path)!r}).curve_count == 2\n"
    )
    assert modules_after(code, (*HEAVY, "trimesh", "scipy")) == []
    assert path.is_file()


def test_every_name_of_the_stub_is_served_and_nothing_else():
    """``__init__.pyi`` is the one list: each name it imports resolves to that module's
    object, ``dir(follicle)`` shows exactly them, and ``__all__`` leaves out the render
    and cards packages (modules, reached as follicle.render and follicle.cards)."""
    listed = {}
    for node in ast.parse(STUB.read_text("utf-8")).body:
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                listed[alias.asname] = node.module
    assert len(listed) > 25 and listed["render_image"] == "render.backends"
    assert sorted(dir(follicle)) == sorted(listed)
    assert set(follicle.__all__) == set(listed) - {"render", "cards"}
    for name, module in listed.items():
        if module is None:
            continue
        owner = __import__(f"follicle.{module}", fromlist=[name])
        assert getattr(follicle, name) is getattr(owner, name), name
    with pytest.raises(AttributeError, match="no attribute 'rendr'"):
        follicle.rendr  # noqa: B018


def test_render_is_the_package_and_calling_it_is_deprecated():
    """``follicle.render`` is the package (its names reachable without an import of their
    own); calling it still reaches render_image, with a DeprecationWarning naming it."""
    import follicle.render
    from follicle.render.opengl import Renderer

    assert follicle.render.Renderer is Renderer
    assert follicle.render.render_image is follicle.render_image
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(InputError):
            follicle.render(np.zeros((4, 3)))  # render_image's own check: not HairCurves
    assert [w.category for w in caught] == [DeprecationWarning]
    assert "follicle.render_image" in str(caught[0].message)
    assert caught[0].filename == __file__  # attributed to the caller


def _parameters(table: dispatch.Registry) -> dict[str, list[str]]:
    """Each entry of ``table`` imported: its parameters' names, by suffix."""
    return {s: list(inspect.signature(table[s]).parameters) for s in table}


def test_each_registry_entry_takes_its_table_parameters():
    """Every ``"module:function"`` entry imports and takes its table's parameters in the
    same places, so any entry is called the same way: hair writers (hair, path,
    **options), readers (path), mesh writers (mesh, path, target), mesh readers (path,
    mpu), and the two cache writers one signature."""
    for suffix, names in _parameters(dispatch.WRITERS).items():
        assert names[1] == "path" and names[0] in ("curves", "chunks"), (suffix, names)
    assert {s: names[0] for s, names in _parameters(dispatch.READERS).items()} == dict.fromkeys(
        dispatch.READERS, "path"
    )
    mesh = _parameters(dispatch.MESH_WRITERS)
    assert mesh == dict.fromkeys(dispatch.MESH_WRITERS, ["mesh", "path", "target"])
    mesh = _parameters(dispatch.MESH_READERS)
    assert mesh == dict.fromkeys(dispatch.MESH_READERS, ["path", "mpu"])
    caches = _parameters(dispatch.CACHE_WRITERS)
    assert set(caches) == {".usd", ".usda", ".usdc", ".usdz", ".abc"}
    assert len({tuple(names) for names in caches.values()}) == 1
    assert caches[".abc"][:2] == ["frames", "path"] and "target" in caches[".abc"]


def test_a_suffix_no_table_has_is_refused_with_the_suffixes_it_has(tmp_path):
    hair = follicle.HairCurves(np.zeros((2, 3), np.float32), np.array([0, 2]))
    with pytest.raises(FormatError, match=r"x\.fbx: cannot write '\.fbx' files; use \.npz, "):
        follicle.save(hair, tmp_path / "x.fbx")
    with pytest.raises(FormatError, match=r"cannot write a mesh as '\.txt' files; use .*\.glb"):
        dispatch.MESH_WRITERS.for_path(tmp_path / "m.txt")
    with pytest.raises(FormatError, match="no extension"):
        follicle.load_curves(tmp_path / "noext")
