"""RenderMan RIB: Catmull-Rom Curves with duplicated end vertices, counts per the RISpec."""

import hashlib
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import follicle
from follicle import FormatError, HairCurves, InputError
from follicle.io.rib import format_floats, save_rib, save_rib_motion
from follicle.pipeline import groom_scene
from follicle.scene import Scene

COMPONENTS = {"width": 1, "Cs": 3, "Os": 3, "N": 3}


@pytest.fixture(scope="module")
def groom():
    return groom_scene(Scene())


@pytest.fixture(scope="module")
def hair(groom):
    return groom.generate(count=60)


def _parse(path):
    """The RIB as [request, args…] lists: strings unquoted, [...] arrays as lists."""
    requests, array = [], None
    lines = [line for line in path.read_text().splitlines() if not line.startswith("##")]
    for token in re.findall(r'"[^"]*"|\[|\]|[^\s\[\]"]+', "\n".join(lines)):
        if token == "[":
            array = []
        elif token == "]":
            requests[-1].append(array)
            array = None
        elif array is not None:
            array.append(token.strip('"'))
        elif token[0].isalpha():  # a bare word: a request
            requests.append([token])
        else:
            requests[-1].append(token.strip('"'))
    return requests


def _curves_requests(path):
    """Each Curves request as (nverts, wrap, {token: float array})."""
    out = []
    for req in _parse(path):
        if req[0] != "Curves":
            continue
        assert req[1] == "cubic"
        nverts = np.array(req[2], dtype=np.int64)
        params = {req[i]: np.array(req[i + 1], dtype=np.float64) for i in range(4, len(req), 2)}
        out.append((nverts, req[3], params))
    return out


def _strip_ends(p, nverts):
    """P of curves with duplicated end vertices, the duplicates checked and removed."""
    p = p.reshape(-1, 3)
    offs = np.concatenate([[0], np.cumsum(nverts)])
    assert np.array_equal(p[offs[:-1]], p[offs[:-1] + 1])
    assert np.array_equal(p[offs[1:] - 1], p[offs[1:] - 2])
    keep = np.ones(len(p), bool)
    keep[offs[:-1]] = keep[offs[1:] - 1] = False
    return p[keep]


def _check_counts(nverts, wrap, params, curves):
    assert wrap == "nonperiodic"
    nsegs = nverts - 3  # cubic nonperiodic, vstep 1: (nverts − 4) / 1 + 1
    varying = int(np.sum(nsegs + 1))
    assert params["P"].size == 3 * int(nverts.sum())
    for token, comps in COMPONENTS.items():
        if token in params:
            assert params[token].size == comps * varying, token
    c = len(nverts)
    assert params["uniform float[2] hair_uv"].size == 2 * c
    assert params["uniform float[2] strand_uv"].size == 2 * c
    assert params["uniform int hair_index"].size == params["uniform int strand_index"].size == c
    assert np.array_equal(nverts, curves.counts + 2) and varying == curves.point_count


def _close(rib_values, values):
    """Equal to 7 significant digits."""
    values = np.asarray(values, np.float64).reshape(-1)
    np.testing.assert_allclose(np.reshape(rib_values, -1), values, rtol=6e-7, atol=1e-30)


def test_structure_counts_and_values(tmp_path, hair):
    path = follicle.save(hair, tmp_path / "hair.rib")
    text = path.read_text()
    assert text.startswith("##RenderMan RIB\nversion 3.04\nAttributeBegin\n")
    assert text.endswith("AttributeEnd\n")
    reqs = [r[0] for r in _parse(path)]
    assert reqs == ["version", "AttributeBegin", "Basis", "Curves", "AttributeEnd"]
    assert _parse(path)[2] == ["Basis", "catmull-rom", "1", "catmull-rom", "1"]
    ((nverts, wrap, params),) = _curves_requests(path)
    _check_counts(nverts, wrap, params, hair)
    _close(_strip_ends(params["P"], nverts), hair.points)
    pd, cd = hair.point_data, hair.curve_data
    _close(params["width"], pd["width"])
    _close(params["Cs"], pd["color"])
    _close(params["Os"], np.repeat(pd["opacity"], 3))
    _close(params["N"], pd["normal"])
    _close(params["uniform float[2] hair_uv"], cd["root_uv"])
    _close(params["uniform float[2] strand_uv"], cd["strand_uv"])
    assert np.array_equal(params["uniform int hair_index"], cd["hair_id"])
    assert np.array_equal(params["uniform int strand_index"], cd["strand_id"])


def test_chunks_become_curves_requests(tmp_path, groom):
    chunks = list(groom.chunks(20, count=60))
    path = save_rib(iter(chunks), tmp_path / "hair.rib")
    requests = _curves_requests(path)
    assert len(requests) == 3
    for (nverts, wrap, params), chunk in zip(requests, chunks, strict=True):
        _check_counts(nverts, wrap, params, chunk)
        _close(_strip_ends(params["P"], nverts), chunk.points)


def test_plain_curves_get_defaults(tmp_path):
    rng = np.random.default_rng(2)
    plain = HairCurves.from_polylines([rng.random((2, 3)), rng.random((5, 3))])
    path = save_rib([plain, plain[:0], plain], tmp_path / "plain.rib")  # empty chunk: skipped
    requests = _curves_requests(path)
    assert len(requests) == 2
    nverts, _, params = requests[1]
    assert nverts.tolist() == [4, 7]
    assert params["constantwidth"].tolist() == [1e-4]
    assert params["uniform int hair_index"].tolist() == [2, 3]  # place in the file
    assert params["uniform int strand_index"].tolist() == [0, 0]
    assert not {"width", "Cs", "Os", "N", "uniform float[2] hair_uv"} & set(params)


def test_normals_can_be_left_out_and_bad_ids_are_refused(tmp_path, hair):
    path = save_rib(hair, tmp_path / "tubes.rib", normals=False)
    assert "N" not in _curves_requests(path)[0][2]
    big = HairCurves(hair.points, hair.offsets, curve_data={"hair_id": np.full(60, 2**40)})
    with pytest.raises(InputError, match="hair_id"):
        save_rib(big, tmp_path / "big.rib")
    assert not (tmp_path / "big.rib").exists()
    with pytest.raises(FormatError, match="cannot read '.rib'"):
        follicle.load_curves(path)


def test_same_curves_give_same_bytes(tmp_path, groom):
    a = save_rib(groom.chunks(25, count=60), tmp_path / "a.rib")
    b = save_rib(groom.chunks(25, count=60), tmp_path / "b.rib")
    assert hashlib.sha256(a.read_bytes()).digest() == hashlib.sha256(b.read_bytes()).digest()


def test_motion_block(tmp_path, hair):
    samples = [hair.with_points(hair.points + np.float32([0.01 * k, 0, 0])) for k in range(3)]
    path = save_rib_motion(samples, [0.0, 0.25, 0.5], tmp_path / "blur.rib")
    reqs = _parse(path)
    names = [r[0] for r in reqs]
    assert names == ["version", "AttributeBegin", "Basis", "MotionBegin", "Curves", "Curves",
                     "Curves", "MotionEnd", "AttributeEnd"]
    assert reqs[3][1] == ["0", "0.25", "0.5"]
    for (nverts, wrap, params), sample in zip(_curves_requests(path), samples, strict=True):
        _check_counts(nverts, wrap, params, sample)
        _close(_strip_ends(params["P"], nverts), sample.points)


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
    values = np.concatenate([
        (rng.standard_normal(20000) * 10.0 ** rng.integers(-30, 30, 20000)).astype(np.float32),
        np.float32([0, 1, -1, 1e-4, 9.9999999e-5, 1e7, 9999999.5, 123456.7, 0.5, 1e6, 1e-5,
                    1e-45, 3.4e38, -2.5e-12]),
    ])  # fmt: skip
    text = format_floats(values, 1).decode()
    assert text.split("\n") == [f"{float(v):.7g}" for v in values]
    assert format_floats(np.arange(1, 8, dtype=np.float32), 3) == b"1 2 3\n4 5 6\n7"


@settings(max_examples=300, deadline=None)
@given(st.floats(width=32, allow_nan=False, allow_infinity=False))
def test_printed_numbers_are_seven_correct_digits(x):
    text = format_floats(np.float32([x])).decode()
    if x == 0:
        assert text == "0"
        return
    exponent = int(np.floor(np.log10(abs(x))))
    assert abs(float(text) - x) <= 0.5 * 10.0 ** (exponent - 6) * (1 + 1e-9)
    assert len(text.replace("-", "").replace(".", "").split("e")[0].lstrip("0")) <= 7
