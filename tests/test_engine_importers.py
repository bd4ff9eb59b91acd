"""Our Alembic files read the way the engines' own importers read them.

Each reader here follows an importer's published source or specification, not
follicle's reader, and the expected values come from the groom itself (the skin's UV at
each root, the side of the head's parting each root is on):

- Unity: com.unity.formats.alembic (Source/abci/Importer/aiCurves.cpp reads positions,
  nVertices, widths, UVs and velocities, ``getExpandedValue``;
  Runtime/Scripts/Importer/AlembicCurvesElement.cs sizes the UV list per vertex,
  ``uvs.ResizeDiscard(positionCount)``), then com.unity.demoteam.hair
  (Editor/HairAssetBuilder.cs: ``BuildHairAssetAlembic`` takes every ``AlembicCurves``
  in the hierarchy, ``BuildStrandGroupAlembic`` joins consecutive sets whose first
  curve has as many vertices (its min/max loop drops its results) and whose features
  match, or keeps each apart with the "Preserve" setting; ``BuildStrandGroupResolved``
  resamples each strand to a uniform vertex count and reads the root UV as
  ``UVs[i * vertexCount]``).
- Unreal: FAlembicHairTranslator (Engine/Plugins/Runtime/HairStrands/Source/
  AlembicHairImporter/Private/AlembicHairTranslator.cpp): ``CanTranslate`` refuses a
  file with any PolyMesh; ``ParseObject`` appends every ICurves into one groom and reads
  ``groom_*`` arbGeomParams per strand (uniform scope); the "Alembic for Grooms"
  specification (dev.epicgames.com, using-alembic-for-grooms-in-unreal-engine): strands
  are grouped by ``groom_group_id``, guides flagged ``groom_guide`` = 1,
  ``groom_closest_guides`` names guides by ``groom_id``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from alembic3d import Abc, AbcGeom
from click.testing import CliRunner

from follicle.cli import main
from follicle.export import grow_file
from follicle.io.dispatch import save
from follicle.io.targets import GUIDE_ID_BASE, for_target
from follicle.pipeline import groom_scene
from follicle.scene import Scene

COUNT = 400
EXISTING = Abc.WrapExistingFlag.kWrapExisting


@pytest.fixture(scope="module")
def scene() -> Scene:
    s = Scene()
    return s.model_copy(update={"groom": s.groom.model_copy(update={"count": COUNT})})


@pytest.fixture(scope="module")
def groom(scene):
    return groom_scene(scene)


@pytest.fixture(scope="module")
def hair(groom):
    return groom.generate()


@pytest.fixture(scope="module")
def files(tmp_path_factory, scene) -> dict[str, Path]:
    """`follicle grow` to Alembic for Unity, Unreal and no tool (generic)."""
    folder = tmp_path_factory.mktemp("engines")
    out = {}
    for target in ("unity", "unreal", "generic"):
        out[target] = folder / f"{target}.abc"
        grow_file(scene, out[target], target=target)
    return out


def _np(values: object) -> np.ndarray:
    """An imath array (V3f, V2f, float, int) as numpy rows."""
    try:
        return np.array(memoryview(values))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return np.array([list(v) if hasattr(v, "__len__") else v for v in values])


def _preorder(obj: Abc.IObject) -> list[Abc.IObject]:
    """Every object under ``obj`` depth first, parents before children: the order of
    Unity's GetComponentsInChildren and of Unreal's ParseObject."""
    out = []
    for i in range(obj.getNumChildren()):
        child = obj.getChild(i)
        out += [child, *_preorder(child)]
    return out


def _curves(path: Path) -> list[Abc.IObject]:
    top = Abc.IArchive(str(path)).getTop()
    return [o for o in _preorder(top) if AbcGeom.ICurves.matches(o.getHeader())]


# ------------------------------------------------------------------ Unity
def _unity_curve_set(obj: Abc.IObject) -> dict[str, np.ndarray | None]:
    """An AlembicCurves component as com.unity.formats.alembic fills it: positions,
    curve offsets (it turns nVertices into offsets), widths and UVs each in a list of
    one entry a vertex, the expanded values copied to its front."""
    schema = AbcGeom.ICurves(obj, EXISTING).getSchema()
    sample = schema.getValue()
    points = _np(sample.getPositions()).reshape(-1, 3)
    counts = _np(sample.getCurvesNumVertices()).reshape(-1)
    out: dict[str, np.ndarray | None] = {
        "positions": points,
        "offsets": np.concatenate([[0], np.cumsum(counts)[:-1]]),
    }
    for key, param, width in (
        ("uvs", schema.getUVsParam(), 2),
        ("widths", schema.getWidthsParam(), 1),
    ):
        if not param.valid() or param.getNumSamples() == 0:
            out[key] = None
            continue
        values = _np(param.getExpandedValue().getVals()).reshape(-1, width)
        listed = np.zeros((len(points), width), np.float32)  # ResizeDiscard(positionCount)
        listed[: len(values)] = values[: len(points)]
        out[key] = listed
    return out


def _unity_strand_groups(path: Path, combine: bool = True) -> list[list[dict]]:
    """The hair package's strand groups: every curve set of the file in hierarchy
    order, consecutive ones joined ("Combine", its default) while their first curves'
    vertex counts and their features (UVs, widths) match."""
    groups: list[list[dict]] = []
    keys: list[tuple] = []
    for obj in _curves(path):
        s = _unity_curve_set(obj)
        counts = np.diff(np.append(s["offsets"], len(s["positions"])))
        if counts[0] < 2:
            continue  # "Skipping alembic curve set ... less than two vertices"
        key = (int(counts[0]), s["uvs"] is not None, s["widths"] is not None)
        s["name"] = obj.getFullName()
        if combine and keys and keys[-1] == key:
            groups[-1].append(s)
        else:
            groups.append([s])
            keys.append(key)
    return groups


def _unity_root_uvs(group: list[dict], n: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """(roots, root UVs) of one strand group: each strand resampled to ``n`` vertices
    evenly by length, its texcoords with it, then ``rootUV[i] = UVs[i * n]``."""
    uniform, roots = [], []
    for s in group:
        ends = np.append(s["offsets"], len(s["positions"]))
        for a, b in zip(ends[:-1], ends[1:], strict=True):
            p = s["positions"][a:b].astype(np.float64)
            length = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
            at = np.linspace(0.0, length[-1], n)
            uv = s["uvs"][a:b]
            uniform.append(np.stack([np.interp(at, length, uv[:, k]) for k in range(2)], axis=1))
            roots.append(p[0])
    texcoords = np.concatenate(uniform)
    return np.array(roots), texcoords[np.arange(len(roots)) * n]


def _skin_uv_at_roots(groom, hair, roots: np.ndarray) -> np.ndarray:
    """The skin's UV under each root (found among the hair's roots by position): the
    mesh's UVs at the root's triangle, weighted u, v, 1 − u − v."""
    mine = hair.points[hair.offsets[:-1]].astype(np.float64)
    index = {tuple(r): i for i, r in enumerate(np.round(mine, 6))}
    which = np.array([index[tuple(r)] for r in np.round(roots, 6)])
    tri = groom.mesh.faces[hair.curve_data["root_triangle"][which]]
    u, v = hair.curve_data["root_bary"][which].T
    uvs = np.asarray(groom.mesh.uvs, np.float64)[tri]
    return u[:, None] * uvs[:, 0] + v[:, None] * uvs[:, 1] + (1 - u - v)[:, None] * uvs[:, 2]


@pytest.mark.parametrize("combine", [True, False], ids=["combine", "preserve"])
def test_unity_gets_one_strand_group_per_interpolation_group_and_no_guides(files, groom, combine):
    """With "Preserve" a strand group per interpolation group; with "Combine" (the
    package's default) the two, of equal sizes, joined into one."""
    groups = _unity_strand_groups(files["unity"], combine)
    names = [s["name"] for g in groups for s in g]
    assert not [n for n in names if "Guides" in n]  # no guides taken for hair
    assert len(names) == groom.guides.groups.count == 2
    assert len(groups) == (1 if combine else 2)
    assert sum(len(s["offsets"]) for g in groups for s in g) == COUNT
    # the built-in bust's parting: one group each side of x = 0
    for group in [[s] for g in groups for s in g]:  # each curves object
        roots, _ = _unity_root_uvs(group)
        side = np.sign(roots[np.abs(roots[:, 0]) > 5e-3, 0])
        assert len(set(side.tolist())) == 1


def test_unity_hair_of_every_chunk_goes_to_its_groups_object(tmp_path, hair):
    """A stream of chunks (``Groom.chunks`` cuts at 32,768 hairs) is written one curves
    object a group, not one a chunk."""
    group = (hair.points[hair.offsets[:-1], 0] > 0).astype(np.int32)
    tagged = type(hair)(
        hair.points, hair.offsets, hair.point_data, {**hair.curve_data, "group": group}
    )
    chunks = [tagged[np.arange(0, 150)], tagged[np.arange(150, 300)], tagged[np.arange(300, COUNT)]]
    path = save(iter(chunks), tmp_path / "c.abc", target="unity")
    sets = [_unity_curve_set(o) for o in _curves(path)]
    assert [len(s["offsets"]) for s in sets] == np.bincount(group).tolist()
    for k, s in enumerate(sets):
        expected = hair.points[hair.offsets[:-1]][group == k]
        np.testing.assert_array_equal(s["positions"][s["offsets"]], expected)


def test_unity_reads_each_roots_skin_uv(files, groom, hair):
    for group in _unity_strand_groups(files["unity"]):
        roots, uv = _unity_root_uvs(group)
        np.testing.assert_allclose(uv, _skin_uv_at_roots(groom, hair, roots), atol=1e-5)


def test_one_uv_a_curve_gives_unitys_hair_package_other_hairs_uvs(files, groom, hair):
    """The layout before: UVs of uniform scope, which Unity's importer copies into the
    front of a list of one a vertex; the package then gives nearly every hair the UV
    of another (or none). (With "Combine", its default, the guides of that layout,
    24 vertices a curve as the hair, also join the hair's strand group.)"""
    assert len(_unity_strand_groups(files["generic"])[0]) == 2  # guides and hair, one group
    groups = _unity_strand_groups(files["generic"], combine=False)
    (group,) = [g for g in groups if "Hair" in g[0]["name"]]
    roots, uv = _unity_root_uvs(group)
    wrong = np.linalg.norm(uv - _skin_uv_at_roots(groom, hair, roots), axis=1) > 1e-3
    assert wrong.mean() > 0.9


def test_unity_reads_positions_in_metres_and_diameters_in_centimetres(files, hair):
    """The hair package's Alembic defaults (Runtime/HairAsset.Settings.cs:
    ``alembicScalePositions = DataInMeters``, ``alembicScaleDiameters =
    DataInCentimeters``): each vertex's width times 0.01 is the hair's width in metres,
    the positions are metres as they are."""
    mine = {tuple(r): i for i, r in enumerate(np.round(hair.points[hair.offsets[:-1]], 6))}
    for group in _unity_strand_groups(files["unity"]):
        for s in group:
            ends = np.append(s["offsets"], len(s["positions"]))
            for a, b in zip(ends[:-1], ends[1:], strict=True):
                i = mine[tuple(np.round(s["positions"][a], 6))]
                ours = slice(hair.offsets[i], hair.offsets[i + 1])
                np.testing.assert_array_equal(s["positions"][a:b], hair.points[ours])
                metres = s["widths"][a:b, 0] * np.float32(0.01)
                np.testing.assert_allclose(metres, hair.point_data["width"][ours], rtol=1e-6)


def test_unity_file_holds_what_its_importer_keeps(files):
    for obj in _curves(files["unity"]):
        schema = AbcGeom.ICurves(obj, EXISTING).getSchema()
        arb = schema.getArbGeomParams()
        assert arb is None or not arb.valid() or arb.getNumProperties() == 0
        assert schema.getUVsParam().getScope() == AbcGeom.GeometryScope.kVertexScope
        assert not schema.getNormalsParam().valid()


# ------------------------------------------------------------------ Unreal
def _unreal_can_translate(path: Path) -> bool:
    """FAlembicHairTranslator::CanTranslate: some ICurves and no PolyMesh."""
    objects = _preorder(Abc.IArchive(str(path)).getTop())
    meshes = [o for o in objects if AbcGeom.IPolyMesh.matches(o.getHeader())]
    return not meshes and any(AbcGeom.ICurves.matches(o.getHeader()) for o in objects)


def _unreal_strands(path: Path) -> dict[str, np.ndarray]:
    """Every ICurves appended into one groom, as ParseObject does: each uniform-scope
    groom_* int parameter per strand (0 where an object lacks it)."""
    out: dict[str, list[np.ndarray]] = {}
    objs = _curves(path)
    sizes = []
    for obj in objs:
        schema = AbcGeom.ICurves(obj, EXISTING).getSchema()
        n = len(_np(schema.getValue().getCurvesNumVertices()).reshape(-1))
        sizes.append(n)
        arb = schema.getArbGeomParams()
        for name in ("groom_id", "groom_group_id", "groom_guide", "groom_closest_guides"):
            if arb.getPropertyHeader(name) is None:
                out.setdefault(name, []).append(np.zeros(n, np.int64))
                continue
            param = (
                AbcGeom.IInt32GeomParam(arb, name)
                if name != "groom_closest_guides"
                else (AbcGeom.IV3iGeomParam(arb, name))
            )
            assert param.getScope() == AbcGeom.GeometryScope.kUniformScope
            values = _np(param.getExpandedValue().getVals()).reshape(n, -1)
            out.setdefault(name, []).append(values.squeeze(1) if values.shape[1] == 1 else values)
    full = {}
    for name, parts in out.items():
        if name == "groom_closest_guides":
            parts = [p if p.ndim == 2 else np.full((len(p), 3), -1) for p in parts]
        full[name] = np.concatenate(parts)
    return full


def test_unreal_takes_the_file_as_a_groom(files):
    assert _unreal_can_translate(files["unreal"])
    assert not _unreal_can_translate(files["generic"])  # it has the skin mesh


def test_unreal_ids_are_unique_between_hairs_and_guides(files, hair):
    s = _unreal_strands(files["unreal"])
    ids, guide = s["groom_id"], s["groom_guide"].astype(bool)
    assert len(np.unique(ids)) == len(ids) == COUNT + int(guide.sum())
    assert ids.min() >= 0 and ids.max() <= np.iinfo(np.int32).max
    assert sorted(ids[~guide].tolist()) == sorted(hair.curve_data["hair_id"].tolist())
    assert ids[guide].min() == GUIDE_ID_BASE


def test_unreal_groups_hairs_with_their_own_groups_guides(files, hair, groom):
    s = _unreal_strands(files["unreal"])
    guide = s["groom_guide"].astype(bool)
    group = s["groom_group_id"]
    assert set(group[~guide].tolist()) == set(group[guide].tolist()) == {0, 1}
    np.testing.assert_array_equal(np.sort(group[guide]), np.sort(groom.guides.group))
    # GroomIDToIndex within each group: each hair's closest guides are its group's guides
    for g in (0, 1):
        members = set(s["groom_id"][guide & (group == g)].tolist())
        closest = s["groom_closest_guides"][~guide & (group == g)]
        assert set(closest.reshape(-1).tolist()) <= members
    # the group is the side of the parting each root is on
    roots = {
        int(i): hair.points[hair.offsets[k], 0] for k, i in enumerate(hair.curve_data["hair_id"])
    }
    x = np.array([roots[int(i)] for i in s["groom_id"][~guide]])
    for g in (0, 1):
        side = np.sign(x[(group[~guide] == g) & (np.abs(x) > 5e-3)])
        assert len(set(side.tolist())) == 1


# ------------------------------------------------------------------ Houdini
def test_houdini_names_ids_id_and_opacity_alpha(hair):
    out = for_target(hair, "houdini")
    assert {"id", "uv", "skinprim"} <= set(out.curve_data) and "hair_id" not in out.curve_data
    np.testing.assert_array_equal(out.curve_data["id"], hair.curve_data["hair_id"])
    assert {"Cd", "Alpha"} <= set(out.point_data) and "opacity" not in out.point_data
    np.testing.assert_array_equal(out.point_data["Alpha"], hair.point_data["opacity"])


# ------------------------------------------------------------------ follicle check
def _check(path: Path, target: str) -> tuple[int, list[str]]:
    run = CliRunner().invoke(main, ["check", str(path), "--target", target])
    return run.exit_code, [x.split(": ", 1)[1] for x in run.output.splitlines()]


def test_check_says_what_unitys_importer_drops_from_a_generic_file(files):
    code, lines = _check(files["generic"], "unity")
    assert code == 1
    assert any(x.startswith("root UVs one per curve ('root_uv')") for x in lines)
    assert any(
        x.startswith("Unity's Alembic importer (com.unity.formats.alembic) keeps only points")
        and "color" in x
        for x in lines
    )
    assert any(x.startswith("guides (/Groom/Guides/GuidesShape)") for x in lines)
    assert not any("reads all of it" in x for x in lines)


def test_check_says_unity_reads_no_usd(tmp_path, hair):
    save(hair, tmp_path / "h.usda", target="unity")
    code, lines = _check(tmp_path / "h.usda", "unity")
    assert code == 1 and lines == [
        "Unity builds hair from .abc files only (Unity's hair package"
        " (com.unity.demoteam.hair), through its Alembic importer): it does not read this"
        " one; fix: `follicle export FILE -o OUT.abc --target unity`"
    ]


def test_check_says_unreal_refuses_a_file_with_a_mesh(files):
    code, lines = _check(files["generic"], "unreal")
    assert code == 1
    assert lines[-1].startswith("a mesh (Skin): Unreal's groom importer refuses an Alembic file")


def test_check_passes_each_engines_own_export_and_says_which_reader(files):
    for target in ("unity", "unreal"):
        code, lines = _check(files[target], target)
        assert code == 0 and lines == [
            f"{target.capitalize()} reads all of it ({COUNT} curves, {COUNT * 24:,} points)"
        ], lines
    code, lines = _check(files["generic"], "generic")
    assert code == 0 and lines[0].startswith("a USD or Alembic reader reads all of it")
    assert lines[0].endswith(
        "; Blender's Alembic importer keeps only points and width (`--target blender`)"
    )
    code, lines = _check(files["generic"], "blender")
    assert code == 1 and "reads all of it" not in " ".join(lines)


@pytest.mark.parametrize("ext", [".abc", ".usda"])
def test_a_houdini_file_reads_back_with_follicles_names(tmp_path, hair, ext):
    from follicle.io.dispatch import load_curves

    path = save(hair, tmp_path / f"h{ext}", target="houdini")
    back = load_curves(path)
    np.testing.assert_array_equal(back.curve_data["hair_id"], hair.curve_data["hair_id"])
    np.testing.assert_allclose(back.point_data["opacity"], hair.point_data["opacity"])
    assert "id" not in back.curve_data and "Alpha" not in back.point_data
