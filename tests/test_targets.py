"""Targets: each tool's names, types, units and curve sizes applied before writing, and
`follicle check` listing what a tool would drop or refuse."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from follicle.cli import main
from follicle.curves import HairCurves
from follicle.errors import FormatError, InputError
from follicle.io.dispatch import save
from follicle.io.targets import (
    GUIDE_ID_BASE,
    MAX_UNREAL_POINTS,
    TARGET_NAMES,
    for_target,
    problems,
)
from follicle.scene import OutputParams


@pytest.fixture(scope="module")
def groom():
    from follicle.pipeline import groom_scene
    from follicle.scene import Scene

    return groom_scene(Scene())


@pytest.fixture(scope="module")
def hair(groom) -> HairCurves:
    return groom.generate(count=300)


def test_the_scene_key_offers_every_target():
    assert OutputParams.model_json_schema()["properties"]["target"]["enum"] == list(TARGET_NAMES)


@pytest.mark.parametrize("name", TARGET_NAMES)
@pytest.mark.slow
def test_what_a_target_writes_is_what_it_reads(hair, name):
    out = for_target(hair, name)
    assert problems(out, name) == []
    assert out.curve_count == hair.curve_count and np.array_equal(out.offsets, hair.offsets)
    scale = 100.0 if name == "unreal" else 1.0
    np.testing.assert_allclose(out.points, hair.points * scale, rtol=1e-6, atol=1e-7)
    # Unity's hair package reads Alembic diameters in centimetres, positions in metres
    widths = 100.0 if name in ("unreal", "unity") else 1.0
    np.testing.assert_allclose(
        out.point_data["width"], hair.point_data["width"] * widths, rtol=1e-6
    )


@pytest.mark.slow
def test_ids_become_int32_for_blender_and_unreal(hair):
    assert [k for k, v in hair.curve_data.items() if v.dtype == np.int64] == [
        "hair_id",
        "strand_id",
        "root_triangle",
    ]
    blender = for_target(hair, "blender")
    assert blender.curve_data["hair_id"].dtype == np.int32
    np.testing.assert_array_equal(blender.curve_data["hair_id"], hair.curve_data["hair_id"])
    np.testing.assert_array_equal(
        blender.curve_data["surface_uv_coordinate"], hair.curve_data["root_uv"]
    )
    unreal = for_target(hair, "unreal")
    assert set(unreal.curve_data) == {"groom_id", "groom_root_uv", "groom_guide"}
    assert set(unreal.point_data) == {"groom_color", "width"}
    assert unreal.curve_data["groom_id"].dtype == np.int32
    assert not unreal.curve_data["groom_guide"].any()


def test_an_id_too_big_for_int32_is_left_out_with_a_warning(caplog):
    c = HairCurves.from_array(
        np.zeros((2, 3, 3)),
        curve_data={"hair_id": np.array([0, 2**40]), "small": np.array([1, 2], np.int64)},
    )
    with caplog.at_level(logging.WARNING, "follicle"):
        out = for_target(c, "blender")
    assert set(out.curve_data) == {"small"} and out.curve_data["small"].dtype == np.int32
    assert "'hair_id'" in caplog.text and "1099511627776" in caplog.text


def test_houdini_binds_to_the_skin_with_its_own_primuv(hair, groom):
    out = for_target(hair, "houdini")
    assert set(out.point_data) >= {"Cd"} and "uv" in out.curve_data
    tri = out.curve_data["skinprim"]
    s, t = out.curve_data["skinprimuv"].T
    v = groom.mesh.rest_vertices[groom.mesh.faces[tri]]  # Houdini: (1-s-t)·v0 + s·v1 + t·v2
    root = (1 - s - t)[:, None] * v[:, 0] + s[:, None] * v[:, 1] + t[:, None] * v[:, 2]
    first = hair.points[hair.offsets[:-1]]
    assert np.abs(root - first).max() < 2e-3  # roots sit on the skin (displaced by < 2 mm)
    assert np.median(np.linalg.norm(root - first, axis=1)) < 1e-5


def test_unreal_resamples_curves_beyond_255_points(caplog):
    t = np.linspace(0.0, 1.0, 300) ** 1.5  # a curl with unequal segments
    long = np.stack([0.01 * np.cos(40 * t), 0.3 * t, 0.01 * np.sin(40 * t)], axis=1)
    c = HairCurves.from_polylines(
        [long, long[:10]],
        point_data={"width": np.linspace(1e-4, 2e-5, 310).astype(np.float32)},
        curve_data={"hair_id": np.array([7, 8])},
    )
    with caplog.at_level(logging.WARNING, "follicle"):
        out = for_target(c, "unreal")
    assert list(out.counts) == [MAX_UNREAL_POINTS, 10]
    assert list(out.curve_data["groom_id"]) == [7, 8]
    first = out.points[:MAX_UNREAL_POINTS] / 100.0  # cm
    np.testing.assert_allclose(first[[0, -1]], long[[0, -1]], atol=1e-7)  # root and tip kept
    seg = np.linalg.norm(np.diff(first, axis=0), axis=1)
    total = np.linalg.norm(np.diff(long, axis=0), axis=1).sum()
    assert abs(seg.sum() - total) / total < 5e-3  # the polyline's length, nearly
    assert seg.max() / seg.min() < 1.01  # evenly spaced
    width = out.point_data["width"][:MAX_UNREAL_POINTS] / 100.0
    assert width[0] == pytest.approx(1e-4) and width[-1] == pytest.approx(2e-5 + 8e-5 * 10 / 309)
    assert "1 hair curve(s) of more than 255 points resampled to 255" in caplog.text
    assert list(for_target(c, "unity").counts) == [300, 10]


def test_guides_get_widths_and_the_guide_flag(groom):
    out = for_target(groom.guides.curves, "unreal", "guides")
    assert out.curve_data["groom_guide"].all()
    assert out.point_data["width"].min() == pytest.approx(1e-2)  # 0.1 mm in cm
    n = groom.guides.count
    # the guides' ids, apart from every hair's (GUIDE_ID_BASE and up)
    assert out.curve_data["groom_id"].tolist() == list(range(GUIDE_ID_BASE, GUIDE_ID_BASE + n))
    g = groom.guides.curves
    for curve_data in ({}, {"guide_id": np.arange(n, dtype=np.int64)[::-1] + 100}):
        # guides from a file (no ids, or ids of their own): the id the hair's closest
        # guides name (Groom.guide_binding's indices, moved by the same base)
        other = for_target(HairCurves(g.points, g.offsets, {}, curve_data), "unreal", "guides")
        assert other.curve_data["groom_id"].tolist() == list(
            range(GUIDE_ID_BASE, GUIDE_ID_BASE + n)
        )
    with pytest.raises(InputError, match="role"):
        for_target(groom.guides.curves, "unreal", "guide")
    with pytest.raises(InputError, match="target: unknown target 'maya'"):
        for_target(groom.guides.curves, "maya")


def test_guide_binding_names_the_guides_that_weigh_most(groom, hair):
    ids = hair.curve_data["hair_id"]
    index, weight = groom.guide_binding(ids)
    assert index.shape == weight.shape == (len(ids), 3) and index.dtype == np.int32
    np.testing.assert_allclose(weight.sum(axis=1), 1.0, atol=1e-6)
    assert (np.diff(weight, axis=1) <= 1e-7).all()  # heaviest first
    roots = hair.points[hair.offsets[:-1]]
    d = [np.linalg.norm(roots - groom.guides.root_positions[index[:, k]], axis=1) for k in range(3)]
    assert np.median(d[0]) < np.median(d[2])  # the heaviest guide is the nearest, mostly
    again, _ = groom.guide_binding(ids[::-1])
    np.testing.assert_array_equal(again, index[::-1])  # per hair, whatever the order


# ------------------------------------------------------------------ follicle check
def test_check_lists_what_unreal_would_drop_and_exits_1(tmp_path, hair):
    save(hair, tmp_path / "h.usda")
    run = CliRunner().invoke(main, ["check", str(tmp_path / "h.usda"), "--target", "unreal"])
    assert run.exit_code == 1, run.output
    lines = run.output.splitlines()
    assert any("'root_uv' is there but Unreal reads 'groom_root_uv'" in x for x in lines)
    assert any("would be dropped" in x and "opacity" in x for x in lines)
    assert all(x.startswith(str(tmp_path / "h.usda")) for x in lines)


def test_check_passes_a_clean_file_and_refuses_an_unreadable_one(tmp_path, hair):
    save(hair, tmp_path / "h.usda")
    run = CliRunner().invoke(main, ["check", str(tmp_path / "h.usda"), "--target", "generic"])
    assert (
        run.exit_code == 0 and "a USD or Alembic reader reads all of it (300 curves" in run.output
    )
    (tmp_path / "bad.usda").write_text("#usda 1.0\n(\n")
    run = CliRunner().invoke(main, ["check", str(tmp_path / "bad.usda")])
    assert run.exit_code == 2


def test_check_finds_widths_in_the_wrong_unit(tmp_path):
    pts = np.cumsum(np.full((4, 5, 3), 0.01), axis=1)
    c = HairCurves.from_array(pts, {"width": np.full(20, 0.02, np.float32)})  # 1 cm radius
    save(c, tmp_path / "b.usda")
    run = CliRunner().invoke(main, ["check", str(tmp_path / "b.usda"), "--target", "unity"])
    assert run.exit_code == 1
    assert (
        "widths look like a tool's default radius, not hair: the median width"
        " (diameter) is 0.02 m" in run.output
    )


def test_check_lists_curves_the_reader_left_out(tmp_path):
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(tmp_path / "one.usda"))
    curves = UsdGeom.BasisCurves.Define(stage, "/Hair")
    curves.CreatePointsAttr([(0, 0, 0), (0, 0.01, 0), (0, 0.02, 0), (1, 0, 0)])
    curves.CreateCurveVertexCountsAttr([3, 1])
    curves.CreateTypeAttr("linear")
    stage.Save()
    run = CliRunner().invoke(main, ["check", str(tmp_path / "one.usda"), "--target", "unity"])
    assert run.exit_code == 1, run.output
    assert "fewer than 2 points" in run.output


@pytest.mark.parametrize("ext", [".usda", ".abc"])
@pytest.mark.parametrize("name", TARGET_NAMES)
def test_our_export_for_a_target_passes_its_check(tmp_path, groom, hair, name, ext):
    path = tmp_path / f"g{ext}"
    save(hair, path, target=name, guides=groom.guides.curves, mesh=groom.mesh)
    run = CliRunner().invoke(main, ["check", str(path), "--target", name])
    if name == "blender" and ext == ".abc":  # measured: Blender keeps points and radius only
        assert run.exit_code == 1 and "write USD for it" in run.output
        return
    if name == "unity" and ext == ".usda":  # its hair package builds hair from Alembic only
        assert run.exit_code == 1 and "it does not read this one" in run.output
        return
    assert run.exit_code == 0, run.output
    assert "reads all of it (300 curves" in run.output


def _broken_for_unreal(hair: HairCurves) -> HairCurves:
    """Houdini's names, int64 ids and a 300-point curve."""
    t = np.linspace(0.0, 0.3, 300)
    long = HairCurves.from_array(np.stack([0 * t, t, 0 * t], axis=1)[None])
    bad = for_target(hair, "houdini")
    return HairCurves.concatenate(
        [
            HairCurves(
                bad.points,
                bad.offsets,
                {"Cd": bad.point_data["Cd"]},
                {"uv": bad.curve_data["uv"], "id": np.arange(300, dtype=np.int64)},
            ),
            HairCurves(
                long.points,
                long.offsets,
                {"Cd": np.zeros((300, 3), np.float32)},
                {"uv": np.zeros((1, 2), np.float32), "id": np.array([300])},
            ),
        ]
    )


def test_check_names_each_problem_of_a_file_broken_for_unreal(tmp_path, hair):
    """Houdini's names, int64 ids, a 300-point curve, no widths, no GroomAPI: every one
    a line."""
    from follicle.io.usd import save_usd

    save_usd(_broken_for_unreal(hair), tmp_path / "bad.usda", target="houdini")  # int64 kept
    run = CliRunner().invoke(main, ["check", str(tmp_path / "bad.usda"), "--target", "unreal"])
    assert run.exit_code == 1
    lines = [x.split(": ", 1)[1] for x in run.output.splitlines()]
    fix = "fix: `follicle export FILE -o OUT --target unreal`"
    assert lines == [
        "1 curve(s) have more than 255 points (up to 300): Unreal refuses them;"
        f" {fix} resamples them",
        "Unreal reads only groom_* attributes: Cd, id, uv would be dropped;"
        f" {fix} writes what it reads, under its names",
        "no widths: Unreal draws every hair at its default width; fix: give the curves"
        " widths where they were made, or regrow them with widths"
        " (`follicle grow SCENE -o OUT --target unreal`)",
        "1 of 1 curves objects (/Groom/Hair/chunk_0000): no GroomAPI on them or a prim"
        f" above: Unreal's USD importer does not read them as a groom; {fix} applies it",
    ]


def test_check_names_each_problem_of_an_alembic_file_broken_for_unreal(tmp_path, hair):
    """The same in Alembic: no groom schema version (Unreal then drops every groom_*
    attribute), and the guides too."""
    from follicle.io.alembic import save_abc

    save_abc(_broken_for_unreal(hair), tmp_path / "bad.abc", target="houdini", guides=hair[:2])
    run = CliRunner().invoke(main, ["check", str(tmp_path / "bad.abc"), "--target", "unreal"])
    assert run.exit_code == 1
    lines = [x.split(": ", 1)[1] for x in run.output.splitlines()]
    assert lines[0].startswith("1 curve(s) have more than 255 points (up to 300)")
    assert any(
        x.startswith("Unreal reads only groom_* attributes: Cd, id, uv would be") for x in lines
    )
    assert lines[-1] == (
        "1 of 1 curves objects (/Groom/Hair_0000/Hair_0000Shape): no groom_version_major /"
        " groom_version_minor where Unreal reads them (user properties of the curves or an"
        " Xform above): it imports their curves without any groom_* attribute;"
        " fix: `follicle export FILE -o OUT --target unreal` writes them"
    )


def _problem_files(tmp_path, groom, hair):
    """(file, target) pairs that between them raise every kind of `follicle check` line:
    each line of problems(), of the layout and the schema, and a reader's warnings."""
    from pxr import Usd, UsdGeom

    from follicle.io.alembic import save_abc
    from follicle.io.usd import save_usd

    save_usd(_broken_for_unreal(hair), tmp_path / "bad.usda", target="houdini")
    save_abc(
        _broken_for_unreal(hair),
        tmp_path / "bad.abc",
        target="houdini",
        guides=hair[:2],
        mesh=groom.mesh,
    )
    save(hair, tmp_path / "ours.usda")
    save(hair, tmp_path / "ours.abc", guides=groom.guides.curves, mesh=groom.mesh)
    save(hair, tmp_path / "ours.npz")  # int64 ids, as follicle keeps them
    pts = np.cumsum(np.full((4, 5, 3), 0.01), axis=1)
    wide = HairCurves.from_array(pts, {"width": np.full(20, 0.02, np.float32)})  # 1 cm radius
    save(wide, tmp_path / "wide.usda")
    stage = Usd.Stage.CreateNew(str(tmp_path / "one.usda"))
    curves = UsdGeom.BasisCurves.Define(stage, "/Hair")
    curves.CreatePointsAttr([(0, 0, 0), (0, 0.01, 0), (0, 0.02, 0), (1, 0, 0)])
    curves.CreateCurveVertexCountsAttr([3, 1])
    curves.CreateTypeAttr("linear")
    curves.CreateWidthsAttr([5e-5] * 4)
    stage.Save()
    return [
        ("bad.usda", "unreal"),
        ("bad.abc", "unreal"),
        ("ours.usda", "unreal"),
        ("ours.usda", "unity"),
        ("ours.abc", "unity"),
        ("ours.abc", "blender"),
        ("ours.npz", "blender"),
        ("wide.usda", "houdini"),
        ("one.usda", "unity"),
    ]


@pytest.mark.slow
def test_every_check_line_ends_with_its_fix_and_the_export_it_names_fixes_it(tmp_path, groom, hair):
    """Each kind of problem `follicle check` reports ends with '; fix: …' (issue 46), and
    doing what it says — the `follicle export` it names — gives a file whose check no
    longer reports it: what is left is only what an export cannot fix (no widths, a
    tool's default radius)."""
    import re

    seen = []
    for name, target in _problem_files(tmp_path, groom, hair):
        run = CliRunner().invoke(main, ["check", str(tmp_path / name), "--target", target])
        assert run.exit_code == 1, run.output
        lines = [x.split(": ", 1)[1] for x in run.output.splitlines()]
        for line in lines:
            assert "; fix: " in line, line
            problem, fix = line.rsplit("; fix: ", 1)
            assert fix.strip() and problem.strip(), line
        seen += lines
        exports = {m for x in lines for m in re.findall(r"`follicle export FILE -o OUT(\S*)", x)}
        if exports:  # do what it says (in the format it names, if any); those lines are gone
            out = tmp_path / f"fixed_{target}_{Path(name).stem}{max(exports) or '.usda'}"
            done = CliRunner().invoke(
                main, ["export", str(tmp_path / name), "-o", str(out), "--target", target]
            )
            assert done.exit_code == 0, done.output
            again = CliRunner().invoke(main, ["check", str(out), "--target", target])
            left = [x for x in again.output.splitlines() if "`follicle export" in x]
            assert left == [], (name, target, again.output)
    kinds = [
        "points (up to",  # too many points
        "reads only groom_*",  # a prefix
        "no widths",
        "no GroomAPI",
        "no groom_version_major",
        "a mesh (",
        "guides (",
        "root UVs one per curve",
        "keeps only points and",  # an Alembic importer that keeps little
        "builds hair from .abc files only",
        "is int64",
        "is there but",  # another name
        "widths look like a tool's default radius",
        "fewer than 2 points",  # a reader's warning
    ]
    assert [k for k in kinds if not any(k in x for x in seen)] == [], seen


@pytest.mark.parametrize("ext", [".usda", ".abc"])
def test_a_groom_schema_above_the_curves_is_found(tmp_path, hair, ext):
    """Unreal reads its schema on the curves or on a transform above them: GroomAPI on
    /Groom/Hair (ours), or the version in an Xform's arbGeomParams (the schema's 1.0
    place) pass; the version among a curves object's own arbGeomParams (Unreal's
    strand attributes) does not."""
    path = tmp_path / f"u{ext}"
    save(hair, path, target="unreal")
    if ext == ".abc":
        from alembic3d import AbcGeom

        from abcfiles import add_curves, add_params, write
        from follicle.io.check import check_file

        def build(top):
            groom, held = AbcGeom.OXform(top, "Groom"), []
            add_params(
                groom.getSchema().getArbGeomParams(),
                [
                    ("groom_version_major", "short", [1], "constant"),
                    ("groom_version_minor", "short", [5], "constant"),
                ],
                held,
            )
            return groom, add_curves(
                AbcGeom.OXform(groom, "Hair"), "HairShape", [2, 2], hair.points[:4] * 100
            )

        _, found = check_file(write(tmp_path / "top.abc", build), "unreal")
        assert not [x for x in found if "groom_version" in x], found
        _, found = check_file(
            write(
                tmp_path / "none.abc",
                lambda top: add_curves(
                    top,
                    "Hair",
                    [2, 2],
                    hair.points[:4] * 100,
                    params=[
                        ("groom_version_major", "short", [1], "constant"),
                        ("groom_version_minor", "short", [5], "constant"),
                    ],
                ),
            ),
            "unreal",
        )
        assert [x for x in found if "groom_version" in x], found
    run = CliRunner().invoke(main, ["check", str(path), "--target", "unreal"])
    assert run.exit_code == 0, run.output


@pytest.mark.parametrize("ext", [".usda", ".abc"])
def test_a_cache_is_written_for_unreal(tmp_path, groom, ext):
    """An animated cache for a target: the simulated guides flagged as guides, in
    centimetres in Alembic (its head's motion too; no skin, as Unreal's groom importer
    refuses an Alembic file with a mesh), GroomAPI in USD; it passes the target's
    check."""
    from follicle.io.alembic import load_abc, load_abc_mesh, save_abc_cache
    from follicle.io.check import check_file
    from follicle.io.sim_cache import SimCache
    from follicle.io.usd import load_usd, save_usd_cache

    strands = groom.guides.curves.points.reshape(groom.guides.count, -1, 3)[:20]
    positions = np.stack([strands, strands + np.float32(0.01)]).astype(np.float32)
    moves = np.stack([np.eye(4)] * 2)
    moves[1, :3, 3] = (0.0, 0.01, 0.02)
    cache = SimCache(positions, moves, 12.0, "", ".")
    write = save_abc_cache if ext == ".abc" else save_usd_cache
    path = write(cache, tmp_path / f"anim{ext}", mesh=groom.mesh, target="unreal")
    curves, found = check_file(path, "unreal")
    assert found == [] and curves.curve_count == 20
    if ext == ".usda":
        back = load_usd(path, time=1, stored=True)  # metres: USD declares its unit
        np.testing.assert_allclose(back.points, positions[1].reshape(-1, 3), atol=1e-7)
        assert back.curve_data["groom_guide"].tolist() == [1] * 20
        return
    back = load_abc(path, time=1 / 12, stored=True)  # as the file has them: centimetres
    np.testing.assert_allclose(back.points, positions[1].reshape(-1, 3) * 100, rtol=1e-6)
    assert back.curve_data["groom_guide"].tolist() == [1] * 20
    np.testing.assert_allclose(back.point_data["width"], 1e-4 * 100, rtol=1e-6)
    with pytest.raises(FormatError, match="no PolyMesh"):  # Unreal refuses a file with one
        load_abc_mesh(path)
    from alembic3d import Abc, AbcGeom

    head = AbcGeom.IXform(
        Abc.IArchive(str(path)).getTop().getChild("Groom").getChild("Head"),
        Abc.WrapExistingFlag.kWrapExisting,
    ).getSchema()
    matrix = np.array(head.getValue(Abc.ISampleSelector(1 / 12)).getMatrix())
    np.testing.assert_allclose(matrix[3, :3], (0.0, 1.0, 2.0), atol=1e-9)  # cm, row vectors


def test_the_cache_writers_share_one_signature():
    """A table of cache writers (suffix → writer) calls any of them the same way; each
    keeps its own name and says how its format lays the animation out."""
    import inspect

    from follicle.io.alembic import save_abc_cache
    from follicle.io.usd import save_usd_cache

    assert inspect.signature(save_abc_cache) == inspect.signature(save_usd_cache)
    assert list(inspect.signature(save_abc_cache).parameters) == [
        *("frames", "path", "fps", "start", "mesh", "transforms"),
        *("target", "role", "skin_vertices"),
    ]
    assert save_abc_cache.__name__ == "save_abc_cache" and "OCurves" in save_abc_cache.__doc__
    assert (
        save_usd_cache.__module__ == "follicle.io.usd" and "BasisCurves" in save_usd_cache.__doc__
    )


def test_a_cache_says_what_its_frames_are(tmp_path, hair):
    from follicle.io.alembic import save_abc_cache

    with pytest.raises(InputError, match="role: expected 'hair', 'guides' or None"):
        save_abc_cache([hair], tmp_path / "x.abc", role="strands")
    from follicle.io.alembic import load_abc

    path = save_abc_cache([hair, hair], tmp_path / "h.abc", target="unreal")
    assert not load_abc(path, stored=True).curve_data["groom_guide"].any()  # hair by default
