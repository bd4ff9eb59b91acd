"""USD from other tools (Blender 5, Houdini): NurbsCurves beside BasisCurves, 4-channel
colours, widths of every interpolation and the implausible-width warning; NURBS
evaluation against independent computations; every writer given an RGBA colour; the
skin mesh (and the animated head) in USD."""

import logging

import numpy as np
import pytest
from pxr import Sdf, Usd, UsdGeom, Vt
from scipy.interpolate import BSpline

import follicle
from follicle import FormatError, HairCurves, InputError
from follicle.io import curve_basis
from follicle.io.cyhair import load_cyhair, save_cyhair
from follicle.io.dispatch import load_curves
from follicle.io.rib import save_rib_motion
from follicle.io.sim_cache import SimCache
from follicle.io.tfx import load_tfx, resample_fixed, save_tfx
from follicle.io.usd import load_usd, save_usd, save_usd_cache
from follicle.mesh.skin import SkinMesh
from hairfiles import curves_requests

F4 = Sdf.ValueTypeNames.Color4fArray
WARNING = "widths look like"


def _define(stage, kind, path, counts, points, widths=None, **primvars):
    """A BasisCurves (``kind`` = (type, basis, wrap)) or NurbsCurves (``kind`` = (orders,
    knots, weights)) prim with widths (values, interpolation) and primvars
    name=(type, interpolation, values)."""
    if isinstance(kind[0], str):
        c = UsdGeom.BasisCurves.Define(stage, path)
        c.CreateTypeAttr(kind[0])
        c.CreateBasisAttr(kind[1])
        c.CreateWrapAttr(kind[2])
    else:
        c = UsdGeom.NurbsCurves.Define(stage, path)
        c.CreateOrderAttr(list(kind[0]))
        c.CreateKnotsAttr(Vt.DoubleArray(list(map(float, kind[1]))))
        c.CreatePointWeightsAttr(Vt.DoubleArray([] if kind[2] is None else list(kind[2])))
    c.CreateCurveVertexCountsAttr(list(counts))
    c.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(points, np.float32)))
    if widths is not None:
        c.CreateWidthsAttr(Vt.FloatArray(list(map(float, widths[0]))))
        c.SetWidthsInterpolation(widths[1])
    for name, (type_name, interpolation, values) in primvars.items():
        pv = UsdGeom.PrimvarsAPI(c).CreatePrimvar(name, type_name, interpolation)
        pv.Set(type_name.type.pythonClass.FromNumpy(np.ascontiguousarray(values)))
    return c


def _stage(path, up=UsdGeom.Tokens.y):
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, up)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.Xform.Define(stage, "/root")
    return stage


def _bspline(knots, control, k, u):
    return BSpline(np.asarray(knots, float), np.asarray(control, float), k - 1)(u)


# ------------------------------------------------------------------ as Blender 5 writes it
# Blender hair: pinned Catmull-Rom curves, radius 1 cm by default (widths 0.02), its
# colour attribute as primvars:color color4f, its root UVs as surface_uv_coordinate;
# Z up. Unequal segments and a repeated vertex, as a comb leaves them.
HAIR = np.array(
    [
        [0, 0, 0],
        [0, 0, 0.001],
        [0, 0, 0.001],
        [0.002, 0, 0.005],
        [0.01, 0, 0],
        [0.01, 0.003, 0.02],
        [0.01, 0.003, 0.021],
    ],
    np.float32,
)
RGBA = np.array(
    [
        [0.1, 0.2, 0.3, 1.0],
        [0.4, 0.5, 0.6, 0.9],
        [0.7, 0.8, 0.9, 0.8],
        [0.15, 0.25, 0.35, 0.7],
        [0.5, 0.5, 0.5, 0.6],
        [0.45, 0.55, 0.65, 0.5],
        [0.75, 0.85, 0.95, 0.25],
    ],
    np.float32,
)
NURBS = np.array(
    [[0.1, 0, 0], [0.1, 0, 0.01], [0.11, 0.002, 0.02], [0.13, 0.002, 0.02], [0.13, 0.005, 0.04]],
    np.float32,
)
NURBS_KNOTS = [0, 0, 0, 0, 0.3, 1, 1, 1, 1]  # order 4, clamped, one unequal inner knot
NURBS_RGBA = np.array(
    [
        [0.9, 0.1, 0.1, 1.0],
        [0.8, 0.2, 0.1, 0.8],
        [0.7, 0.3, 0.1, 0.6],
        [0.6, 0.4, 0.1, 0.4],
        [0.5, 0.5, 0.1, 0.2],
    ],
    np.float32,
)
Z_TO_Y = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], np.float64)  # rows: (x, y, z) -> (x, z, -y)


def _blender_file(path):
    stage = _stage(path, UsdGeom.Tokens.z)
    _define(
        stage,
        ("cubic", "catmullRom", "pinned"),
        "/root/Curves/Curves",
        [4, 3],
        HAIR,
        widths=([0.02] * 7, "vertex"),
        color=(F4, "vertex", RGBA),
        surface_uv_coordinate=(
            Sdf.ValueTypeNames.TexCoord2fArray,
            "uniform",
            np.float32([[0.25, 0.5], [0.75, 0.125]]),
        ),
    )
    _define(
        stage,
        ([4], NURBS_KNOTS, None),
        "/root/Nurbs/Nurbs",
        [5],
        NURBS,
        widths=([0.02] * 5, "vertex"),
        color=(F4, "vertex", NURBS_RGBA),
        surface_uv_coordinate=(
            Sdf.ValueTypeNames.TexCoord2fArray,
            "uniform",
            np.float32([[0.5, 0.5]]),
        ),
    )
    stage.Save()
    return path


def test_blender_hair_nurbs_beside_basis_rgba_colour_and_default_radius(tmp_path, caplog):
    path = _blender_file(tmp_path / "blender.usda")
    with caplog.at_level(logging.WARNING, logger="follicle"):
        back = load_curves(path)  # the widths warning comes from load_curves, in metres
    # the NURBS prim is read beside the BasisCurves: 4 + 3 vertices, then 5 NURBS points
    assert back.counts.tolist() == [4, 3, 5]
    np.testing.assert_allclose(back.points[:7], HAIR @ Z_TO_Y, atol=1e-9)
    u = np.array([0, 0.15, 0.3, 0.65, 1.0])  # knots 0, 0.3, 1; 2 steps a span: ≥ 5 points
    np.testing.assert_allclose(
        back.points[7:], _bspline(NURBS_KNOTS, NURBS, 4, u) @ Z_TO_Y, atol=1e-7
    )
    # colour: RGB from the first three channels, opacity from the fourth
    nurbs_rgba = _bspline(NURBS_KNOTS, NURBS_RGBA, 4, u)
    np.testing.assert_array_equal(back.point_data["color"][:7], RGBA[:, :3])
    np.testing.assert_array_equal(back.point_data["opacity"][:7], RGBA[:, 3])
    np.testing.assert_allclose(back.point_data["color"][7:], nurbs_rgba[:, :3], atol=1e-7)
    np.testing.assert_allclose(back.point_data["opacity"][7:], nurbs_rgba[:, 3], atol=1e-7)
    assert back.point_data["color"].shape == (12, 3) and back.point_data["opacity"].shape == (12,)
    np.testing.assert_allclose(back.point_data["width"], 0.02, rtol=1e-6)
    assert back.curve_data["root_uv"].tolist() == [[0.25, 0.5], [0.75, 0.125], [0.5, 0.5]]
    # Blender's default 1 cm radius: one warning naming the file, the median and the fix
    warnings = [r.getMessage() for r in caplog.records if WARNING in r.getMessage()]
    assert len(warnings) == 1
    assert str(path) in warnings[0] and "0.02 m" in warnings[0] and "radius" in warnings[0]
    # and no attribute was dropped on joining the two prims
    assert not [r for r in caplog.records if "dropped" in r.getMessage()]


def test_an_attribute_on_one_curves_object_only_is_kept_and_filled(tmp_path, caplog):
    """Blender hair with colour and root UVs beside a NURBS curve without them: joined
    as Blender's Join does (zeros where missing; opacity 1, so the curve stays drawn),
    with one warning naming the object without them."""
    path = tmp_path / "two.usda"
    stage = _stage(path, UsdGeom.Tokens.z)
    uv = np.float32([[0.25, 0.5], [0.75, 0.125]])
    _define(
        stage,
        ("cubic", "catmullRom", "pinned"),
        "/root/Curves/Curves",
        [4, 3],
        HAIR,
        widths=([0.0002] * 7, "vertex"),
        color=(F4, "vertex", RGBA),
        surface_uv_coordinate=(Sdf.ValueTypeNames.TexCoord2fArray, "uniform", uv),
    )
    _define(
        stage, ([4], NURBS_KNOTS, None), "/root/Nurbs/Nurbs", [5], NURBS, ([0.0002] * 5, "vertex")
    )
    stage.Save()
    with caplog.at_level(logging.WARNING, logger="follicle"):
        back = load_curves(path)
    assert back.counts.tolist() == [4, 3, 5]
    np.testing.assert_array_equal(back.point_data["color"][:7], RGBA[:, :3])
    np.testing.assert_array_equal(back.point_data["color"][7:], 0.0)
    np.testing.assert_array_equal(back.point_data["opacity"], [*RGBA[:, 3], 1, 1, 1, 1, 1])
    assert back.curve_data["root_uv"].tolist() == [[0.25, 0.5], [0.75, 0.125], [0.0, 0.0]]
    said = [r.getMessage() for r in caplog.records if "curves object" in r.getMessage()]
    assert len(said) == 1 and "dropped" not in said[0], said
    assert "/root/Nurbs/Nurbs" in said[0] and "/root/Curves" not in said[0]
    assert "color" in said[0] and "opacity" in said[0] and "root_uv" in said[0]


@pytest.mark.parametrize("fmt", ["hair", "tfx", "npz", "usdc"])
def test_blender_colours_survive_export_to_every_format(tmp_path, fmt):
    """The reported failure: Blender USD → .hair wrote wrong colours, → .tfx crashed."""
    back = load_usd(_blender_file(tmp_path / "blender.usda"))
    again = follicle.load_curves(follicle.save(back, tmp_path / f"out.{fmt}"))
    color, opacity = back.point_data["color"], back.point_data["opacity"]
    if fmt == "tfx":  # one vertex count for all: curves of 3 and 5 are resampled to 4
        _, resampled = resample_fixed(back, 4, {"color": color, "opacity": opacity})
        color, opacity = resampled["color"].reshape(-1, 3), resampled["opacity"].reshape(-1)
    np.testing.assert_array_equal(again.point_data["color"], color)
    np.testing.assert_allclose(again.point_data["opacity"], opacity, atol=1e-7)


def test_houdini_cd_alpha_constant_and_uniform_widths(tmp_path, caplog):
    path = tmp_path / "houdini.usda"
    stage = _stage(path)
    pts = np.arange(15, dtype=np.float32).reshape(5, 3) * 1e-3
    cd = np.float32([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0, 1, 1]])
    _define(
        stage,
        ("linear", "bspline", "nonperiodic"),
        "/root/hair",
        [3, 2],
        pts,
        widths=([1e-4, 2e-4], "uniform"),
        Cd=(Sdf.ValueTypeNames.Color3fArray, "vertex", cd),
        Alpha=(Sdf.ValueTypeNames.FloatArray, "vertex", np.float32([1, 0.5, 0.25, 0.125, 0])),
    )
    fur = _define(
        stage,
        ("linear", "bspline", "nonperiodic"),
        "/root/fur",
        [2],
        pts[:2],
        Cd=(Sdf.ValueTypeNames.Color3fArray, "constant", cd[:1]),
        Alpha=(Sdf.ValueTypeNames.FloatArray, "constant", np.float32([0.5])),
    )
    UsdGeom.PrimvarsAPI(fur).CreatePrimvar("widths", Sdf.ValueTypeNames.FloatArray, "constant").Set(
        Vt.FloatArray([3e-5])
    )
    stage.Save()
    with caplog.at_level(logging.WARNING, logger="follicle"):
        back = load_usd(path)
    assert back.counts.tolist() == [3, 2, 2]
    np.testing.assert_array_equal(
        back.point_data["width"], np.float32([1e-4] * 3 + [2e-4] * 2 + [3e-5] * 2)
    )
    np.testing.assert_array_equal(back.point_data["color"], np.vstack([cd, cd[[0, 0]]]))
    np.testing.assert_array_equal(
        back.point_data["opacity"], np.float32([1, 0.5, 0.25, 0.125, 0, 0.5, 0.5])
    )
    assert WARNING not in caplog.text  # 0.03-0.2 mm is hair


def test_display_color_wins_and_other_colours_are_kept_under_their_own_name(tmp_path):
    path = tmp_path / "two.usda"
    stage = _stage(path)
    rgba = np.float32([[0.1, 0.2, 0.3, 0.4], [0.5, 0.6, 0.7, 0.8]])
    _define(
        stage,
        ("linear", "bspline", "nonperiodic"),
        "/root/c",
        [2],
        np.eye(3)[:2],
        displayColor=(Sdf.ValueTypeNames.Color3fArray, "vertex", np.float32([[1, 0, 0]] * 2)),
        displayOpacity=(Sdf.ValueTypeNames.FloatArray, "vertex", np.float32([0.9, 0.7])),
        color=(F4, "vertex", rgba),
        width=(Sdf.ValueTypeNames.FloatArray, "vertex", np.float32([5, 6])),
    )
    stage.Save()
    back = load_usd(path)
    assert back.point_data["color"].tolist() == [[1, 0, 0], [1, 0, 0]]
    np.testing.assert_array_equal(back.point_data["opacity"], np.float32([0.9, 0.7]))
    np.testing.assert_array_equal(back.point_data["color_primvar"], rgba)
    np.testing.assert_array_equal(back.point_data["width_primvar"], np.float32([5, 6]))
    assert "width" not in back.point_data  # a primvar named width is not the schema's widths


def test_nurbs_varying_constant_and_integer_primvars(tmp_path):
    path = tmp_path / "nurbs.usda"
    stage = _stage(path)
    _define(
        stage,
        ([4], NURBS_KNOTS, None),
        "/root/n",
        [5],
        NURBS,
        widths=([1e-4, 2e-4, 4e-4], "varying"),  # one per segment end: u = 0, 0.3, 1
        strand=(Sdf.ValueTypeNames.IntArray, "vertex", np.int32([7, 8, 9, 10, 11])),
        tint=(Sdf.ValueTypeNames.Float3Array, "constant", np.float32([[1, 2, 3]])),
    )
    stage.Save()
    back = load_usd(path)
    # u = 0, 0.15, 0.3, 0.65, 1: linear in u between the segment ends
    np.testing.assert_allclose(
        back.point_data["width"], [1e-4, 1.5e-4, 2e-4, 3e-4, 4e-4], rtol=1e-6
    )
    # integers are not blended: each point takes its heaviest control vertex's value
    basis = _bspline(NURBS_KNOTS, np.eye(5), 4, [0, 0.15, 0.3, 0.65, 1.0])
    assert back.point_data["strand"].tolist() == (7 + basis.argmax(axis=1)).tolist()
    assert back.point_data["strand"].tolist() == [7, 8, 8, 10, 11]
    assert "tint" not in back.point_data  # constant primvars other than colours are skipped


@pytest.mark.parametrize(
    "attr, value, message",
    [
        ("knots", [0, 0, 0, 0, 1, 1, 1, 1], "knots has 8 values; .* need 9"),
        (
            "knots",
            [0, 0, 0, 0, 0.7, 0.3, 1, 1, 1],
            r"the knots of curve 0 decrease \(0.7 then 0.3\)",
        ),
        ("order", [6], "curve 0 has order 6 and 5 vertices: the order is more than its control"),
        ("order", [1], "curve 0 has order 1 and 5 vertices: the order is below 2"),
        ("pointWeights", [1, 1, 0, 1, 1], r"pointWeights\[2\] = 0; weights must be > 0"),
        ("ranges", [(0.0, 2.0)], r"ranges of curve 0 \(0, 2\) reach outside its knots' domain"),
    ],
)
def test_unreadable_nurbs_are_one_format_error_naming_the_prim(tmp_path, attr, value, message):
    path = tmp_path / "bad.usda"
    stage = _stage(path)
    c = _define(stage, ([4], NURBS_KNOTS, None), "/root/bad", [5], NURBS)
    c.GetPrim().GetAttribute(attr).Set(value)
    stage.Save()
    with pytest.raises(FormatError, match=f"bad.usda: /root/bad: {message}"):
        load_usd(path)


# ------------------------------------------------------------------ NURBS evaluation
def test_nurbs_points_match_scipy_for_mixed_orders_uneven_and_unclamped_knots():
    rng = np.random.default_rng(3)
    a, b = rng.random((7, 3)), rng.random((6, 3))
    ka = [0, 0, 0, 0, 0.1, 0.5, 0.55, 1, 1, 1, 1]  # cubic, clamped, uneven spans
    kb = [0, 1, 2, 3, 4, 5, 6, 7, 8]  # order 3, uniform, unclamped: u in [2, 6]
    pts, counts = curve_basis.nurbs_points(np.vstack([a, b]), [7, 6], [4, 3], ka + kb)
    ua = [0, 0.05, 0.1, 0.3, 0.5, 0.525, 0.55, 0.775, 1]  # 4 spans × 2 steps + 1 ≥ 7
    ub = np.linspace(2, 6, 9)  # 4 spans × 2 steps + 1 ≥ 6 (1 step would give 5 < 6)
    assert counts.tolist() == [9, 9]
    np.testing.assert_allclose(pts[:9], _bspline(ka, a, 4, ua), atol=1e-12)
    np.testing.assert_allclose(pts[9:], _bspline(kb, b, 3, ub), atol=1e-12)
    # ranges narrow the interval: its ends and the knots inside it, 3 spans × 2 steps + 1
    pts, counts = curve_basis.nurbs_points(a, [7], [4], ka, ranges=np.array([[0.2, 0.6]]))
    u = [0.2, 0.35, 0.5, 0.525, 0.55, 0.575, 0.6]
    assert counts.tolist() == [7]
    np.testing.assert_allclose(pts, _bspline(ka, a, 4, u), atol=1e-12)


def test_a_single_span_of_n_vertices_gives_n_points_evenly_in_its_parameter():
    control = np.float64([[0, 0, 0], [1, 2, 0], [3, 2, 0], [4, 0, 0]])
    pts, counts = curve_basis.nurbs_points(control, [4], [4], [0, 0, 0, 0, 1, 1, 1, 1])
    t = np.linspace(0, 1, 4)[:, None]
    bezier = (
        (1 - t) ** 3 * control[0]
        + 3 * t * (1 - t) ** 2 * control[1]
        + 3 * t**2 * (1 - t) * control[2]
        + t**3 * control[3]
    )
    assert counts.tolist() == [4]
    np.testing.assert_allclose(pts, bezier, atol=1e-12)


def test_rational_quadratic_nurbs_circle_lies_on_the_circle():
    """The 9-point rational quadratic circle (Piegl & Tiller 1997 §7.5): its points at the
    knots are the corner-free control points and halfway in each quarter is 45° on."""
    w = np.sqrt(0.5)
    control = np.float64(
        [
            [1, 0, 0],
            [1, 1, 0],
            [0, 1, 0],
            [-1, 1, 0],
            [-1, 0, 0],
            [-1, -1, 0],
            [0, -1, 0],
            [1, -1, 0],
            [1, 0, 0],
        ]
    )
    weights = [1, w, 1, w, 1, w, 1, w, 1]
    knots = [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1]
    pts, counts = curve_basis.nurbs_points(control, [9], [3], knots, weights)
    angle = np.radians(45 * np.arange(9))
    assert counts.tolist() == [9]
    np.testing.assert_allclose(
        pts, np.column_stack([np.cos(angle), np.sin(angle), np.zeros(9)]), atol=1e-12
    )
    # without its weights it is a B-spline, off the circle at 45°: the weights are used
    flat, _ = curve_basis.nurbs_points(control, [9], [3], knots)
    assert abs(np.linalg.norm(flat[1]) - 1) > 0.05


def test_nurbs_refusals_name_where():
    args = ([5], [4], np.zeros(9))
    with pytest.raises(curve_basis.CurveBasisError, match="f.usd: /n: curve 0 has an empty"):
        curve_basis.nurbs_stencil(*args, where="f.usd: /n")
    with pytest.raises(curve_basis.CurveBasisError, match="order has 2 values; 1 curves"):
        curve_basis.nurbs_stencil([5], [4, 4], np.arange(9.0))
    with pytest.raises(curve_basis.CurveBasisError, match="above 16"):
        curve_basis.nurbs_stencil([20], [17], np.arange(37.0))


# ------------------------------------------------------------------ every writer, RGBA
def _rgba_hair(opacity=False):
    rng = np.random.default_rng(5)
    pts = np.cumsum(rng.normal(scale=0.002, size=(12, 3)), axis=0).astype(np.float32)
    rgba = rng.random((12, 4)).astype(np.float32)
    pd = {"color": rgba, "width": np.full((12, 1), 8e-5, np.float32)}
    if opacity:
        pd["opacity"] = np.full(12, 0.5, np.float32)
    return HairCurves(pts, [0, 4, 8, 12], pd), rgba


READ_BACK = {"hair", "tfx", "usda", "npz"}


@pytest.mark.parametrize("fmt", ["hair", "tfx", "usda", "npz", "rib", "obj", "pbrt", "txt"])
def test_every_writer_takes_rgba_colour_as_rgb_and_opacity(tmp_path, fmt):
    hair, rgba = _rgba_hair()
    path = follicle.save(hair, tmp_path / f"h.{fmt}")
    if fmt in READ_BACK:
        back = follicle.load_curves(path)
        np.testing.assert_array_equal(back.point_data["color"], rgba[:, :3])
        np.testing.assert_allclose(back.point_data["opacity"], rgba[:, 3], atol=1e-7)
        np.testing.assert_allclose(back.point_data["width"], 8e-5, rtol=1e-6)
    elif fmt == "rib":
        ((_, _, params),) = curves_requests(path)
        np.testing.assert_allclose(params["Cs"].reshape(-1, 3), rgba[:, :3], rtol=1e-6)
        np.testing.assert_allclose(
            params["Os"].reshape(-1, 3), np.repeat(rgba[:, 3:], 3, 1), rtol=1e-6
        )
    elif fmt in ("obj", "txt"):  # positions only
        np.testing.assert_allclose(follicle.load_curves(path).points, hair.points, atol=1e-6)
    else:  # one Shape a curve, its (P, 1) widths flattened
        text = path.read_text()
        assert text.count('Shape "curve"') == 3 == text.count('"float width0" 0.00008 ')


def test_the_hairs_own_opacity_wins_over_a_fourth_channel(tmp_path):
    hair, rgba = _rgba_hair(opacity=True)
    back = load_cyhair(save_cyhair(iter([hair]), tmp_path / "h.hair"))  # not through save()
    np.testing.assert_array_equal(back.point_data["color"], rgba[:, :3])
    np.testing.assert_allclose(back.point_data["opacity"], 0.5)
    tfx = load_tfx(save_tfx(iter([hair]), tmp_path / "h.tfx"))
    np.testing.assert_array_equal(tfx.point_data["color"], rgba[:, :3])
    np.testing.assert_allclose(tfx.point_data["opacity"], 0.5)


def test_rgba_reaches_rib_motion_and_usd_cache_frames(tmp_path):
    hair, rgba = _rgba_hair()
    moved = hair.with_points(hair.points + 0.01)
    path = save_rib_motion([hair, moved], [0.0, 0.5], tmp_path / "m.rib")
    for _, _, params in curves_requests(path):
        np.testing.assert_allclose(params["Cs"].reshape(-1, 3), rgba[:, :3], rtol=1e-6)
    back = load_usd(save_usd_cache([hair, moved], tmp_path / "m.usdc"), time=1)
    np.testing.assert_array_equal(back.point_data["color"], rgba[:, :3])
    np.testing.assert_array_equal(back.points, moved.points)


@pytest.mark.parametrize("fmt", ["hair", "tfx", "usda", "npz", "rib", "pbrt", "txt"])
@pytest.mark.parametrize(
    "key, shape, message",
    [
        (
            "color",
            (12, 2),
            r"point_data\['color'\]: expected RGB or RGBA .* \(12, 3\) or \(12, 4\),"
            r" got float32 of shape \(12, 2\)",
        ),
        ("width", (12, 2), r"point_data\['width'\]: expected one number a point, shape \(12,\)"),
    ],
)
def test_mis_shaped_attributes_are_input_errors_naming_them(tmp_path, fmt, key, shape, message):
    hair, _ = _rgba_hair()
    bad = HairCurves(
        hair.points, hair.offsets, {**hair.point_data, key: np.ones(shape, np.float32)}
    )
    with pytest.raises(InputError, match=message):
        follicle.save(bad, tmp_path / f"bad.{fmt}")
    assert not list(tmp_path.iterdir())  # nothing half-written


# ------------------------------------------------------------------ the skin in USD
def _skin():
    verts = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0.05]])
    uvs = np.array([[0, 0], [1, 0], [0, 1], [1, 1]])
    return SkinMesh(verts, [[0, 1, 2], [1, 3, 2]], uvs, name="patch")


def _turn(angle, shift):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s, shift[0]], [0, 1, 0, shift[1]], [-s, 0, c, shift[2]], [0, 0, 0, 1]])


def test_the_skin_is_a_usd_mesh_beside_the_hair(tmp_path):
    hair, _ = _rgba_hair()
    skin = _skin()
    path = save_usd(hair, tmp_path / "groom.usda", mesh=skin)
    stage = Usd.Stage.Open(str(path))
    mesh = UsdGeom.Mesh.Get(stage, "/Groom/Skin")
    assert mesh and mesh.GetPrim().IsA(UsdGeom.Mesh)
    np.testing.assert_array_equal(
        np.array(mesh.GetPointsAttr().Get()), skin.rest_vertices.astype(np.float32)
    )
    assert list(mesh.GetFaceVertexCountsAttr().Get()) == [3, 3]
    assert list(mesh.GetFaceVertexIndicesAttr().Get()) == [0, 1, 2, 1, 3, 2]
    st = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st")
    assert st.GetTypeName() == Sdf.ValueTypeNames.TexCoord2fArray
    assert st.GetInterpolation() == UsdGeom.Tokens.vertex
    assert np.array(st.Get()).tolist() == [[0, 0], [1, 0], [0, 1], [1, 1]]
    assert mesh.GetSubdivisionSchemeAttr().Get() == "none"
    assert mesh.GetOrientationAttr().Get() == "rightHanded"
    np.testing.assert_array_equal(
        np.array(mesh.GetExtentAttr().Get()), np.float32([[0, 0, 0], [0.1, 0.1, 0.05]])
    )
    # usd-core's own bound of the mesh agrees, and the hair still reads alone
    bound = (
        UsdGeom.BBoxCache(Usd.TimeCode.Default(), ["default"])
        .ComputeWorldBound(mesh.GetPrim())
        .ComputeAlignedRange()
    )
    np.testing.assert_allclose(
        [bound.GetMin(), bound.GetMax()], [[0, 0, 0], [0.1, 0.1, 0.05]], atol=1e-7
    )
    assert load_usd(path).points.tolist() == hair.points.tolist()
    with pytest.raises(InputError, match="mesh: expected a SkinMesh"):
        save_usd(hair, tmp_path / "x.usda", mesh="builtin:head")
    assert not (tmp_path / "x.usda").exists()


def test_the_cache_moves_the_skin_with_the_head(tmp_path):
    hair, _ = _rgba_hair()
    skin = _skin()
    transforms = np.stack([_turn(0.3 * f, (0.01 * f, 0.02, -0.01 * f)) for f in range(3)])
    frames = [hair.with_points(hair.points + 0.001 * f) for f in range(3)]
    path = save_usd_cache(frames, tmp_path / "anim.usdc", start=5, mesh=skin, transforms=transforms)
    stage = Usd.Stage.Open(str(path))
    head = UsdGeom.Xform.Get(stage, "/Groom/Head")
    (op,) = head.GetOrderedXformOps()
    assert op.GetOpType() == UsdGeom.XformOp.TypeTransform
    assert op.GetAttr().GetTimeSamples() == [5, 6, 7]
    mesh = UsdGeom.Mesh.Get(stage, "/Groom/Head/Skin")
    rest = np.array(mesh.GetPointsAttr().Get(), np.float64)
    for f in (0, 2):
        world = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode(5 + f)))
        posed = skin.posed(transform=transforms[f])  # follicle's own pose of the head
        moved = np.c_[rest, np.ones(len(rest))] @ world
        np.testing.assert_allclose(moved[:, :3], posed.vertices, atol=1e-7)
    assert not UsdGeom.Mesh.Get(stage, "/Groom/Skin")
    assert np.array_equal(load_usd(path, time=7).points, frames[2].points)


def test_a_sim_cache_gives_its_own_head_transforms(tmp_path):
    transforms = np.stack([np.eye(4), _turn(0.5, (0, 0.1, 0))])
    positions = np.stack([np.zeros((2, 3, 3)), np.ones((2, 3, 3))]).astype(np.float32)
    cache = SimCache(positions, transforms, 12.0, "", ".")
    path = save_usd_cache(cache, tmp_path / "sim.usda", mesh=_skin())
    stage = Usd.Stage.Open(str(path))  # held: a prim of a freed stage is invalid
    (op,) = UsdGeom.Xform.Get(stage, "/Groom/Head").GetOrderedXformOps()
    np.testing.assert_allclose(np.array(op.Get(1)), transforms[1].T, atol=1e-15)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"transforms": np.stack([np.eye(4)] * 2)}, "transforms: given without mesh="),
        ({"mesh": True, "transforms": np.stack([np.eye(4)] * 2)}, "transforms: 2 matrices for 3"),
        ({"mesh": True, "transforms": np.stack([np.eye(4)] * 4)}, "transforms: 4 matrices for 3"),
        ({"mesh": True, "transforms": np.zeros((3, 4, 4))}, "transforms: frame 0 is not a finite"),
        ({"mesh": True, "transforms": np.zeros((3, 3, 3))}, r"shape \(F, 4, 4\), got \(3, 3, 3\)"),
    ],
)
def test_bad_head_transforms_are_input_errors(tmp_path, kwargs, message):
    hair, _ = _rgba_hair()
    if kwargs.get("mesh"):
        kwargs = {**kwargs, "mesh": _skin()}
    with pytest.raises(InputError, match=message):
        save_usd_cache([hair] * 3, tmp_path / "bad.usda", **kwargs)
    assert not list(tmp_path.iterdir())
