"""RenderMan RIB: Catmull-Rom Curves with duplicated end vertices, counts per the RISpec."""

import hashlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import follicle
from follicle import FormatError, HairCurves, InputError
from follicle.io.rib import format_floats, save_rib, save_rib_motion
from follicle.pipeline import groom_scene
from follicle.scene import Scene
from hairfiles import check_counts, close7, curves_requests, parse_rib, strip_ends


@pytest.fixture(scope="module")
def groom():
    return groom_scene(Scene())


@pytest.fixture(scope="module")
def hair(groom):
    return groom.generate(count=60)


@pytest.mark.slow
def test_structure_counts_and_values(tmp_path, hair):
    path = follicle.save(hair, tmp_path / "hair.rib")
    text = path.read_text()
    assert text.startswith("##RenderMan RIB\nversion 3.04\nAttributeBegin\n")
    assert text.endswith("AttributeEnd\n")
    reqs = [r[0] for r in parse_rib(path)]
    assert reqs == ["version", "AttributeBegin", "Basis", "Curves", "AttributeEnd"]
    assert parse_rib(path)[2] == ["Basis", "catmull-rom", "1", "catmull-rom", "1"]
    ((nverts, wrap, params),) = curves_requests(path)
    check_counts(nverts, wrap, params, hair)
    close7(strip_ends(params["P"], nverts), hair.points)
    pd, cd = hair.point_data, hair.curve_data
    close7(params["width"], pd["width"])
    close7(params["Cs"], pd["color"])
    close7(params["Os"], np.repeat(pd["opacity"], 3))
    close7(params["N"], pd["normal"])
    close7(params["uniform float[2] hair_uv"], cd["root_uv"])
    close7(params["uniform float[2] strand_uv"], cd["strand_uv"])
    assert np.array_equal(params["uniform int hair_index"], cd["hair_id"])
    assert np.array_equal(params["uniform int strand_index"], cd["strand_id"])


@pytest.mark.slow
def test_chunks_becomecurves_requests(tmp_path, groom):
    chunks = list(groom.chunks(20, count=60))
    path = save_rib(iter(chunks), tmp_path / "hair.rib")
    requests = curves_requests(path)
    assert len(requests) == 3
    for (nverts, wrap, params), chunk in zip(requests, chunks, strict=True):
        check_counts(nverts, wrap, params, chunk)
        close7(strip_ends(params["P"], nverts), chunk.points)


def test_plain_curves_get_defaults(tmp_path):
    rng = np.random.default_rng(2)
    plain = HairCurves.from_polylines([rng.random((2, 3)), rng.random((5, 3))])
    path = save_rib([plain, plain[:0], plain], tmp_path / "plain.rib")  # empty chunk: skipped
    requests = curves_requests(path)
    assert len(requests) == 2
    nverts, _, params = requests[1]
    assert nverts.tolist() == [4, 7]
    assert params["constantwidth"].tolist() == [1e-4]
    assert params["uniform int hair_index"].tolist() == [2, 3]  # place in the file
    assert params["uniform int strand_index"].tolist() == [0, 0]
    assert not {"width", "Cs", "Os", "N", "uniform float[2] hair_uv"} & set(params)


def test_normals_can_be_left_out_and_bad_ids_are_refused(tmp_path, hair):
    path = save_rib(hair, tmp_path / "tubes.rib", normals=False)
    assert "N" not in curves_requests(path)[0][2]
    big = HairCurves(hair.points, hair.offsets, curve_data={"hair_id": np.full(60, 2**40)})
    with pytest.raises(InputError, match="hair_id"):
        save_rib(big, tmp_path / "big.rib")
    assert not (tmp_path / "big.rib").exists()
    with pytest.raises(FormatError, match="cannot read '.rib'"):
        follicle.load_curves(path)


@pytest.mark.slow
def test_same_curves_give_same_bytes(tmp_path, groom):
    a = save_rib(groom.chunks(25, count=60), tmp_path / "a.rib")
    b = save_rib(groom.chunks(25, count=60), tmp_path / "b.rib")
    assert hashlib.sha256(a.read_bytes()).digest() == hashlib.sha256(b.read_bytes()).digest()


def test_motion_block(tmp_path, hair):
    samples = [hair.with_points(hair.points + np.float32([0.01 * k, 0, 0])) for k in range(3)]
    path = save_rib_motion(samples, [0.0, 0.25, 0.5], tmp_path / "blur.rib")
    reqs = parse_rib(path)
    names = [r[0] for r in reqs]
    assert names == [
        "version",
        "AttributeBegin",
        "Basis",
        "MotionBegin",
        "Curves",
        "Curves",
        "Curves",
        "MotionEnd",
        "AttributeEnd",
    ]
    assert reqs[3][1] == ["0", "0.25", "0.5"]
    for (nverts, wrap, params), sample in zip(curves_requests(path), samples, strict=True):
        check_counts(nverts, wrap, params, sample)
        close7(strip_ends(params["P"], nverts), sample.points)


@pytest.mark.parametrize(
    ("samples", "times", "match"),
    [
        ("two", [0, 1], "sequence of HairCurves"),
        ([None, None], [0, 1], "sample 0 is a NoneType"),
        (["h"], [0], "two or more samples"),
        (["h", "h"], [0], "one time each"),
        (["h", "h"], [1, 1], "strictly increasing"),
        (["h", "h"], [0, np.nan], "finite"),
        (["h", "short"], [0, 1], "sample 1 differs"),
    ],
)
def test_motion_arguments_are_checked(tmp_path, hair, samples, times, match):
    named = {"h": hair, "short": hair[:-1]}
    samples = [named.get(s, s) for s in samples] if isinstance(samples, list) else samples
    with pytest.raises(InputError, match=match):
        save_rib_motion(samples, times, tmp_path / "m.rib")
    assert not (tmp_path / "m.rib").exists()


def test_numbers_print_like_c_percent_7g():
    rng = np.random.default_rng(5)
    values = np.concatenate(
        [
            (rng.standard_normal(20000) * 10.0 ** rng.integers(-30, 30, 20000)).astype(np.float32),
            np.float32(
                [
                    0,
                    1,
                    -1,
                    1e-4,
                    9.9999999e-5,
                    1e7,
                    9999999.5,
                    123456.7,
                    0.5,
                    1e6,
                    1e-5,
                    1e-45,
                    3.4e38,
                    -2.5e-12,
                ]
            ),
        ]
    )
    text = format_floats(values, 1).decode()
    assert text.split("\n") == [f"{float(v):.7g}" for v in values]
    assert format_floats(np.arange(1, 8, dtype=np.float32), 3) == b"1 2 3\n4 5 6\n7"


@settings(max_examples=300, deadline=None)
@given(st.floats(width=32, allow_nan=False, allow_infinity=False))
@pytest.mark.slow
def test_printed_numbers_are_seven_correct_digits(x):
    text = format_floats(np.float32([x])).decode()
    if x == 0:
        assert text == "0"
        return
    exponent = int(np.floor(np.log10(abs(x))))
    assert abs(float(text) - x) <= 0.5 * 10.0 ** (exponent - 6) * (1 + 1e-9)
    assert len(text.replace("-", "").replace(".", "").split("e")[0].lstrip("0")) <= 7
