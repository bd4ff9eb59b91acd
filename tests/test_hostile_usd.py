"""Hostile USD: every bad file is one FormatError naming it, within 30 s and 2 GiB.

Files are made here: valid ones with ``follicle.save`` (.usda, .usdc, .usdz) and then
damaged, and hand-written ``.usda`` text with one thing wrong (bad transforms, units,
value types, element sizes, counts, NaN), composition bombs and cycles. Reading happens
in-process (usd-core runs in a guarded child anyway); crate and package corruption also
goes through the ``follicle`` command in a child under the README's limits. Writing to
a full disk (a file-size limit) must end in one line and leave no file behind.
"""

from __future__ import annotations

import io
import re
import struct
import time
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import follicle
from follicle import FormatError, HairCurves
from follicle.io.guard import died
from follicle.io.usd import load_usd
from follicle.io.usd_guard import check_container
from hostile import Outcome, assert_cli_refused, byte_damage, files, run_cli

POINTS = "[(0, 0, 0), (0, 1, 0), (0, 2, 0), (1, 0, 0), (1, 1, 0), (1, 2, 0)]"
NORMALS = (
    "normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1), "
    '(0, 0, 1)] (interpolation = "vertex")'
)


def usda(
    body: str = "",
    *,
    meta: str = "",
    counts: str = "int[] curveVertexCounts = [3, 3]",
    points: str = f"point3f[] points = {POINTS}",
) -> str:
    """A one-prim linear BasisCurves layer with ``body`` added to the prim and ``meta``
    to the layer's metadata."""
    return (
        f'#usda 1.0\n(\n    upAxis = "Y"\n    {meta}\n)\n\ndef BasisCurves "C"\n{{\n'
        f'    uniform token type = "linear"\n    {counts}\n    {points}\n    {body}\n}}\n'
    )


def test_the_template_reads(tmp_path):
    path = tmp_path / "ok.usda"
    path.write_text(usda(NORMALS, meta="metersPerUnit = 0.01"))
    back = load_usd(path)
    assert back.counts.tolist() == [3, 3]
    np.testing.assert_allclose(back.points[2], [0, 0.02, 0], atol=1e-7)


TRANSLATE = 'uniform token[] xformOpOrder = ["xformOp:translate"]'
WRONG_OP = r"could not read it \(Invalid combination of opType \(TypeTranslate\) and opVal"
BAD = {  # name: (layer text, what the message must say)
    "xformOpOrder names a missing op": (
        usda(TRANSLATE),
        r"/C: xformOpOrder of /C names"
        r" xformOp:translate, which it does",
    ),
    "xformOp a token": (usda('token xformOp:translate = "far"\n    ' + TRANSLATE), WRONG_OP),
    "xformOp a string": (usda('string xformOp:translate = "far"\n    ' + TRANSLATE), WRONG_OP),
    "scale 0 with normals": (
        usda(
            f"double3 xformOp:scale = (0, 1, 1)\n    {NORMALS}\n    "
            'uniform token[] xformOpOrder = ["xformOp:scale"]'
        ),
        r"/C: its transform is singular \(a scale of 0\)",
    ),
    "metersPerUnit 0": (usda(NORMALS, meta="metersPerUnit = 0"), r"metersPerUnit is 0\.0"),
    "metersPerUnit negative": (usda(meta="metersPerUnit = -1"), r"metersPerUnit is -1\.0"),
    "metersPerUnit nan": (usda(meta="metersPerUnit = nan"), r"metersPerUnit is nan"),
    "scalar widths": (usda("float widths = 1"), r"/C: widths is a single value"),
    "scalar counts": (
        usda(counts="int curveVertexCounts = 6"),
        r"/C: curveVertexCounts is a single value",
    ),
    "elementSize mismatch": (
        usda(
            "float[] primvars:f = [1, 2, 3, 4, 5, 6, 7] ("
            'interpolation = "vertex"\n elementSize = 2)'
        ),
        r"/C: primvar f has elementSize 2 but 7 values",
    ),
    "2-D points": (
        usda(points="float2[] points = [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2)]"),
        r"/C: points must be point3f\[\]|no points",
    ),
    "NaN in points": (
        usda(
            points="point3f[] points = [(0, 0, 0), (nan, 1, 0), (0, 2, 0),"
            " (1, 0, 0), (1, 1, 0), (1, 2, 0)]"
        ),
        r"/C: points: vertex 1 is not finite",
    ),
    "inf in points": (
        usda(
            points="point3f[] points = [(0, 0, 0), (0, 1, 0), (0, 2, 0),"
            " (1, 0, 0), (1, 1, 0), (1, 2, -inf)]"
        ),
        r"/C: points: vertex 5 is not finite",
    ),
    "counts do not sum to the points": (
        usda(counts="int[] curveVertexCounts = [3, 4]"),
        r"/C: curveVertexCounts sum to 7 but there are 6",
    ),
    "negative count": (
        usda(counts="int[] curveVertexCounts = [-1, 7]"),
        r"/C: curve 0 has a negative vertex count \(-1\)",
    ),
    "unknown interpolation": (
        usda('float[] primvars:f = [1, 2] (interpolation = "sideways")'),
        r"/C: f has 2 values; sideways interpolation",
    ),
    "not usda": ("PXR-USDC but called .usda", r"must start with '#usda 1.0'"),
    "syntax error": (
        '#usda 1.0\ndef BasisCurves "C" {\n  int[] curveVertexCounts = [3,\n',
        r"usd-core could not read it \(",
    ),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_usda_is_one_format_error_naming_the_file(tmp_path, name):
    text, message = BAD[name]
    path = tmp_path / "bad.usda"
    path.write_text(text)
    with pytest.raises(FormatError, match=message) as err:
        load_usd(path)
    assert str(err.value).startswith(f"{path}") and "\n" not in str(err.value)


def test_invalid_utf8_is_refused_before_usd_core_reads_it(tmp_path):
    path = tmp_path / "latin1.usda"
    path.write_bytes(usda('custom string note = "caf\xe9"').encode("latin-1"))
    with pytest.raises(FormatError, match=r"latin1.usda: byte \d+ is not UTF-8"):
        load_usd(path)


def test_a_usd_file_may_hold_text_or_crate_but_nothing_else(tmp_path, valid):
    text, crate, junk = tmp_path / "text.usd", tmp_path / "crate.usd", tmp_path / "junk.usd"
    text.write_bytes(valid["usda"])
    crate.write_bytes(valid["usdc"])
    junk.write_bytes(b"GIF89a")
    assert load_usd(text) == load_usd(crate)
    with pytest.raises(
        FormatError,
        match=r"junk.usd: not a USD crate \(no PXR-USDC header\)"
        r" nor USD text \(#usda\)",
    ):
        load_usd(junk)


def test_half_primvars_come_back_as_float32(tmp_path):
    path = tmp_path / "half.usda"
    path.write_text(
        usda(
            "half[] primvars:h = [0.5, 1, 2, 3, 4, 65504] (interpolation ="
            ' "vertex")\n    half3[] primvars:c = [(1, 2, 3), (4, 5, 6)] ('
            'interpolation = "uniform")'
        )
    )
    back = load_usd(path)
    assert back.point_data["h"].dtype == np.float32 and back.point_data["h"][-1] == 65504
    assert back.curve_data["c"].dtype == np.float32 and back.curve_data["c"].shape == (2, 3)


# ------------------------------------------------------------------ composition bombs
def _reference_bomb(folder, levels: int = 30, arc: str = "references") -> object:
    """L0 references L1 twice, L1 references L2 twice, …: 2^levels prims, 3 KB of text."""
    for i in range(levels):
        refs = "" if i == levels - 1 else f"(\n    {arc} = @L{i + 1}.usda@\n)"
        (folder / f"L{i}.usda").write_text(
            f'#usda 1.0\n(\n    defaultPrim = "R"\n)\n\ndef Xform "R"\n{{\n'
            f'    def Xform "a" {refs}\n    {{\n    }}\n'
            f'    def Xform "b" {refs}\n    {{\n    }}\n}}\n'
        )
    return folder / "L0.usda"


def _variant_bomb(folder, levels: int = 30) -> object:
    """As :func:`_reference_bomb`, the two referencing prims inside a variant."""
    for i in range(levels):
        refs = "" if i == levels - 1 else f"(\n references = @L{i + 1}.usda@\n)"
        (folder / f"L{i}.usda").write_text(
            '#usda 1.0\n(\n    defaultPrim = "R"\n)\ndef Xform "R" (\n    variants = {\n'
            '        string v = "on"\n    }\n    prepend variantSets = "v"\n)\n{\n'
            f'    variantSet "v" = {{\n        "on" {{\n            def Xform "a" {refs} {{}}\n'
            f'            def Xform "b" {refs} {{}}\n        }}\n    }}\n}}\n'
        )
    return folder / "L0.usda"


def _internal_bomb(folder, levels: int = 25) -> object:
    """One layer whose prim Ni has two children referencing N(i+1): 2^levels prims."""
    prims = []
    for i in range(levels):
        refs = f"(\n    references = </N{i + 1}>\n)" if i < levels - 1 else ""
        prims.append(
            f'def Xform "N{i}"\n{{\n    def Xform "a" {refs}\n    {{\n    }}\n'
            f'    def Xform "b" {refs}\n    {{\n    }}\n}}\n'
        )
    path = folder / "inner.usda"
    path.write_text("#usda 1.0\n\n" + "\n".join(prims))
    return path


def _sublayer_cycle(folder) -> object:
    (folder / "A.usda").write_text("#usda 1.0\n(\n    subLayers = [@B.usda@]\n)\n")
    (folder / "B.usda").write_text("#usda 1.0\n(\n    subLayers = [@A.usda@]\n)\n")
    return folder / "A.usda"


def _self_reference(folder) -> object:
    path = folder / "self.usda"
    path.write_text(
        usda().replace(
            'def BasisCurves "C"', 'def BasisCurves "C" (\n    references = @self.usda@</C>\n)'
        )
    )
    return path


@pytest.mark.parametrize(
    "make, message",
    [
        (_reference_bomb, r"L0.usda: composes more than 100000 prims"),
        (
            lambda folder: _reference_bomb(folder, arc="prepend payload"),
            r"L0.usda: composes more than 100000 prims",
        ),
        (_variant_bomb, r"L0.usda: composes more than 100000 prims"),
        (_internal_bomb, r"inner.usda: composes more than 100000 prims"),
        (_sublayer_cycle, r"A.usda: .*A.usda composes itself"),
        (_self_reference, r"self.usda: .*self.usda composes itself"),
    ],
)
def test_composition_bombs_and_cycles_are_refused_in_seconds(tmp_path, make, message):
    path = make(tmp_path)
    assert path.stat().st_size < 4000
    start = time.perf_counter()
    with pytest.raises(FormatError, match=message):
        load_usd(path)
    assert time.perf_counter() - start < 10


# ------------------------------------------------------------------ crate and package
@pytest.fixture(scope="module")
def valid(tmp_path_factory):
    """Bytes of a small valid .usda, .usdc and .usdz written by follicle."""
    folder = tmp_path_factory.mktemp("valid")
    rng = np.random.default_rng(7)
    curves = HairCurves.from_array(
        rng.random((3, 4, 3), dtype=np.float32), point_data={"width": np.full(12, 0.01, np.float32)}
    )
    return {
        ext: follicle.save(curves, folder / f"v.{ext}").read_bytes()
        for ext in ("usda", "usdc", "usdz")
    }


def _toc(data: bytes) -> int:
    return struct.unpack_from("<q", data, 16)[0]


def _crate_cases(crate: bytes) -> dict[str, tuple[bytes, str]]:
    toc = _toc(crate)
    far = crate[:16] + struct.pack("<q", 2**40) + crate[24:]
    many = crate[:toc] + struct.pack("<Q", 2**40) + crate[toc + 8 :]
    section = crate[: toc + 8 + 16] + struct.pack("<q", len(crate) - 4) + crate[toc + 32 :]
    return {
        "empty": (b"", r"no PXR-USDC header"),
        "text in a .usdc": (b"#usda 1.0\n", r"no PXR-USDC header"),
        "truncated": (crate[: len(crate) // 2], r"table of contents at byte \d+ lies outside"),
        "toc far away": (far, r"table of contents at byte 1099511627776 lies outside"),
        "toc negative": (crate[:16] + struct.pack("<q", -8) + crate[24:], r"at byte -8"),
        "absurd section count": (many, r"lists 1099511627776 sections"),
        "section past the end": (section, r"a crate section lies outside"),
    }


def _zip(members: list[tuple[str, bytes]], compress: int = zipfile.ZIP_STORED) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compress) as z:
        for name, data in members:
            z.writestr(name, data)
    return buffer.getvalue()


def _usdz_cases(valid: dict[str, bytes]) -> dict[str, tuple[bytes, str]]:
    crate = valid["usdc"]
    return {
        "not a zip": (b"PK\x03\x04 not really", r"not a readable zip"),
        "empty zip": (_zip([]), r"first file must be a USD layer"),
        "png first": (_zip([("a.png", b"x"), ("v.usdc", crate)]), r"must be a USD layer"),
        "deflated": (
            _zip([("v.usdc", crate)], zipfile.ZIP_DEFLATED),
            r"is compressed or not"
            r" 64-byte aligned",
        ),
        "unaligned": (_zip([("v.usdc", crate)]), r"is compressed or not 64-byte aligned"),
        "truncated": (valid["usdz"][: len(valid["usdz"]) // 2], r"not a readable zip"),
    }


CONTAINERS = [
    ("usdc", name)
    for name in [
        "empty",
        "text in a .usdc",
        "truncated",
        "toc far away",
        "toc negative",
        "absurd section count",
        "section past the end",
    ]
] + [
    ("usdz", name)
    for name in ["not a zip", "empty zip", "png first", "deflated", "unaligned", "truncated"]
]


@pytest.mark.parametrize("ext, name", CONTAINERS)
def test_a_corrupt_crate_or_package_is_refused_by_the_container_check(tmp_path, valid, ext, name):
    cases = _crate_cases(valid["usdc"]) if ext == "usdc" else _usdz_cases(valid)
    data, message = cases[name]
    path = tmp_path / f"bad.{ext}"
    path.write_bytes(data)
    with pytest.raises(FormatError, match=f"bad.{ext}: .*{message}"):
        check_container(path)
    with pytest.raises(FormatError, match=f"bad.{ext}: .*{message}"):
        load_usd(path)


@pytest.mark.parametrize("ext, damage", [("usdc", "toc far away"), ("usdz", "deflated")])
@pytest.mark.slow
def test_the_cli_prints_one_line_for_a_corrupt_crate_or_package(tmp_path, valid, ext, damage):
    cases = _crate_cases(valid["usdc"]) if ext == "usdc" else _usdz_cases(valid)
    (tmp_path / f"bad.{ext}").write_bytes(cases[damage][0])
    before = files(tmp_path)
    line = assert_cli_refused(run_cli("info", f"bad.{ext}", cwd=tmp_path), f"bad.{ext}")
    assert line.endswith("is it a valid USD file?") or "usdzip" in line
    assert files(tmp_path) == before


def test_usdz_whose_crate_toc_is_corrupt_is_refused(tmp_path, valid):
    data = bytearray(valid["usdz"])
    start = data.index(b"PXR-USDC")
    data[start + 16 : start + 24] = struct.pack("<q", 2**40)
    path = tmp_path / "toc.usdz"
    path.write_bytes(bytes(data))
    with pytest.raises(FormatError, match=r"toc.usdz: crate table of contents at byte"):
        load_usd(path)


@pytest.mark.parametrize(
    "limit, message",
    [
        (
            "MEMORY_BASE",
            r"out of memory|bad_alloc|crashed with SIG\w+, or needed more than|needed"
            r" more than",
        ),
        ("SECONDS_BASE", r"took more than 0 s"),
    ],
)
def test_usd_core_out_of_memory_or_time_is_a_format_error(tmp_path, monkeypatch, limit, message):
    """The child's limits, made tiny: one line naming the file, not a crash or a hang."""
    path = follicle.save(HairCurves.from_array(np.zeros((2, 3, 3))), tmp_path / "ok.usdc")
    monkeypatch.setattr(f"follicle.io.guard.{limit}", 64 << 20 if "MEMORY" in limit else 0)
    monkeypatch.setattr("follicle.io.guard.BYTES_PER_SECOND", 2**60)
    with pytest.raises(FormatError, match=f"ok.usdc: usd-core could not read it \\(.*({message})"):
        load_usd(path)


def test_a_child_killed_by_a_signal_is_named_as_a_crash(tmp_path):
    """No file found here crashes usd-core 26.11 (2,000 crate mutations tried), so the
    crash line is checked from the reply the server gives for a child killed by SIGSEGV."""
    error = died(
        tmp_path / "x.usdc",
        {"code": -11, "timed_out": False},
        tmp_path / "none",
        3 << 29,
        6.0,
        "usd-core",
        "is it a valid USD file?",
    )
    assert (
        str(error) == f"{tmp_path / 'x.usdc'}: usd-core could not read it (crashed with"
        " SIGSEGV, or needed more than 1.5 GiB); is it a valid USD file?"
    )


def test_the_same_file_gives_the_same_answer(tmp_path, valid):
    path = tmp_path / "v.usdc"
    path.write_bytes(valid["usdc"])
    first = load_usd(path)
    assert first == load_usd(path)
    # and it is the right answer, not merely the same one: the fixture's curves
    points = np.random.default_rng(7).random((3, 4, 3), dtype=np.float32).reshape(-1, 3)
    np.testing.assert_array_equal(first.points, points)
    np.testing.assert_array_equal(first.offsets, [0, 4, 8, 12])
    np.testing.assert_array_equal(first.point_data["width"], np.full(12, 0.01, np.float32))
    bad = tmp_path / "bad.usda"
    bad.write_text(BAD["scale 0 with normals"][0])
    messages = set()
    for _ in range(2):
        with pytest.raises(FormatError) as err:
            load_usd(bad)
        messages.add(str(err.value))
    assert len(messages) == 1


# ------------------------------------------------------------------ fuzz
TOKENS = [
    "nan",
    "inf",
    "-",
    "[",
    "]",
    "(",
    ")",
    "@",
    "@L.usda@",
    "</C>",
    "\\",
    "\n",
    '"',
    "0",
    "-1",
    "99999999999999999999",
    "float",
    "half",
    "int[]",
    "def",
    "over",
    "{",
    "}",
    "references = @v.usda@",
    "elementSize = 3",
    'interpolation = "bad"',
    "\x00",
    "é",
    "xformOp:scale",
    "#usda 1.0",
]


@st.composite
def text_damage(draw, text: str) -> bytes:
    """``text`` with a few tokens inserted or a stretch deleted."""
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(text)))
        if draw(st.booleans()):
            text = text[:at] + draw(st.sampled_from(TOKENS)) + text[at:]
        else:
            text = text[:at] + text[at + draw(st.integers(1, 20)) :]
    return text.encode()


def _read_or_refuse(path) -> None:
    try:
        result = load_usd(path)
    except FormatError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc), str(exc)
    else:
        assert isinstance(result, HairCurves)


@pytest.mark.parametrize("ext, examples", [("usda", 80), ("usdc", 80), ("usdz", 40)])
@pytest.mark.slow
def test_damaged_usd_gives_curves_or_a_format_error(tmp_path, valid, ext, examples):
    path = tmp_path / f"fuzz.{ext}"
    strategy = text_damage(valid[ext].decode()) if ext == "usda" else byte_damage(valid[ext])

    @settings(
        max_examples=examples,
        deadline=None,
        derandomize=True,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    )
    @given(strategy)
    def check(data):
        path.write_bytes(data)
        _read_or_refuse(path)

    check()


# ------------------------------------------------------------------ writing
def _write_limited(folder, ext: str, limit: int) -> Outcome:
    """``follicle export`` to ``out.{ext}`` under a file-size limit of ``limit`` bytes; the
    CLI sets SIGXFSZ aside itself, so writes fail with EFBIG."""
    out = f"out.{ext}"
    return run_cli("export", "in.hair", "-o", out, cwd=folder, timeout=60, file_size=limit)


@pytest.mark.parametrize(
    "ext, room",
    [
        ("usdc", 0.5),  # the crate itself
        ("usda", 1.5),  # the crate fits (in the temporary folder); the text export does not
        ("usdz", 1.0),  # the crate fits; the package around it does not
    ],
)
@pytest.mark.slow
def test_a_full_disk_is_one_line_and_leaves_nothing(tmp_path, ext, room):
    rng = np.random.default_rng(1)
    curves = HairCurves.from_array(rng.random((2000, 8, 3), dtype=np.float32))
    follicle.save(curves, tmp_path / "in.hair")
    probe = follicle.save(curves, tmp_path / "probe.usdc")
    limit = int(room * probe.stat().st_size) + 64
    probe.unlink()
    before = files(tmp_path)
    out = _write_limited(tmp_path, ext, limit)
    line = assert_cli_refused(out, f"out.{ext}")
    assert re.fullmatch(
        rf"error: out\.{ext}: (usd-core )?could not write it \((Error occurred"
        r" writing file: )?File too large\); free disk space or write elsewhere",
        line,
    ), line
    assert files(tmp_path) == before
