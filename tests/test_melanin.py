"""Hair colour by melanin: the pigments' absorption (Chiang 2016 §4.2), Blender's
melanin mapping, the colour fit both ways, the groom's per-hair pigments, the Mitsuba
scene's σ_a and the exported primvars."""

import math

import numpy as np
import pytest

from follicle.errors import ConfigError, InputError
from follicle.groom.appearance import hair_appearance
from follicle.groom.settings import GroomParams
from follicle.io.dispatch import save
from follicle.melanin import (
    absorption_from_color,
    absorption_from_concentrations,
    color_from_absorption,
    concentrations,
    hair_pigments,
    melanin_absorption,
    melanin_color,
)
from follicle.pipeline import groom_scene
from follicle.scene import Scene

# D(β_n = 0.3) of Chiang 2016 §4.2's fit, by hand: 5.969 − 0.0645 + 0.22788 − 0.28971
# + 0.0451494 + 0.00059535
D_03 = 5.88841475


def test_absorption_of_published_concentrations():
    # pbrt-v3's hair example (eumelanin 1.3) and Chiang 2016 §4.2's coefficients
    assert absorption_from_concentrations(1.3, 0.0) == pytest.approx(
        [1.3 * 0.419, 1.3 * 0.697, 1.3 * 1.37]
    )
    assert absorption_from_concentrations(0.0, 2.0) == pytest.approx([0.374, 0.8, 2.1])
    both = absorption_from_concentrations([1.0, 0.5], [0.5, 0.0])
    assert both == pytest.approx(np.array([[0.5125, 0.897, 1.895], [0.2095, 0.3485, 0.685]]))


@pytest.mark.slow
def test_mitsuba_pigments_absorb_as_ours():
    """Mitsuba's hair BSDF given eumelanin and pheomelanin scatters exactly as given our
    σ_a of them: its own coefficients are ours."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    pigmented = mi.load_dict({"type": "hair", "eumelanin": 0.7, "pheomelanin": 0.4})
    sigma = absorption_from_concentrations(0.7, 0.4)
    ours = mi.load_dict({"type": "hair", "sigma_a": {"type": "rgb", "value": sigma.tolist()}})
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*(np.array([0.3, 0.2, 0.93]) / np.linalg.norm([0.3, 0.2, 0.93])))
    ctx = mi.BSDFContext()
    for wo in ([0.1, -0.5, 0.8], [-0.6, 0.1, -0.7], [0.9, 0.3, 0.1]):
        wo = mi.Vector3f(*(np.array(wo) / np.linalg.norm(wo)))
        expected = np.array(pigmented.eval(ctx, si, wo))
        assert expected.max() > 0
        assert np.array(ours.eval(ctx, si, wo)) == pytest.approx(expected, rel=1e-6)


def test_blender_melanin_mapping():
    # q = −ln(max(1 − melanin, 1e-4)); eumelanin q(1 − r), pheomelanin q·r
    eu, pheo = concentrations([0.0, 0.5, 0.75, 1.0], [0.3, 0.0, 0.25, 1.0])
    assert eu == pytest.approx([0.0, math.log(2), 0.75 * math.log(4), 0.0])
    assert pheo == pytest.approx([0.0, 0.0, 0.25 * math.log(4), math.log(1e4)])
    # melanin 0.6, redness 0.5: q = ln 2.5, half each
    sigma = melanin_absorption(0.6, 0.5)
    q = math.log(2.5)
    assert sigma == pytest.approx(0.5 * q * np.array([0.606, 1.097, 2.42]))


def test_colour_fit_by_hand_and_both_ways():
    # Chiang 2016 §4.2 at β_n = 0.3: σ_a = (ln C / D)²
    assert absorption_from_color([0.5, 1.0, 0.2]) == pytest.approx(
        [(math.log(0.5) / D_03) ** 2, 0.0, (math.log(0.2) / D_03) ** 2]
    )
    assert color_from_absorption((math.log(0.5) / D_03) ** 2) == pytest.approx(0.5)
    colours = np.linspace(0.001, 1.0, 50)
    assert color_from_absorption(absorption_from_color(colours)) == pytest.approx(colours)
    # up to the σ_a of the darkest colour the fit takes, 1e-4: (ln 1e-4 / D)² ≥ 2.38
    sigma = np.array([0.0, 0.01, 0.5, 1.5, 2.3])
    for beta in (0.1, 0.3, 0.8):
        assert absorption_from_color(color_from_absorption(sigma, beta), beta) == pytest.approx(
            sigma
        )
    # no melanin and no dye: white hair; a white dye adds nothing
    assert melanin_color(0.0, 0.0) == pytest.approx([1.0, 1.0, 1.0])
    assert melanin_absorption(0.4, 0.2, (1, 1, 1)) == pytest.approx(melanin_absorption(0.4, 0.2))
    # a dye adds its own colour's σ_a: dyed white hair is the dye
    assert melanin_color(0.0, 0.0, (0.8, 0.3, 0.1)) == pytest.approx([0.8, 0.3, 0.1])
    # more melanin is darker, more redness redder
    blond, brown, black = melanin_color([0.2, 0.6, 0.95], 0.0)
    assert (blond > brown).all() and (brown > black).all()
    plain, red = melanin_color(0.6, [0.0, 1.0])
    assert red[0] / red[2] > plain[0] / plain[2]


def test_bad_values_refused():
    with pytest.raises(InputError, match="melanin"):
        concentrations(1.5, 0.0)
    with pytest.raises(InputError, match="dye"):
        melanin_absorption(0.5, 0.0, (1.0, 1.0))
    with pytest.raises(InputError, match="sigma_a"):
        color_from_absorption(-1.0)
    with pytest.raises(InputError, match="random_melanin"):
        hair_pigments([0, 1], 0, 0.5, 0.0, random_melanin=2.0)


@pytest.mark.parametrize(
    "keys, named",
    [
        ({"melanin": 1.5}, r"\[groom\]\.melanin"),
        ({"melanin": 0.5, "melanin_redness": -0.1}, "melanin_redness"),
        ({"melanin": 0.5, "dye": [1.0, 1.2, 1.0]}, "dye"),
        ({"melanin": 0.5, "random_redness": 2}, "random_redness"),
        ({"melanin": 0.5, "root_color": [0.1, 0.1, 0.1]}, "root_color: melanin gives"),
        ({"melanin": 0.5, "hue_variation": 5.0}, "hue_variation"),
        ({"melanin": 0.5, "mutant_fraction": 0.1}, "mutant_fraction"),
        ({"melanin_redness": 0.3}, "melanin_redness: takes effect with melanin only"),
        ({"dye": [0.5, 0.5, 0.5]}, "dye: takes effect"),
        ({"melanin": 0.5, "inherit": ["color"]}, "inherit: melanin gives the hair's colour"),
    ],
)
def test_groom_keys_refused(keys, named):
    with pytest.raises(ConfigError, match=named):
        GroomParams(**keys)


def test_per_hair_pigments_deterministic_and_chunk_independent():
    ids = np.arange(4000)
    m, r = hair_pigments(ids, 7, 0.5, 0.4, 0.2, 0.5)
    again = [hair_pigments(part, 7, 0.5, 0.4, 0.2, 0.5) for part in (ids[:1234], ids[1234:])]
    assert np.array_equal(m, np.concatenate([a[0] for a in again]))
    assert np.array_equal(r, np.concatenate([a[1] for a in again]))
    # Blender's Random Color: melanin × (1 ± 0.2), spread over the whole range
    assert m.min() >= np.float32(0.4) and m.max() <= np.float32(0.6)
    assert m.min() < 0.41 and m.max() > 0.59 and abs(m.mean() - 0.5) < 0.01
    assert r.min() < 0.21 and r.max() > 0.59
    # another seed, other draws; no randomness, the value itself
    assert not np.array_equal(m, hair_pigments(ids, 8, 0.5, 0.4, 0.2, 0.5)[0])
    plain = hair_pigments(ids, 7, 0.5, 0.4)
    assert (plain[0] == np.float32(0.5)).all() and (plain[1] == np.float32(0.4)).all()


@pytest.fixture(scope="module")
def melanin_groom():
    params = GroomParams(count=400, melanin=0.6, melanin_redness=0.3, random_melanin=0.2)
    scene = Scene().replace(groom=params)
    return groom_scene(scene)


def test_grown_hair_is_coloured_by_its_melanin(melanin_groom):
    hair = melanin_groom.generate()
    cd = hair.curve_data
    assert cd["melanin"].dtype == np.float32 and cd["dye"].shape == (hair.curve_count, 3)
    expected = hair_pigments(cd["hair_id"], 0, 0.6, 0.3, 0.2)
    assert np.array_equal(cd["melanin"], expected[0])
    assert (cd["melanin_redness"] == np.float32(0.3)).all() and (cd["dye"] == 1).all()
    # every vertex of a hair has its melanin's colour, root to tip
    rgb = melanin_color(cd["melanin"], cd["melanin_redness"])
    per_vertex = np.repeat(rgb, hair.counts, axis=0)
    assert hair.point_data["color"] == pytest.approx(per_vertex, rel=1e-5, abs=1e-7)
    # chunks grow the same hairs
    a, b = melanin_groom.generate(150, 0), melanin_groom.generate(250, 150)
    for key in ("melanin", "melanin_redness", "dye"):
        assert np.array_equal(np.concatenate([a.curve_data[key], b.curve_data[key]]), cd[key])
    assert np.array_equal(
        np.concatenate([a.point_data["color"], b.point_data["color"]]), hair.point_data["color"]
    )


def test_without_melanin_hair_is_as_before():
    """Unset melanin: no pigment data, and the colours are root_color and tip_color's
    (Šik 2012 §2.2.6) as :func:`hair_appearance` makes them."""
    params = {"count": 100, "vertices": 8, "cut": 1.0, "hue_variation": 10.0}
    groom = groom_scene(Scene().replace(groom=GroomParams(**params)))
    hair = groom.generate()
    assert set(hair.curve_data) == {
        "hair_id",
        "strand_id",
        "root_uv",
        "strand_uv",
        "root_triangle",
        "root_bary",
    }
    p = groom.params
    look = hair_appearance(
        hair.curve_data["hair_id"],
        p.seed,
        8,
        root_color=p.root_color,
        tip_color=p.tip_color,
        hue_var=p.hue_variation,
        sat_var=0.0,
        val_var=0.0,
        mutant_fraction=0.0,
        mutant_color=p.mutant_color,
        root_width=p.root_width,
        tip_width=p.tip_width,
        root_opacity=1.0,
        tip_opacity=1.0,
    )
    assert (hair.counts == 8).all()
    assert np.array_equal(hair.point_data["color"], look["color"])


@pytest.mark.slow
def test_mitsuba_scene_takes_the_pigments_absorption(melanin_groom, tmp_path):
    pytest.importorskip("mitsuba")
    from follicle.render.mitsuba import _hair_shapes, _mitsuba

    hair = melanin_groom.generate(60)
    # the vertex colours must not be what the path tracer reads: make them white
    hair = type(hair)(
        hair.points,
        hair.offsets,
        {**hair.point_data, "color": np.ones((hair.point_count, 3), np.float32)},
        hair.curve_data,
    )
    shapes = _hair_shapes(_mitsuba(), hair, np.ones(3), 1e-4, tmp_path)
    texels = np.array(shapes["hair_0"]["bsdf"]["sigma_a"]["bitmap"])[:, 0, :]
    cd = hair.curve_data
    sigma = melanin_absorption(cd["melanin"], cd["melanin_redness"], cd["dye"])
    per_segment = np.repeat(sigma, hair.counts - 1, axis=0)
    assert texels[:-1] == pytest.approx(per_segment, rel=1e-6)  # the last: the sentinel's
    # the σ_a of pbrt's concentrations, by hand for the first hair
    q = -math.log(1.0 - float(cd["melanin"][0]))
    eu, pheo = 0.7 * q, 0.3 * q
    by_hand = [eu * 0.419 + pheo * 0.187, eu * 0.697 + pheo * 0.4, eu * 1.37 + pheo * 1.05]
    assert texels[0] == pytest.approx(by_hand, rel=1e-5)


@pytest.mark.parametrize("target", ["generic", "blender"])
def test_usd_carries_the_pigments(melanin_groom, tmp_path, target):
    from pxr import Sdf, Usd, UsdGeom

    hair = melanin_groom.generate(50)
    path = tmp_path / "groom.usda"
    save(hair, path, target=target)
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetPrimAtPath("/Groom/Hair/chunk_0000")
    api = UsdGeom.PrimvarsAPI(prim)
    for name in ("melanin", "melanin_redness"):
        primvar = api.GetPrimvar(name)
        assert primvar.GetInterpolation() == UsdGeom.Tokens.uniform
        assert primvar.GetTypeName() == Sdf.ValueTypeNames.FloatArray
        assert np.array(primvar.Get()) == pytest.approx(hair.curve_data[name])
    dye = api.GetPrimvar("dye")
    assert dye.GetInterpolation() == UsdGeom.Tokens.uniform
    assert np.array(dye.Get()) == pytest.approx(hair.curve_data["dye"])
    # and the colour for tools without melanin
    shown = np.array(UsdGeom.BasisCurves(prim).GetDisplayColorPrimvar().Get())
    assert shown == pytest.approx(hair.point_data["color"])


def test_alembic_carries_the_pigments(melanin_groom, tmp_path):
    from follicle.io.dispatch import load_curves

    hair = melanin_groom.generate(50)
    path = save(hair, tmp_path / "groom.abc")
    back = load_curves(path)
    for name in ("melanin", "melanin_redness", "dye"):
        assert np.array_equal(back.curve_data[name], hair.curve_data[name]), name
