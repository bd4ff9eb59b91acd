"""Alembic: linear OCurves written per chunk (with guides, skin and animation), read back
from any type, basis, wrap and scope, and meshes read from Alembic and USD."""

import logging
import math
import tracemalloc

import numpy as np
import pytest
from alembic3d import Abc, AbcGeom
from pxr import Gf, Sdf, Usd, UsdGeom
from scipy.interpolate import BSpline

import follicle
from abcfiles import add_curves, add_mesh, write, xforms
from follicle import FormatError, HairCurves, InputError
from follicle.io.alembic import load_abc, load_abc_mesh, save_abc, save_abc_cache
from follicle.io.attributes import DEFAULT_WIDTH
from follicle.io.polymesh import load_usd_mesh
from follicle.io.sim_cache import SimCache
from follicle.pipeline import groom_scene
from follicle.scene import Scene
from hairfiles import hair

EXISTING = Abc.WrapExistingFlag.kWrapExisting


@pytest.fixture(scope="module")
def groom():
    return groom_scene(Scene())


@pytest.fixture(scope="module")
def grown(groom):
    return groom.generate(count=500)


HAIR = "/Groom/Hair_0000/Hair_0000Shape"  # the first (or only) chunk's curves


def _objects(path):
    """{full name: IObject} of every object in the archive at ``path``, depth first in
    archive order."""
    found, stack = {}, list(Abc.IArchive(str(path)).getTop().children)[::-1]
    while stack:
        obj = stack.pop()
        found[obj.getFullName()] = obj
        stack.extend(list(obj.children)[::-1])
    return found


def _geom(obj):
    return Abc.ICompoundProperty(obj.getProperties(), ".geom")


def _meta(compound, name):
    return compound.getPropertyHeader(name).getMetaData()


# ------------------------------------------------------------------ writing
def test_round_trip_is_exact(tmp_path):
    curves = hair()
    curves.curve_data["hair_id"] = np.arange(curves.curve_count, dtype=np.int64) + 10**6
    path = follicle.save(curves, tmp_path / "hair.abc")
    back = follicle.load_curves(path)
    assert back == curves  # points, widths, colours, opacity, uvs and ids bit for bit
    assert back.points.dtype == np.float32 and back.curve_data["hair_id"].dtype == np.int64
    assert back.curve_data["root_uv"].dtype == np.float32
    assert not list(tmp_path.glob(".*"))  # no temporary left behind


def test_an_empty_groom_round_trips(tmp_path):
    empty = HairCurves(
        np.zeros((0, 3), np.float32),
        [0],
        {"width": np.zeros(0, np.float32)},
        {"root_uv": np.zeros((0, 2), np.float32)},
    )
    back = load_abc(save_abc(empty, tmp_path / "empty.abc"))
    assert back == empty and back.curve_count == 0


@pytest.mark.slow
def test_the_built_in_groom_round_trips_with_every_attribute(tmp_path, grown):
    path = save_abc(grown, tmp_path / "groom.abc")
    back = load_abc(path)
    assert back == grown
    assert sorted(back.point_data) == ["color", "normal", "opacity", "width"]
    assert sorted(back.curve_data) == [
        "hair_id",
        "root_bary",
        "root_triangle",
        "root_uv",
        "strand_id",
        "strand_uv",
    ]


@pytest.mark.slow
def test_layout_types_and_scopes(tmp_path, grown):
    path = save_abc(grown, tmp_path / "groom.abc")
    objects = _objects(path)
    assert sorted(objects) == ["/Groom", "/Groom/Hair_0000", "/Groom/Hair_0000/Hair_0000Shape"]
    assert AbcGeom.IXform.matches(objects["/Groom"].getHeader())
    obj = objects[HAIR]
    schema = AbcGeom.ICurves(obj, EXISTING).getSchema()
    sample = schema.getValue()
    assert (sample.getType(), sample.getBasis(), sample.getWrap()) == (
        AbcGeom.CurveType.kLinear,
        AbcGeom.BasisType.kNoBasis,
        AbcGeom.CurvePeriodicity.kNonPeriodic,
    )
    assert np.array_equal(np.asarray(sample.getCurvesNumVertices()), grown.counts)
    assert np.array_equal(np.asarray(sample.getPositions()), grown.points)
    geom = _geom(obj)
    assert _meta(geom, "width").get("geoScope") == "vtx"
    assert _meta(geom, "N").get("geoScope") == "vtx"
    assert _meta(geom, "uv").get("geoScope") == "uni"
    arb = Abc.ICompoundProperty(geom, ".arbGeomParams")
    kinds = {
        h.getName(): (
            str(h.getDataType()),
            h.getMetaData().get("geoScope"),
            h.getMetaData().get("interpretation"),
        )
        for h in arb.propertyheaders
    }
    assert kinds == {
        "color": ("float32_t[3]", "vtx", "rgb"),
        "opacity": ("float32_t", "vtx", ""),
        "hair_id": ("int32_t", "uni", ""),
        "strand_id": ("int32_t", "uni", ""),
        "root_triangle": ("int32_t", "uni", ""),
        "root_bary": ("float32_t[2]", "uni", "vector"),
        "strand_uv": ("float32_t[2]", "uni", "vector"),
    }
    widths = np.asarray(AbcGeom.IFloatGeomParam(geom, "width").getExpandedValue().getVals())
    assert np.array_equal(widths, grown.point_data["width"])  # diameters, metres
    bounds = sample.getSelfBounds()
    lo = np.array([bounds.min()[i] for i in range(3)])
    hi = np.array([bounds.max()[i] for i in range(3)])
    pad = 0.5 * grown.point_data["width"].max()
    np.testing.assert_allclose(lo, grown.points.min(axis=0) - pad, rtol=1e-6)
    np.testing.assert_allclose(hi, grown.points.max(axis=0) + pad, rtol=1e-6)


def test_same_curves_give_same_bytes(tmp_path, grown, groom):
    a = save_abc(grown, tmp_path / "a.abc", guides=groom.guides, mesh=groom.mesh)
    b = save_abc(grown, tmp_path / "b.abc", guides=groom.guides, mesh=groom.mesh)
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes()[:5] == b"Ogawa"


@pytest.mark.slow
def test_chunks_become_objects_in_order_with_bounded_memory(tmp_path):
    rng = np.random.default_rng(3)
    parts = [
        HairCurves.from_array(
            rng.random((500, 16, 3), dtype=np.float32) + i,
            point_data={"width": np.full(8000, 1e-4, np.float32)},
            curve_data={"hair_id": np.arange(500) + 500 * i},
        )
        for i in range(40)
    ]
    chunk_bytes = parts[0].points.nbytes + 8000 * 4 + 500 * 8
    tracemalloc.start()
    try:
        path = save_abc((p for p in parts), tmp_path / "many.abc")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # a few chunks' worth in flight at most, not the 40 of the stream (16 MB)
    assert peak < 4 * chunk_bytes, peak
    names = [n for n in _objects(path) if n.startswith("/Groom/Hair_")]
    assert names == [
        n
        for i in range(40)
        for n in (f"/Groom/Hair_{i:04d}", f"/Groom/Hair_{i:04d}/Hair_{i:04d}Shape")
    ]
    assert load_abc(path) == HairCurves.concatenate(parts)


def test_guides_are_skipped_unless_asked_or_alone(tmp_path, grown, groom):
    path = save_abc(grown, tmp_path / "g.abc", guides=groom.guides)
    assert "/Groom/Guides" in _objects(path)
    assert load_abc(path) == grown
    guides = groom.guides.curves  # written with widths: the default when they have none
    width = guides.point_data.get("width", np.full(guides.point_count, DEFAULT_WIDTH, "f4"))
    assert load_abc(path, guides=True) == HairCurves(
        guides.points, guides.offsets, {**guides.point_data, "width": width}, guides.curve_data
    )
    alone = save_abc(guides, tmp_path / "alone.abc")
    assert load_abc(alone) == guides
    with pytest.raises(FormatError, match="none.abc: no /Groom/Guides curves"):
        load_abc(save_abc(grown, tmp_path / "none.abc"), guides=True)


def test_the_unreal_target_writes_centimetres_and_the_groom_schema(tmp_path, grown, groom):
    path = save_abc(
        grown, tmp_path / "ue.abc", guides=groom.guides, mesh=groom.mesh, target="unreal"
    )
    xform = Abc.ICompoundProperty(_objects(path)["/Groom"].getProperties(), ".xform")
    user = Abc.ICompoundProperty(xform, ".userProperties")  # where Unreal reads it
    for key, number in (("groom_version_major", 1), ("groom_version_minor", 5)):
        header = user.getPropertyHeader(key)
        assert header.isScalar() and str(header.getDataType()) == "int16_t"
        assert user.getProperty(key).getValue() == number
    arb = Abc.ICompoundProperty(_geom(_objects(path)[HAIR]), ".arbGeomParams")
    assert arb.getPropertyHeader("groom_version_major") is None  # strands' attributes there
    back = load_abc(path)  # Alembic declares no unit: these are Unreal's centimetres
    np.testing.assert_allclose(back.points, grown.points.astype(np.float64) * 100, rtol=1e-6)
    np.testing.assert_allclose(back.point_data["width"], grown.point_data["width"] * 100, rtol=1e-6)
    assert not back.curve_data["groom_guide"].any()
    assert load_abc(path, guides=True).curve_data["groom_guide"].all()
    assert np.array_equal(back.curve_data["groom_root_uv"], grown.curve_data["root_uv"])
    assert "color" in back.point_data  # written as groom_color, read as the colour
    # no skin: Unreal's groom translator refuses an Alembic file with any PolyMesh
    with pytest.raises(FormatError, match="no PolyMesh"):
        load_abc_mesh(path)


def test_normals_can_be_left_out(tmp_path, grown):
    path = save_abc(grown, tmp_path / "tubes.abc", normals=False)
    assert _geom(_objects(path)[HAIR]).getPropertyHeader("N") is None
    back = load_abc(path)
    assert "normal" not in back.point_data and back.point_data["width"].size


def test_unmappable_attributes_are_skipped_with_a_warning(tmp_path, caplog):
    c = HairCurves.from_array(
        np.zeros((2, 3, 3)),
        point_data={
            "rgba4": np.zeros((6, 4), np.float32),
            "flag": np.array([1, 0, 1, 1, 0, 0], bool),
        },
        curve_data={"label": np.array(["a", "b"]), "big": np.array([2**40, 1])},
    )
    with caplog.at_level(logging.WARNING, logger="follicle"):
        back = load_abc(save_abc(c, tmp_path / "x.abc"))
    for name in ("rgba4", "label", "big"):
        assert f"'{name}'" in caplog.text
    assert back.curve_data == {} and list(back.point_data) == ["flag"]
    assert back.point_data["flag"].tolist() == [1, 0, 1, 1, 0, 0]  # bool as uchar


def test_bad_arguments_and_paths(tmp_path, grown):
    with pytest.raises(FormatError, match=r"x.txt: an Alembic file must end in \.abc"):
        save_abc(grown, tmp_path / "x.txt")
    with pytest.raises(InputError, match="guides"):
        save_abc(grown, tmp_path / "x.abc", guides="builtin:long")
    with pytest.raises(InputError, match="mesh: expected a SkinMesh"):
        save_abc(grown, tmp_path / "x.abc", mesh="head")
    with pytest.raises(InputError, match=r"time: must be finite \(got nan\)"):
        load_abc(tmp_path / "x.abc", time=float("nan"))
    with pytest.raises(FormatError, match="no such file"):
        load_abc(tmp_path / "missing.abc")
    assert not list(tmp_path.iterdir())


# ------------------------------------------------------------------ skin
def test_skin_mesh_round_trips_and_is_wound_as_alembic_keeps_it(tmp_path, grown, groom):
    mesh = groom.mesh
    path = save_abc(grown, tmp_path / "skin.abc", mesh=mesh)
    skin = _objects(path)["/Groom/Skin/SkinShape"]
    sample = AbcGeom.IPolyMesh(skin, EXISTING).getSchema().getValue()
    faces = np.asarray(sample.getFaceIndices()).reshape(-1, 3)
    assert np.array_equal(faces, mesh.faces[:, ::-1])  # clockwise in the file
    assert _meta(_geom(skin), "uv").get("geoScope") == "fvr"
    back = load_abc_mesh(path)
    assert np.array_equal(back.rest_vertices, mesh.rest_vertices.astype(np.float32))
    assert np.array_equal(back.faces, mesh.faces)
    assert np.array_equal(back.uvs, mesh.uvs.astype(np.float32))
    again = follicle.load_mesh(path)
    assert again.vertex_count == mesh.vertex_count and again.name == "Skin"
    assert load_abc(path) == grown  # the skin is not hair


def _strip():
    """Two quads side by side whose shared edge is a UV seam: vertices 1 and 4 carry
    two UVs each. Corners listed clockwise, as Alembic keeps them."""
    points = [[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 0, -1], [1, 0, -1], [2, 0, -1]]
    ccw = [[0, 1, 4, 3], [1, 2, 5, 4]]
    corners = [list(reversed(q)) for q in ccw]
    corner_uv = {
        (0, 0): (0, 0),
        (0, 1): (0.5, 0),
        (0, 4): (0.5, 1),
        (0, 3): (0, 1),
        (1, 1): (0.6, 0),
        (1, 2): (1, 0),
        (1, 5): (1, 1),
        (1, 4): (0.6, 1),
    }
    uv = [corner_uv[(f, v)] for f, quad in enumerate(corners) for v in quad]
    return np.array(points, float), corners, np.array(uv, np.float32)


def _meshes(path, *meshes, chain=()):
    """An archive of meshes: kwargs of :func:`abcfiles.add_mesh` each, under ``chain``."""

    def build(top):
        parent = xforms(top, chain)
        return [add_mesh(parent, **kw) for kw in meshes]

    return write(path, build)


def test_alembic_mesh_with_a_uv_seam_is_split_at_it(tmp_path):
    points, corners, uv = _strip()
    strip = dict(points=points, indices_=np.ravel(corners), counts=[4, 4])
    path = _meshes(
        tmp_path / "strip.abc",
        dict(name="Strip", uv=(uv, "faceVarying"), **strip),
        chain=[("Body", np.diag([0.5, 0.5, 0.5, 1.0]), True)],
    )
    mesh = load_abc_mesh(path)
    assert mesh.vertex_count == 8 and mesh.face_count == 4
    assert np.array_equal(mesh.rest_vertices[:6], 0.5 * points)  # the Xform's scale
    assert np.array_equal(mesh.rest_vertices[6:], 0.5 * points[[1, 4]])  # the split ones
    expected = {
        0: (0, 0),
        1: (0.5, 0),
        2: (1, 0),
        3: (0, 1),
        4: (0.5, 1),
        5: (1, 1),
        6: (0.6, 0),
        7: (0.6, 1),
    }
    np.testing.assert_allclose(mesh.uvs, [expected[i] for i in range(8)], atol=1e-7)
    # counter-clockwise triangles: normals point up (+Y), as the quads were drawn
    assert np.allclose(mesh.face_normals(), [0, 1, 0])
    assert sorted(map(tuple, np.sort(mesh.faces, axis=1).tolist())) == [
        (0, 1, 4),
        (0, 3, 4),
        (2, 5, 6),
        (5, 6, 7),
    ]
    # per-vertex UVs with indices, and a SubD cage, need no split
    cage = load_abc_mesh(
        _meshes(
            tmp_path / "vertex.abc",
            dict(
                name="Cage",
                uv=(points[[0, 1, 2]][:, :2], "vertex", [0, 1, 2, 0, 1, 2]),
                subd=True,
                **strip,
            ),
        )
    )
    assert cage.vertex_count == 6 and cage.uvs[5].tolist() == [2.0, 0.0]


def test_several_meshes_read_the_first_with_a_warning(tmp_path, caplog):
    points, corners, _ = _strip()
    path = _meshes(
        tmp_path / "two.abc",
        *[
            dict(name=name, points=points, counts=[4, 4], indices_=np.ravel(corners))
            for name in "AB"
        ],
    )
    with caplog.at_level(logging.WARNING, logger="follicle"):
        mesh = load_abc_mesh(path)
    assert mesh.name == "A" and "two.abc: /A is the skin" in caplog.text and "/B" in caplog.text
    scaled = follicle.load_mesh(path, units="cm")
    np.testing.assert_allclose(scaled.rest_vertices, mesh.rest_vertices * 0.01)


def _usd_mesh(
    path, st, interpolation, *, z_up=False, mpu=1.0, translate=None, left=False, indices=None
):
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, mpu)
    if z_up:
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    parent = "/"
    if translate is not None:
        xf = UsdGeom.Xform.Define(stage, "/Root")
        xf.AddTranslateOp().Set(Gf.Vec3d(*translate))
        parent = "/Root/"
    mesh = UsdGeom.Mesh.Define(stage, parent + "Strip")
    points, corners, _ = _strip()
    mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in points.tolist()])
    mesh.CreateFaceVertexCountsAttr([4, 4])
    ccw = [list(reversed(q)) for q in corners]
    mesh.CreateFaceVertexIndicesAttr(np.ravel(corners if left else ccw).tolist())
    if left:
        mesh.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    primvar = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
        st, Sdf.ValueTypeNames.TexCoord2fArray, interpolation
    )
    primvar.Set(np.asarray(indices[0] if indices else _usd_uv(left), np.float32).tolist())
    if indices:
        primvar.SetIndices(indices[1])
    stage.Save()
    return path


def _usd_uv(left):
    """The strip's faceVarying UVs, in the order its corners are listed."""
    _, corners, uv = _strip()
    if left:
        return uv
    return np.concatenate([uv[3::-1], uv[7:3:-1]])


def test_usd_meshes_with_vertex_and_face_varying_uvs(tmp_path):
    face = load_usd_mesh(_usd_mesh(tmp_path / "fv.usda", "st", UsdGeom.Tokens.faceVarying))
    points, _, _ = _strip()
    assert face.vertex_count == 8 and np.array_equal(face.rest_vertices[:6], points)
    np.testing.assert_allclose(
        face.uvs[[1, 4, 6, 7]], [[0.5, 0], [0.5, 1], [0.6, 0], [0.6, 1]], atol=1e-7
    )
    assert np.allclose(face.face_normals(), [0, 1, 0])
    # leftHanded: the corners are listed clockwise, and still face +Y
    left = load_usd_mesh(
        _usd_mesh(tmp_path / "left.usda", "UVMap", UsdGeom.Tokens.faceVarying, left=True)
    )
    assert np.allclose(left.face_normals(), [0, 1, 0]) and left.vertex_count == 8
    vertex = load_usd_mesh(
        _usd_mesh(
            tmp_path / "v.usdc",
            "uv",
            UsdGeom.Tokens.vertex,
            indices=(points[:, [0, 2]], list(range(6))),
        )
    )
    assert vertex.vertex_count == 6
    np.testing.assert_allclose(vertex.uvs, points[:, [0, 2]], atol=1e-7)


def test_usd_mesh_units_z_up_and_transform(tmp_path):
    path = _usd_mesh(
        tmp_path / "z.usda",
        "st",
        UsdGeom.Tokens.faceVarying,
        z_up=True,
        mpu=0.01,
        translate=(100, 0, 50),
    )
    mesh = follicle.load_mesh(path)
    points, _, _ = _strip()
    # centimetres, Z up: (x, y, z) cm -> (x, z, -y) m, after the translation
    moved = (points + [100, 0, 50]) * 0.01
    expected = np.stack([moved[:, 0], moved[:, 2], -moved[:, 1]], axis=1)
    np.testing.assert_allclose(mesh.rest_vertices[:6], expected, atol=1e-7)
    assert np.allclose(mesh.face_normals(), [0, 0, -1])  # the file's +Y: Y up's -Z
    with pytest.raises(InputError, match="metersPerUnit"):
        follicle.load_mesh(path, units="cm")
    empty = tmp_path / "empty.usda"
    stage = Usd.Stage.CreateNew(str(empty))
    UsdGeom.Xform.Define(stage, "/X")
    stage.Save()
    with pytest.raises(FormatError, match="empty.usda: no Mesh prims"):
        follicle.load_mesh(empty)


# ------------------------------------------------------------------ animation
def _frames(curves, n):
    rng = np.random.default_rng(5)
    return [
        curves.with_points(
            curves.points + rng.normal(0, 0.01, curves.points.shape).astype(np.float32)
        )
        for _ in range(n)
    ]


def test_cache_samples_points_velocities_and_head_motion(tmp_path, grown, groom):
    frames = _frames(grown, 4)
    transforms = np.stack([np.eye(4)] * 4)
    transforms[:, :3, 3] = [[0.1 * f, 0, -0.05 * f] for f in range(4)]
    transforms[2, :3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    path = save_abc_cache(
        iter(frames), tmp_path / "sim.abc", fps=30, start=10, mesh=groom.mesh, transforms=transforms
    )
    objects = _objects(path)
    schema = AbcGeom.ICurves(objects[HAIR], EXISTING).getSchema()
    assert schema.getNumSamples() == 4
    timing = schema.getTimeSampling()
    assert [timing.getSampleTime(f) for f in range(4)] == pytest.approx(
        [(10 + f) / 30 for f in range(4)], abs=1e-12
    )
    for f, frame in enumerate(frames):  # (alembic3d reads a whole number as a time too)
        sample = schema.getValue(Abc.ISampleSelector((10 + f) / 30))
        assert np.array_equal(np.asarray(sample.getPositions()), frame.points)
        velocity = np.asarray(sample.getVelocities())
        a, b = (f, f + 1) if f < 3 else (2, 3)  # the last frame keeps the one into it
        step = (frames[b].points.astype(np.float64) - frames[a].points) * 30
        np.testing.assert_allclose(velocity, step, rtol=1e-5, atol=1e-6)
        assert load_abc(path, time=(10 + f) / 30) == frame
    assert load_abc(path) == frames[0]  # no time: the first sample
    head = AbcGeom.IXform(objects["/Groom/Head"], EXISTING).getSchema()
    assert head.getNumSamples() == 4
    for f in range(4):
        m = np.array(head.getValue(Abc.ISampleSelector((10 + f) / 30)).getMatrix())
        np.testing.assert_array_equal(m, transforms[f].T)  # Alembic's act on rows
    assert "/Groom/Head/Skin" in objects and "/Groom/Skin" not in objects
    skin = load_abc_mesh(path)  # at the first sample: the head at frame 0
    np.testing.assert_allclose(skin.rest_vertices, groom.mesh.rest_vertices, atol=1e-6)


@pytest.mark.slow
def test_cache_takes_a_sim_cache_and_refuses_bad_frames(tmp_path, grown, groom):
    positions = np.stack([np.zeros((2, 3, 3)), np.ones((2, 3, 3))]).astype(np.float32)
    moves = np.stack([np.eye(4)] * 2)
    moves[1, 1, 3] = 0.25
    cache = SimCache(positions, moves, 12.0, "", ".")
    path = save_abc_cache(cache, tmp_path / "guides.abc", mesh=groom.mesh)
    schema = AbcGeom.ICurves(_objects(path)[HAIR], EXISTING).getSchema()
    assert schema.getTimeSampling().getSampleTime(1) == pytest.approx(1 / 12)
    assert np.array_equal(load_abc(path, time=1 / 12).points, np.ones((6, 3), np.float32))
    head = AbcGeom.IXform(_objects(path)["/Groom/Head"], EXISTING).getSchema()
    assert np.array(head.getValue(Abc.ISampleSelector(1 / 12)).getMatrix())[3, 1] == 0.25
    early = save_abc_cache(_frames(grown, 3), tmp_path / "early.abc", start=-2)
    assert load_abc(early) != load_abc(early, time=0.0)  # no time: the first, at -2/24 s
    assert load_abc(early) == load_abc(early, time=-2 / 24)
    single = save_abc_cache([grown], tmp_path / "one.abc")
    sample = AbcGeom.ICurves(_objects(single)[HAIR], EXISTING).getSchema().getValue()
    assert not np.asarray(sample.getVelocities()).any()  # one frame: no motion
    frames = _frames(grown, 3)
    frames[2] = frames[2][:-1]
    with pytest.raises(InputError, match="frame 2 has 499 curves"):
        save_abc_cache(frames, tmp_path / "bad.abc")
    with pytest.raises(InputError, match="empty"):
        save_abc_cache([], tmp_path / "none.abc")
    with pytest.raises(InputError, match="transforms: given without mesh"):
        save_abc_cache(frames[:2], tmp_path / "t.abc", transforms=np.stack([np.eye(4)] * 2))
    with pytest.raises(InputError, match="transforms: 3 matrices for 2 frames"):
        save_abc_cache(
            frames[:2], tmp_path / "t.abc", mesh=groom.mesh, transforms=np.stack([np.eye(4)] * 3)
        )
    with pytest.raises(InputError, match="fps"):
        save_abc_cache(frames[:2], tmp_path / "t.abc", fps=0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["early.abc", "guides.abc", "one.abc"]


def test_cache_frame_without_the_first_frames_normals_keeps_the_last(tmp_path):
    normal = np.tile([1.0, 0, 0], (9, 1)).astype(np.float32)
    first = HairCurves(PTS, [0, 4, 9], point_data={"normal": normal})
    later = HairCurves(PTS + 0.2, [0, 4, 9], point_data={"normal": -normal})
    frames = [first, HairCurves(PTS + 0.1, [0, 4, 9]), later]
    path = save_abc_cache(frames, tmp_path / "normals.abc")  # not a failed write
    for f, expected in enumerate([normal, normal, -normal]):
        np.testing.assert_array_equal(load_abc(path, time=f / 24).point_data["normal"], expected)


# ------------------------------------------------------------------ reading any curves
def _write(path, *objects, chain=()):
    """An archive of curves objects: kwargs of :func:`abcfiles.add_curves` each."""

    def build(top):
        parent = xforms(top, chain)
        return [add_curves(parent, kw.pop("name", f"C{i}"), **kw) for i, kw in enumerate(objects)]

    return write(path, build)


PTS = np.arange(9 * 3, dtype=np.float32).reshape(9, 3) * 0.01


def test_linear_curves_with_widths_of_every_scope(tmp_path):
    for scope, widths, expected in (
        ("constant", [0.002], [0.002] * 9),
        ("uniform", [0.001, 0.003], [0.001] * 4 + [0.003] * 5),
        ("vertex", np.arange(9) * 1e-4, np.arange(9) * 1e-4),
        ("varying", np.arange(9) * 1e-4, np.arange(9) * 1e-4),
    ):
        path = _write(
            tmp_path / f"{scope}.abc", dict(counts=[4, 5], points=PTS, widths=(widths, scope))
        )
        back = load_abc(path)
        assert np.array_equal(back.points, PTS) and back.counts.tolist() == [4, 5]
        np.testing.assert_allclose(back.point_data["width"], expected, rtol=1e-6)


def test_cubic_bases_reduce_to_the_points_the_curves_pass_through(tmp_path):
    cr = load_abc(
        _write(
            tmp_path / "cr.abc",
            dict(
                counts=[4, 5],
                points=PTS,
                kind="cubic",
                basis="catmullRom",
                widths=(np.arange(9), "vertex"),
            ),
        )
    )
    assert np.array_equal(cr.points, PTS[[1, 2, 5, 6, 7]])
    assert cr.point_data["width"].tolist() == [1, 2, 5, 6, 7]
    bez = load_abc(
        _write(
            tmp_path / "bez.abc",
            dict(
                counts=[7],
                points=PTS[:7],
                kind="cubic",
                basis="bezier",
                widths=([1, 2, 3], "varying"),
            ),
        )
    )
    assert np.array_equal(bez.points, PTS[[0, 3, 6]])
    assert bez.point_data["width"].tolist() == [1, 2, 3]
    rng = np.random.default_rng(0)
    pts = rng.random((6, 3)).astype(np.float32)
    bsp = load_abc(
        _write(tmp_path / "bsp.abc", dict(counts=[6], points=pts, kind="cubic", basis="bspline"))
    )
    p = pts.astype(np.float64)
    np.testing.assert_allclose(bsp.points, (p[:-2] + 4 * p[1:-1] + p[2:]) / 6, atol=1e-6)
    # Blender's Catmull-Rom curves are variable-order and pass through every vertex
    blender = load_abc(
        _write(
            tmp_path / "blender.abc",
            dict(counts=[4, 5], points=PTS, kind="variable", basis="catmullRom", orders=[4, 4]),
        )
    )
    assert np.array_equal(blender.points, PTS)
    # a cubic curve of no basis is Blender's poly curve: every vertex
    assert np.array_equal(
        load_abc(
            _write(tmp_path / "poly.abc", dict(counts=[9], points=PTS, kind="cubic", basis="none"))
        ).points,
        PTS,
    )


def test_curves_that_cannot_be_read_are_format_errors_naming_the_object(tmp_path):
    cases = {
        "periodic": (
            dict(counts=[4, 5], points=PTS, kind="cubic", basis="bspline", wrap="periodic"),
            r"/C0: periodic \(closed\) curves are not hair",
        ),
        "hermite": (
            dict(counts=[4, 5], points=PTS, kind="cubic", basis="hermite"),
            r"/C0: unknown basis 'hermite'",
        ),
        "short bezier": (
            dict(counts=[5, 4], points=PTS, kind="cubic", basis="bezier"),
            r"/C0: curve 0 has 5 vertices, invalid for cubic bezier",
        ),
        "widths": (
            dict(counts=[4, 5], points=PTS, widths=([1, 2, 3], "vertex")),
            r"/C0: width has 3 values; vertex scope needs 9",
        ),
        "orders": (
            dict(counts=[4, 5], points=PTS, kind="variable", basis="bspline", orders=[4]),
            r"/C0: \.orders has 1 values; 2 curves need one each",
        ),
        "high order": (
            dict(counts=[4, 5], points=PTS, kind="variable", basis="bspline", orders=[5, 4]),
            r"/C0: curve 0 has order 5 and 4 vertices",
        ),
    }
    for name, (kw, message) in cases.items():
        path = _write(tmp_path / f"{name.replace(' ', '_')}.abc", kw)
        with pytest.raises(FormatError, match=message) as err:
            load_abc(path)
        assert str(err.value).startswith(str(path)) and "\n" not in str(err.value), name


def _nurbs_reference(ctrl, order, knots, weights=None):
    """Points of one NURBS curve where follicle promises them (its distinct knots in
    the domain, each span cut into the fewest equal steps giving at least as many
    points as vertices), by scipy's B-spline evaluation."""
    n, k = len(ctrl), order
    lo, hi = knots[k - 1], knots[n]
    breaks = np.unique(knots[(knots >= lo) & (knots <= hi)])
    steps = max(1, math.ceil((n - 1) / (len(breaks) - 1)))
    params = np.concatenate(
        [
            np.linspace(a, b, steps, endpoint=False)
            for a, b in zip(breaks[:-1], breaks[1:], strict=True)
        ]
        + [[hi]]
    )
    w = np.ones(n) if weights is None else np.asarray(weights, float)
    homogeneous = np.concatenate([ctrl * w[:, None], w[:, None]], axis=1)
    values = BSpline(knots, homogeneous, k - 1, extrapolate=False)(params)
    values[-1] = BSpline(knots, homogeneous, k - 1)(hi - 1e-12 * (hi - lo))  # the closed end
    return values[:, :3] / values[:, 3:]


def test_nurbs_curves_are_evaluated_on_the_curve(tmp_path):
    # a real-shaped strand in centimetres: unequal spans, a double knot, two coincident
    # control vertices, rational weights; and a quadratic one
    ctrl = np.array(
        [
            [0, 0, 0],
            [0.4, 1.1, 0.1],
            [0.4, 1.1, 0.1],
            [1.5, 2.9, -0.6],
            [2.1, 6.5, -1.2],
            [2.0, 9.0, -0.4],
            [3.2, 12.5, 0.9],
        ],
        np.float64,
    )
    knots = np.array([0, 0, 0, 0, 0.15, 0.4, 0.4, 1, 1, 1, 1], np.float64)
    weights = [1, 1, 2, 0.5, 1, 1.5, 1]
    quad = np.array([[5, 0, 0], [5.5, 2, 0], [6, 3.5, 0.2], [7, 4, 0.1]], np.float64)
    quad_knots = np.array([0, 0, 0, 0.3, 1, 1, 1], np.float64)
    path = _write(
        tmp_path / "nurbs.abc",
        dict(
            counts=[7, 4],
            points=np.concatenate([ctrl, quad]),
            kind="variable",
            basis="bspline",
            orders=[4, 3],
            knots=np.concatenate([knots, quad_knots]),
            weights=np.concatenate([weights, np.ones(4)]),
            widths=(np.linspace(0.01, 0.002, 11), "vertex"),
        ),
    )
    back = load_abc(path)
    first = _nurbs_reference(ctrl, 4, knots, weights)
    second = _nurbs_reference(quad, 3, quad_knots)
    assert back.counts.tolist() == [len(first), len(second)]
    np.testing.assert_allclose(back.points, np.concatenate([first, second]), atol=2e-5)
    np.testing.assert_allclose(back.points[[0, len(first) - 1]], ctrl[[0, -1]], atol=1e-5)
    assert np.all(np.diff(back.point_data["width"][: len(first)]) < 0)  # evaluated, tapering
    # Maya writes knot vectors without their two outer knots; none means clamped uniform
    maya = load_abc(
        _write(
            tmp_path / "maya.abc",
            dict(
                counts=[7],
                points=ctrl,
                kind="variable",
                basis="bspline",
                orders=[4],
                knots=knots[1:-1],
                weights=weights,
            ),
        )
    )
    np.testing.assert_allclose(maya.points, first, atol=2e-5)
    clamped = np.array([0, 0, 0, 0, 1, 2, 3, 4, 4, 4, 4], np.float64)
    plain = load_abc(
        _write(
            tmp_path / "plain.abc",
            dict(counts=[7], points=ctrl, kind="variable", basis="bspline", orders=[4]),
        )
    )
    np.testing.assert_allclose(plain.points, _nurbs_reference(ctrl, 4, clamped), atol=2e-5)
    # a cubic B-spline with knots is a NURBS curve of order 4
    cubic = load_abc(
        _write(
            tmp_path / "cubic.abc",
            dict(counts=[7], points=ctrl, kind="cubic", basis="bspline", knots=knots),
        )
    )
    np.testing.assert_allclose(cubic.points, _nurbs_reference(ctrl, 4, knots), atol=2e-5)


def test_colours_uvs_and_params_of_every_scope(tmp_path):
    rgba = np.linspace(0, 1, 9 * 4).reshape(9, 4)
    path = _write(
        tmp_path / "params.abc",
        dict(
            counts=[4, 5],
            points=PTS,
            uv=([[0.1, 0.2], [0.3, 0.4]], "uniform", [1, 0]),
            params=[
                ("Cd", "c4f", rgba, "vertex"),
                ("tint", "c3f", [[1, 0, 0], [0, 1, 0]], "uniform"),
                ("clump", "int", [7, 8], "uniform"),
                ("stiff", "float", np.arange(9), "varying"),
                ("dir", "v3f", np.ones((9, 3)), "vertex"),
                ("gain", "float", [2.0], "constant"),
                ("rest", "double", np.arange(9) / 3, "vertex", list(range(9))),
            ],
        ),
    )
    back = load_abc(path)
    np.testing.assert_allclose(back.point_data["color"], rgba[:, :3], atol=1e-7)
    np.testing.assert_allclose(back.point_data["opacity"], rgba[:, 3], atol=1e-7)
    np.testing.assert_allclose(back.curve_data["root_uv"], [[0.3, 0.4], [0.1, 0.2]], atol=1e-7)
    assert back.curve_data["tint"].tolist() == [[1, 0, 0], [0, 1, 0]]  # a second colour
    assert back.curve_data["clump"].tolist() == [7, 8]
    assert back.curve_data["clump"].dtype == np.int64
    assert back.point_data["stiff"].tolist() == list(range(9))
    assert back.point_data["dir"].shape == (9, 3)
    assert back.point_data["rest"].dtype == np.float64
    np.testing.assert_allclose(back.point_data["rest"], np.arange(9) / 3)
    assert "gain" not in back.point_data and "gain" not in back.curve_data  # constant
    uniform = load_abc(
        _write(
            tmp_path / "uni.abc",
            dict(
                counts=[4, 5],
                points=PTS,
                params=[
                    ("color", "c3f", [[1, 0, 0], [0, 0, 1]], "uniform"),
                    ("opacity", "float", [0.5], "constant"),
                ],
            ),
        )
    )
    assert uniform.point_data["color"].tolist() == [[1, 0, 0]] * 4 + [[0, 0, 1]] * 5
    assert uniform.point_data["opacity"].tolist() == [0.5] * 9


def test_xforms_move_points_widths_and_normals(tmp_path):
    turn = np.eye(4)
    turn[:3, :3] = [[0, 1, 0], [-1, 0, 0], [0, 0, 1]]  # rows: x -> y, y -> -x
    scale = np.diag([2.0, 2.0, 2.0, 1.0])
    scale[3, :3] = [1, 0, 0]
    chain = [("Root", scale, True), ("Head", turn, True)]
    normals = np.tile([1.0, 0, 0], (9, 1))
    path = _write(
        tmp_path / "xf.abc",
        dict(counts=[4, 5], points=PTS, widths=([0.01], "constant"), normals=(normals, "vertex")),
        chain=chain,
    )
    back = load_abc(path)
    expected = (PTS.astype(np.float64) @ turn[:3, :3]) * 2 + [1, 0, 0]
    np.testing.assert_allclose(back.points, expected, atol=1e-6)
    np.testing.assert_allclose(back.point_data["width"], 0.02, rtol=1e-6)
    np.testing.assert_allclose(back.point_data["normal"], np.tile([0, 1, 0], (9, 1)), atol=1e-6)
    # an Xform that does not inherit starts afresh
    alone = [("Root", scale, True), ("Head", turn, False)]
    back = load_abc(_write(tmp_path / "alone.abc", dict(counts=[4, 5], points=PTS), chain=alone))
    np.testing.assert_allclose(back.points, PTS.astype(np.float64) @ turn[:3, :3], atol=1e-6)
    flat = [("Flat", np.diag([1.0, 0, 1, 1]), True)]
    with pytest.raises(FormatError, match=r"/Flat/C0: its transform is singular"):
        load_abc(
            _write(
                tmp_path / "flat.abc",
                dict(counts=[4, 5], points=PTS, normals=(normals, "vertex")),
                chain=flat,
            )
        )


def test_several_objects_join_filling_an_attribute_one_lacks(tmp_path, caplog):
    path = _write(
        tmp_path / "two.abc",
        dict(
            counts=[4],
            points=PTS[:4],
            widths=([0.1], "constant"),
            params=[("a", "float", np.ones(4), "vertex")],
        ),
        dict(counts=[5], points=PTS[4:], widths=([0.2], "constant")),
    )
    with caplog.at_level(logging.WARNING, logger="follicle"):
        back = load_abc(path)
    assert back.counts.tolist() == [4, 5] and np.array_equal(back.points, PTS)
    assert sorted(back.point_data) == ["a", "width"] and "dropped" not in caplog.text
    assert back.point_data["a"].tolist() == [1, 1, 1, 1, 0, 0, 0, 0, 0]  # zeros, as Blender's Join
    assert "filled" in caplog.text and "(no a)" in caplog.text
