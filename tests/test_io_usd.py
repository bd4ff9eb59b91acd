"""USD: pinned Catmull-Rom BasisCurves written per chunk, read back from any basis."""

import hashlib
import logging

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

import follicle
from follicle import FormatError, HairCurves, InputError
from follicle.io.sim_cache import SimCache
from follicle.io.usd import load_usd, save_usd, save_usd_cache
from follicle.pipeline import groom_scene
from follicle.scene import Scene

EXTS = ["usda", "usdc", "usdz", "usd"]


@pytest.fixture(scope="module")
def groom():
    return groom_scene(Scene())


@pytest.fixture(scope="module")
def hair(groom):
    return groom.generate(count=120)


def _curves_prims(path):
    stage = Usd.Stage.Open(str(path))
    return stage, [p for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves)]


@pytest.mark.parametrize("ext", EXTS)
@pytest.mark.slow
def test_round_trip_is_exact(tmp_path, hair, ext):
    path = follicle.save(hair, tmp_path / f"hair.{ext}")
    back = follicle.load_curves(path)
    assert back == hair  # float32 points, widths, colours, ids, uvs: bit for bit
    assert back.points.dtype == np.float32 and back.curve_data["hair_id"].dtype == np.int64
    assert not list(tmp_path.glob(".*"))  # no temporary left behind


@pytest.mark.parametrize("ext", EXTS)
@pytest.mark.slow
def test_prims_attributes_and_stage_metadata(tmp_path, hair, ext):
    path = save_usd(hair, tmp_path / f"hair.{ext}")
    stage, prims = _curves_prims(path)
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert stage.GetDefaultPrim().GetPath() == Sdf.Path("/Groom")
    assert [str(p.GetPath()) for p in prims] == ["/Groom/Hair/chunk_0000"]
    curves = UsdGeom.BasisCurves(prims[0])
    t = Usd.TimeCode.Default()
    assert (
        curves.GetTypeAttr().Get(),
        curves.GetBasisAttr().Get(),
        curves.GetWrapAttr().Get(),
    ) == ("cubic", "catmullRom", "pinned")
    assert list(curves.GetCurveVertexCountsAttr().Get()) == hair.counts.tolist()
    # every attribute's length gives back the interpolation it was written with
    sizes = {
        "points": (len(curves.GetPointsAttr().Get()), "vertex"),
        "widths": (len(curves.GetWidthsAttr().Get()), curves.GetWidthsInterpolation()),
        "normals": (len(curves.GetNormalsAttr().Get()), curves.GetNormalsInterpolation()),
    }
    for pv in UsdGeom.PrimvarsAPI(curves).GetPrimvarsWithAuthoredValues():
        sizes[pv.GetPrimvarName()] = (len(pv.Get()), pv.GetInterpolation())
    expected = {
        "points": "vertex",
        "widths": "vertex",
        "normals": "vertex",
        "displayColor": "vertex",
        "displayOpacity": "vertex",
        "root_uv": "uniform",
        "hair_id": "uniform",
        "strand_id": "uniform",
        "strand_uv": "uniform",
        "root_triangle": "uniform",
        "root_bary": "uniform",
    }
    assert {k: v[1] for k, v in sizes.items()} == expected
    for name, (n, interpolation) in sizes.items():
        assert curves.ComputeInterpolationForSize(n, t) == interpolation, name
    pv = UsdGeom.PrimvarsAPI(curves)
    assert pv.GetPrimvar("root_uv").GetTypeName() == Sdf.ValueTypeNames.Float2Array
    # ids as int32 (Blender drops int64 primvars; they read back as int64, follicle's)
    assert pv.GetPrimvar("hair_id").GetTypeName() == Sdf.ValueTypeNames.IntArray
    assert curves.GetDisplayColorPrimvar().GetTypeName() == Sdf.ValueTypeNames.Color3fArray


def _pinned_catmull_rom(points, offsets, k=16):
    """Dense samples of USD's pinned Catmull-Rom curves (phantom ends 2·P0 − P1)."""
    out = []
    u = np.linspace(0, 1, k)[:, None]
    w = 0.5 * np.hstack(
        [-u + 2 * u**2 - u**3, 2 - 5 * u**2 + 3 * u**3, u + 4 * u**2 - 3 * u**3, -(u**2) + u**3]
    )
    for a, b in zip(offsets[:-1], offsets[1:], strict=True):
        p = points[a:b].astype(np.float64)
        p = np.vstack([2 * p[0] - p[1], p, 2 * p[-1] - p[-2]])
        for s in range(len(p) - 3):
            out.append(w @ p[s : s + 4])
    return np.vstack(out)


def test_extent_bounds_the_smooth_curves_and_widths(tmp_path, hair):
    _, prims = _curves_prims(save_usd(hair, tmp_path / "hair.usda"))
    lo, hi = np.array(UsdGeom.BasisCurves(prims[0]).GetExtentAttr().Get(), dtype=np.float64)
    dense = _pinned_catmull_rom(hair.points, hair.offsets)
    r = 0.5 * float(hair.point_data["width"].max())
    assert np.all(dense - r >= lo - 1e-7) and np.all(dense + r <= hi + 1e-7)
    assert np.all(hi - lo < np.ptp(dense, axis=0) + 2 * r + 0.01)  # and stays tight


def test_usd_validators_find_nothing_wrong(tmp_path, hair, groom):
    # pxr.UsdValidation came with later usd-core releases than the 23.11 we accept; the
    # usd-core CI installs has it, so this runs there
    UsdValidation = pytest.importorskip("pxr.UsdValidation")
    registry = UsdValidation.ValidationRegistry()
    validators = registry.GetOrLoadValidatorsByName(
        [m.name for m in registry.GetAllValidatorMetadata()]
    )
    context = UsdValidation.ValidationContext(validators)
    for ext in ("usdz", "usda"):
        path = save_usd(hair, tmp_path / f"hair.{ext}", guides=groom.guides)
        stage = Usd.Stage.Open(str(path))
        assert [e.GetMessage() for e in context.Validate(stage)] == []


def test_usdz_is_an_aligned_stored_zip32_package(tmp_path, hair):
    import zipfile

    path = save_usd(hair, tmp_path / "hair.usdz")
    with zipfile.ZipFile(path) as zf:
        assert zf.testzip() is None
        (info,) = zf.infolist()
        assert info.filename == "hair.usdc" and info.compress_type == zipfile.ZIP_STORED
        assert info.date_time == (1980, 1, 1, 0, 0, 0)
    member = Sdf.ZipFile.Open(str(path)).GetFileInfo("hair.usdc")
    assert member.dataOffset % 64 == 0 and member.compressionMethod == 0


def test_chunks_become_prims_in_order(tmp_path, groom):
    chunks = list(groom.chunks(40, count=120))
    path = save_usd(iter(chunks), tmp_path / "hair.usdc")
    _, prims = _curves_prims(path)
    assert [p.GetName() for p in prims] == ["chunk_0000", "chunk_0001", "chunk_0002"]
    for prim, chunk in zip(prims, chunks, strict=True):
        pts = np.array(UsdGeom.BasisCurves(prim).GetPointsAttr().Get(), dtype=np.float32)
        assert np.array_equal(pts, chunk.points)
    assert load_usd(path) == HairCurves.concatenate(chunks)


@pytest.mark.parametrize("ext", ["usda", "usdc", "usdz"])
@pytest.mark.slow
def test_same_curves_give_same_bytes(tmp_path, groom, ext):
    digests = set()
    for k in range(2):
        chunks = groom.chunks(50, count=100)
        path = save_usd(chunks, tmp_path / str(k) / f"hair.{ext}", guides=groom.guides)
        digests.add(hashlib.sha256(path.read_bytes()).hexdigest())
    assert len(digests) == 1


def test_guides_prim_is_skipped_unless_asked_or_alone(tmp_path, hair, groom):
    path = save_usd(hair, tmp_path / "both.usda", guides=groom.guides)
    _, prims = _curves_prims(path)
    assert "/Groom/Guides" in [str(p.GetPath()) for p in prims]
    assert load_usd(path) == hair
    guides = load_usd(path, guides=True)  # written with widths (0.1 mm: guides have none)
    assert (guides.point_data.pop("width") == np.float32(1e-4)).all()
    assert guides == groom.guides.curves
    with pytest.raises(FormatError, match="no /Groom/Guides prim"):
        load_usd(save_usd(hair, tmp_path / "hair.usda"), guides=True)
    with pytest.raises(InputError, match="guides"):
        save_usd(hair, tmp_path / "x.usda", guides="builtin:long")


@pytest.mark.slow
def test_load_guides_reads_a_usd_of_guides(tmp_path):
    mesh = follicle.load_mesh("builtin:head")
    guides = follicle.load_guides("builtin:long", mesh)
    path = follicle.save(guides.curves, tmp_path / "guides.usdc")
    again = follicle.load_guides(path, mesh)
    assert again.curves == guides.curves
    assert np.array_equal(again.triangles, guides.triangles)


def _stage_with(tmp_path, name, kind, basis, wrap, counts, points, **primvars):
    path = tmp_path / name
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    c = UsdGeom.BasisCurves.Define(stage, "/C")
    c.CreateTypeAttr(kind)
    c.CreateBasisAttr(basis)
    c.CreateWrapAttr(wrap)
    c.CreateCurveVertexCountsAttr(counts)
    c.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(points, np.float32)))
    for pv_name, (type_name, interpolation, values) in primvars.items():
        if pv_name == "widths":
            c.CreateWidthsAttr(values)
            c.SetWidthsInterpolation(interpolation)
        else:
            UsdGeom.PrimvarsAPI(c).CreatePrimvar(pv_name, type_name, interpolation).Set(values)
    stage.Save()
    return path, stage


def test_bezier_keeps_every_third_control_point(tmp_path):
    pts = np.arange(7 * 3, dtype=np.float32).reshape(7, 3)
    path, _ = _stage_with(
        tmp_path,
        "bez.usda",
        "cubic",
        "bezier",
        "nonperiodic",
        [7],
        pts,
        widths=(None, "varying", [1.0, 2.0, 3.0]),
    )
    back = load_usd(path)
    assert np.array_equal(back.points, pts[[0, 3, 6]])
    assert back.point_data["width"].tolist() == [1.0, 2.0, 3.0]


def test_bspline_is_read_at_its_knots(tmp_path):
    rng = np.random.default_rng(0)
    pts = rng.random((6, 3)).astype(np.float32)
    colours = rng.random((6, 3)).astype(np.float32)
    path, _ = _stage_with(
        tmp_path,
        "bsp.usda",
        "cubic",
        "bspline",
        "nonperiodic",
        [6],
        pts,
        displayColor=(Sdf.ValueTypeNames.Color3fArray, "vertex", Vt.Vec3fArray.FromNumpy(colours)),
    )
    back = load_usd(path)
    p = pts.astype(np.float64)
    knots = (p[:-2] + 4 * p[1:-1] + p[2:]) / 6
    np.testing.assert_allclose(back.points, knots, rtol=0, atol=1e-6)
    c = colours.astype(np.float64)
    np.testing.assert_allclose(
        back.point_data["color"], (c[:-2] + 4 * c[1:-1] + c[2:]) / 6, atol=1e-6
    )
    # pinned: phantom ends added, so the curve starts and ends at the end vertices
    path, _ = _stage_with(tmp_path, "bsp_pinned.usda", "cubic", "bspline", "pinned", [6], pts)
    pinned = load_usd(path)
    assert pinned.point_count == 6
    np.testing.assert_allclose(pinned.points[[0, -1]], pts[[0, -1]], atol=1e-6)
    np.testing.assert_allclose(pinned.points[1:-1], knots, atol=1e-6)


def test_linear_and_nonperiodic_catmull_rom_with_widths_of_every_interpolation(tmp_path):
    pts = np.arange(9 * 3, dtype=np.float32).reshape(9, 3)
    path, _ = _stage_with(
        tmp_path,
        "lin.usda",
        "linear",
        "catmullRom",
        "nonperiodic",
        [4, 5],
        pts,
        widths=(None, "uniform", [0.5, 0.25]),
        displayOpacity=(Sdf.ValueTypeNames.FloatArray, "constant", [0.7]),
        tag=(Sdf.ValueTypeNames.IntArray, "uniform", [3, 4]),
    )
    back = load_usd(path)
    assert np.array_equal(back.points, pts) and back.counts.tolist() == [4, 5]
    assert back.point_data["width"].tolist() == [0.5] * 4 + [0.25] * 5
    np.testing.assert_allclose(back.point_data["opacity"], 0.7)
    assert back.curve_data["tag"].tolist() == [3, 4]
    path, _ = _stage_with(
        tmp_path,
        "cr.usda",
        "cubic",
        "catmullRom",
        "nonperiodic",
        [4, 5],
        pts,
        widths=(None, "vertex", list(range(9))),
    )
    back = load_usd(path)
    assert np.array_equal(back.points, pts[[1, 2, 5, 6, 7]])
    assert back.point_data["width"].tolist() == [1, 2, 5, 6, 7]


def test_transforms_units_and_z_up_are_applied(tmp_path):
    pts = [[0, 0, 0], [0, 0, 100]]  # centimetres, Z up: one metre straight up
    path = tmp_path / "z.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    xf = UsdGeom.Xform.Define(stage, "/Root")
    xf.AddTranslateOp().Set(Gf.Vec3d(100, 0, 0))
    c = UsdGeom.BasisCurves.Define(stage, "/Root/C")
    c.CreateTypeAttr("linear")
    c.CreateCurveVertexCountsAttr([2])
    c.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.array(pts, np.float32)))
    c.CreateWidthsAttr([2.0])
    c.SetWidthsInterpolation("constant")
    stage.Save()
    back = load_usd(path)
    np.testing.assert_allclose(back.points, [[1, 0, 0], [1, 1, 0]], atol=1e-6)
    np.testing.assert_allclose(back.point_data["width"], 0.02, rtol=1e-6)
    stage.ClearMetadata("metersPerUnit")  # unauthored means centimetres, as USD defines
    stage.Save()
    np.testing.assert_allclose(load_usd(path).points[1], [1, 1, 0], atol=1e-6)


def test_bad_files_are_format_errors_naming_the_file(tmp_path):
    with pytest.raises(FormatError, match="no such file"):
        load_usd(tmp_path / "missing.usda")
    empty = tmp_path / "empty.usda"
    stage = Usd.Stage.CreateNew(str(empty))
    UsdGeom.Xform.Define(stage, "/Groom")
    stage.Save()
    with pytest.raises(FormatError, match="empty.usda: no BasisCurves or NurbsCurves prims"):
        follicle.load_curves(empty)
    junk = tmp_path / "junk.usda"
    junk.write_text("this is not USD")
    with pytest.raises(FormatError, match="junk.usda"):
        load_usd(junk)
    path, _ = _stage_with(
        tmp_path, "short.usda", "cubic", "bezier", "nonperiodic", [5], np.zeros((5, 3))
    )
    with pytest.raises(FormatError, match="short.usda: /C: curve 0 has 5 vertices"):
        load_usd(path)
    path, _ = _stage_with(
        tmp_path,
        "size.usda",
        "linear",
        "bezier",
        "nonperiodic",
        [2, 2],
        np.zeros((4, 3)),
        widths=(None, "vertex", [1.0, 2.0, 3.0]),
    )
    with pytest.raises(FormatError, match="size.usda: /C: widths has 3 values; vertex"):
        load_usd(path)


def test_unmappable_attributes_are_skipped_with_a_warning(tmp_path, caplog):
    c = HairCurves.from_array(
        np.zeros((2, 3, 3)),
        point_data={"wide": np.zeros((6, 7), np.float32)},
        curve_data={"label": np.array(["a", "b"])},
    )
    with caplog.at_level(logging.WARNING, logger="follicle"):
        back = load_usd(save_usd(c, tmp_path / "x.usda", normals=False))
    assert "wide" in caplog.text and "label" in caplog.text
    assert back.point_data == {} and back.curve_data == {}


def test_normals_can_be_left_out(tmp_path, hair):
    path = save_usd(hair, tmp_path / "tubes.usdc", normals=False)
    _, prims = _curves_prims(path)
    assert not UsdGeom.BasisCurves(prims[0]).GetNormalsAttr().HasAuthoredValue()
    assert "normal" not in load_usd(path).point_data


def _frames(hair, n):
    return [hair.with_points(hair.points + np.float32([0, 0.01 * f, 0])) for f in range(n)]


def test_cache_samples_points_per_frame(tmp_path, hair):
    frames = _frames(hair, 4)
    path = save_usd_cache(iter(frames), tmp_path / "sim.usdc", fps=30, start=10)
    stage, (prim,) = _curves_prims(path)
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (10, 13)
    assert stage.GetTimeCodesPerSecond() == 30
    curves = UsdGeom.BasisCurves(prim)
    assert curves.GetPointsAttr().GetTimeSamples() == [10, 11, 12, 13]
    assert curves.GetExtentAttr().GetTimeSamples() == [10, 11, 12, 13]
    for f, frame in enumerate(frames):
        pts = np.array(curves.GetPointsAttr().Get(10 + f), dtype=np.float32)
        assert np.array_equal(pts, frame.points)
        assert load_usd(path, time=10 + f) == frame
    assert load_usd(path) == frames[0]  # no time: the first sample


def test_cache_rejects_changing_topology_and_accepts_a_sim_cache(tmp_path, hair):
    frames = _frames(hair, 3)
    frames[2] = frames[2][:-1]
    with pytest.raises(InputError, match="frame 2"):
        save_usd_cache(frames, tmp_path / "bad.usda")
    assert not (tmp_path / "bad.usda").exists()
    with pytest.raises(InputError, match="empty"):
        save_usd_cache([], tmp_path / "none.usda")
    positions = np.stack([np.zeros((2, 3, 3)), np.ones((2, 3, 3))]).astype(np.float32)
    cache = SimCache(positions, np.stack([np.eye(4)] * 2), 12.0, "", ".")
    path = save_usd_cache(cache, tmp_path / "guides.usda")
    stage, _ = _curves_prims(path)
    assert stage.GetTimeCodesPerSecond() == 12.0
    assert np.array_equal(load_usd(path, time=1).points, np.ones((6, 3), np.float32))
