"""Hair file formats: round trips, files built from the specifications, streaming and
determinism, and the errors bad files and arguments give."""

import re
import struct

import numpy as np
import pytest

import follicle
from follicle import FormatError, HairCurves, InputError, spline
from follicle.io.dispatch import READERS, WRITERS
from hairfiles import hair, tfx3_table

OURS = (".hair", ".tfx", ".obj", ".pbrt", ".txt")


def test_every_format_is_registered():
    assert set(OURS) <= set(WRITERS)
    assert set(OURS) - {".pbrt"} <= set(READERS) and ".pbrt" not in READERS


# ------------------------------------------------------------------ round trips
def test_cyhair_round_trip_keeps_everything_it_stores(tmp_path):
    c = hair()
    back = follicle.load_curves(follicle.save(c, tmp_path / "h.hair"))
    np.testing.assert_array_equal(back.offsets, c.offsets)
    np.testing.assert_array_equal(back.points, c.points)
    np.testing.assert_array_equal(back.point_data["width"], c.point_data["width"])
    np.testing.assert_array_equal(back.point_data["color"], c.point_data["color"])
    np.testing.assert_allclose(back.point_data["opacity"], c.point_data["opacity"], atol=1e-7)
    assert back.curve_data == {}  # cyHair has no per-hair data


def test_cyhair_header_and_default_segments(tmp_path):
    c = hair(counts=(5, 5, 5))
    data = follicle.save(c, tmp_path / "h.hair").read_bytes()
    magic, hairs, points, flags, dseg = struct.unpack_from("<4s4I", data)
    assert (magic, hairs, points, dseg) == (b"HAIR", 3, 15, 4)
    assert flags == 2 | 4 | 8 | 16  # no segments array: every hair has 5 vertices
    assert data[40:48] == b"follicle" and len(data) == 128 + 15 * (12 + 4 + 4 + 12)
    transparency = np.frombuffer(data, "<f4", 15, 128 + 15 * 16)
    np.testing.assert_allclose(transparency, 1 - c.point_data["opacity"], atol=1e-7)
    data = follicle.save(hair(counts=(5, 3)), tmp_path / "v.hair").read_bytes()
    assert struct.unpack_from("<I", data, 12)[0] & 1
    assert np.frombuffer(data, "<u2", 2, 128).tolist() == [4, 2]


def test_cyhair_without_attributes_reads_the_defaults(tmp_path):
    c = HairCurves.from_array(np.random.default_rng(1).normal(size=(2, 3, 3)))
    back = follicle.load_curves(follicle.save(c, tmp_path / "h.hair"))
    np.testing.assert_array_equal(back.points, c.points)
    np.testing.assert_allclose(back.point_data["width"], 1e-4)
    np.testing.assert_array_equal(back.point_data["opacity"], 1.0)
    np.testing.assert_allclose(back.point_data["color"], 0.5)


def test_tfx_round_trip_and_header(tmp_path):
    c = hair(counts=(8, 8, 8))
    path = follicle.save(c, tmp_path / "h.tfx")
    back = follicle.load_curves(path)
    np.testing.assert_array_equal(back.points, c.points)
    np.testing.assert_array_equal(back.curve_data["root_uv"], c.curve_data["root_uv"])
    np.testing.assert_array_equal(back.point_data["color"], c.point_data["color"])
    np.testing.assert_array_equal(back.point_data["opacity"], c.point_data["opacity"])
    roots = c.point_data["width"][c.offsets[:-1]]
    np.testing.assert_array_equal(back.point_data["width"], np.repeat(roots, 8))
    data = path.read_bytes()
    version, strands, n, *offsets = struct.unpack_from("<f7I", data)
    assert (version, strands, n) == (4.0, 3, 8)
    assert all(o % 8 == 0 and o >= 160 for o in offsets) and len(data) >= offsets[-1] + 16 * 24
    xyzw = np.frombuffer(data, "<f4", 24 * 4, offsets[0]).reshape(3, 8, 4)
    assert (xyzw[:, 0, 3] == 0).all() and (xyzw[:, 1:, 3] == 1).all()  # immovable roots
    vertex_uv = np.frombuffer(data, "<f4", 24 * 2, offsets[2]).reshape(3, 8, 2)
    root_u = c.curve_data["root_uv"][:, :1]
    np.testing.assert_array_equal(vertex_uv[..., 0], np.repeat(root_u, 8, axis=1))
    np.testing.assert_allclose(vertex_uv[:, [0, -1], 1], [[0, 1]] * 3)


def test_tfx_resamples_to_a_fixed_count_by_arc_length(tmp_path):
    bent = [[0, 0, 0], [0, 0.1, 0], [0, 0.1, 0.3]]  # length 0.4
    straight = np.stack([np.zeros(7), np.linspace(0, 1, 7) ** 2, np.zeros(7)], axis=1)
    c = HairCurves.from_polylines([bent, straight, np.ones((4, 3)) * [1, 2, 3]])
    back = follicle.load_curves(follicle.save(c, tmp_path / "h.tfx", vertices=5))
    assert back.uniform_count() == 5
    pts = back.as_array()
    np.testing.assert_allclose(
        pts[0], [[0, 0, 0], [0, 0.1, 0], [0, 0.1, 0.1], [0, 0.1, 0.2], [0, 0.1, 0.3]], atol=1e-7
    )
    np.testing.assert_allclose(pts[1, :, 1], np.linspace(0, 1, 5), atol=1e-7)
    np.testing.assert_array_equal(pts[2], np.ones((5, 3)) * [1, 2, 3])  # zero length: kept
    # the default count is the first curve's; curves of that count are kept exactly
    back = follicle.load_curves(follicle.save(c, tmp_path / "d.tfx"))
    assert back.uniform_count() == 3
    np.testing.assert_array_equal(back.as_array()[0], np.asarray(bent, np.float32))
    with pytest.raises(InputError, match="vertices"):
        follicle.save(c, tmp_path / "x.tfx", vertices=1)


def test_obj_round_trip_of_positions(tmp_path):
    c = hair()
    path = follicle.save(c, tmp_path / "h.obj")
    text = path.read_text()
    assert text.startswith("# follicle hair curves\n")
    assert text.count("\nv ") == c.point_count
    assert re.findall(r"^l .*$", text, re.M)[1] == "l 5 6 7 8 9 10"
    back = follicle.load_curves(path)
    assert back == HairCurves(c.points, c.offsets)


def test_obj_reader_handles_relative_indices_continuations_and_other_records(tmp_path):
    path = tmp_path / "x.obj"
    path.write_text(
        "# made by hand\r\nmtllib x.mtl\no hair\nv 0 0 0\nv 1 0 0 1.0\nv 1 1 0\n"
        "vt 0 0\nvn 0 1 0\nl 1 \\\n  2/1 -1\ng other\nl -2 \\\r\n-1\nf 1 2 3\n"
        "v 5 5 5\nl 4 1\n"
    )
    back = follicle.load_curves(path)
    np.testing.assert_array_equal(back.offsets, [0, 3, 5, 7])
    np.testing.assert_array_equal(
        back.points, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [1, 0, 0], [1, 1, 0], [5, 5, 5], [0, 0, 0]]
    )


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("v 0 0 0\nv 1 1 1\n\nl 2\n", "line 4: an 'l' record has fewer than 2 vertices"),
        ("v 0 0 0\nl 1 \\\n\nl 1 1\n", "line 2: an 'l' record has fewer than 2"),
        ("v 0 0 0\nl 1 \\\n 1\nv 1 x 1\n", "line 4: a 'v' record needs three numbers"),
        ("v 0 0\nl 1 1\n", "line 1: a 'v' record needs three numbers"),
        ("v 0 0 0\nv 1 1 x\n", "line 2: a 'v' record needs three numbers"),
        ("v 0 0 0\nv 1 1 nan\n", "line 2: a 'v' record"),
        ("v 0 0 1e39\n", "line 1: a vertex coordinate is not finite"),
        ("v 0 0 0\nl 1 2\n", "line 2: an 'l' index refers to a vertex that does not exist"),
        ("v 0 0 0\nl 1 -2\n", "line 2: an 'l' index refers to a vertex that does not exist"),
        ("v 0 0 0\nl 0 1\n", "line 2: an 'l' index is 0"),
        ("v 0 0 0\nl 1 1.5\n", "line 2: an 'l' index is not an integer"),
    ],
)
def test_obj_errors_name_the_line(tmp_path, text, message):
    path = tmp_path / "bad.obj"
    path.write_text(text)
    with pytest.raises(FormatError, match=re.escape(f"{path}: {message}")):
        follicle.load_curves(path)


def test_mitsuba_file_is_an_interpolating_bspline(tmp_path):
    c = hair()
    path = follicle.save(c, tmp_path / "h.txt")
    blocks = path.read_text().strip("\n").split("\n\n")
    assert [len(b.splitlines()) for b in blocks] == list(c.counts + 2)
    for i, block in enumerate(blocks):
        ctrl = np.array([line.split() for line in block.splitlines()], dtype=np.float64)
        knots = (ctrl[:-2] + 4 * ctrl[1:-1] + ctrl[2:]) / 6  # where each segment starts/ends
        np.testing.assert_allclose(knots[:, :3], c.curve(i), atol=1e-8)
        np.testing.assert_allclose(
            2 * knots[:, 3],
            c.point_data["width"][c.offsets[i] : c.offsets[i + 1]],
            rtol=1e-5,
            atol=1e-10,
        )
        # zero curvature at the ends: c0 - 2 c1 + c2 = 0
        np.testing.assert_allclose(ctrl[0] - 2 * ctrl[1] + ctrl[2], 0, atol=1e-7)
    back = follicle.load_curves(path)
    np.testing.assert_array_equal(back.offsets, c.offsets)
    np.testing.assert_allclose(back.points, c.points, atol=1e-8)
    np.testing.assert_allclose(
        back.point_data["width"], c.point_data["width"], rtol=1e-5, atol=1e-10
    )


def test_mitsuba_reader_takes_any_bspline_file(tmp_path):
    path = tmp_path / "m.txt"
    path.write_text(
        "0 0 0 1\n  6 0 0 1\t\n0 6 0 1\n0 0 6 4\r\n\n\n1 1 1 0.5\n1 1 1 0.5\n"
        "1 1 1 0.5\n1 1 1 0.5\n1 1 1 0.5"
    )
    back = follicle.load_curves(path)
    np.testing.assert_array_equal(back.offsets, [0, 2, 5])
    np.testing.assert_allclose(back.points[:2], [[4, 1, 0], [1, 4, 1]])
    np.testing.assert_allclose(back.point_data["width"], [2, 3, 1, 1, 1])
    for text, message in [
        ("0 0 0 1\n0 0 0 1\n0 0 0 1\n", "line 1: a curve has fewer than 4"),
        ("0 0 0 1\n0 0 0\n", "line 2: expected four numbers"),
        ("0 0 0 1 2\n", "line 1: expected four numbers"),
        ("0 0 0 1e40\n", "line 1: a value is not finite"),
    ]:
        path.write_text(text)
        with pytest.raises(FormatError, match=re.escape(f"{path}: {message}")):
            follicle.load_curves(path)


def test_pbrt_curves_are_the_catmull_rom_curves_as_bezier_segments(tmp_path):
    c = hair()
    text = follicle.save(c, tmp_path / "h.pbrt").read_text()
    assert text.startswith("# follicle hair curves for pbrt-v4")
    assert 'MakeNamedMaterial "follicle_hair" "string type" "hair"' in text
    assert '  NamedMaterial "follicle_hair"' in text
    assert text.index("AttributeBegin") < text.index("Shape") and text.endswith("AttributeEnd\n")
    shapes = re.findall(
        r'Shape "curve" "string type" "cylinder" "float width0" (\S+) '
        r'"float width1" (\S+) "point3 P" \[ ([^\]]*) \]',
        text,
    )
    assert len(shapes) == c.curve_count == text.count("Shape")
    u = np.array([0.0, 0.3, 0.5, 1.0])[:, None]
    bern = np.hstack([(1 - u) ** 3, 3 * (1 - u) ** 2 * u, 3 * (1 - u) * u**2, u**3])
    for i, (w0, w1, coords) in enumerate(shapes):
        w = c.point_data["width"][c.offsets[i] : c.offsets[i + 1]]
        assert float(w0) == pytest.approx(w[0]) and float(w1) == pytest.approx(w[-1])
        ctrl = np.array(coords.split(), dtype=np.float64).reshape(-1, 3)
        n = c.counts[i]
        assert len(ctrl) == 3 * (n - 1) + 1
        for s in range(n - 1):  # each Bézier segment is the Catmull-Rom segment
            pts = bern @ ctrl[3 * s : 3 * s + 4]
            expect = spline.evaluate(c.curve(i), (s + u[:, 0]) / (n - 1))
            np.testing.assert_allclose(pts, expect, atol=1e-7)


# ------------------------------------------------------------------ from the specifications
def test_cyhair_built_by_hand(tmp_path):
    header = struct.pack(
        "<4s4I5f88s", b"HAIR", 2, 5, 1 | 2 | 4, 0, 9.0, 0.25, 0.1, 0.2, 0.3, b"made by hand"
    )
    segments = struct.pack("<2H", 2, 1)
    points = struct.pack("<15f", *range(15))
    thickness = struct.pack("<5f", 1, 2, 3, 4, 5)
    path = tmp_path / "hand.hair"
    path.write_bytes(header + segments + points + thickness)
    c = follicle.load_curves(path)
    np.testing.assert_array_equal(c.offsets, [0, 3, 5])
    np.testing.assert_array_equal(c.points, np.arange(15).reshape(5, 3))
    np.testing.assert_array_equal(c.point_data["width"], [1, 2, 3, 4, 5])
    np.testing.assert_array_equal(c.point_data["opacity"], 0.75)
    np.testing.assert_allclose(c.point_data["color"], [[0.1, 0.2, 0.3]] * 5)
    # no segments array: every hair has the default segments + 1 points
    path.write_bytes(
        struct.pack("<4s4I5f88s", b"HAIR", 2, 8, 2, 3, 1, 0, 0, 0, 0, b"")
        + struct.pack("<24f", *range(24))
    )
    np.testing.assert_array_equal(follicle.load_curves(path).offsets, [0, 4, 8])


def test_tfx3_files_built_by_hand(tmp_path):
    rng = np.random.default_rng(5)
    vertices = rng.random((3 * 4, 3))
    path = tmp_path / "t3.tfx"
    path.write_bytes(
        tfx3_table(
            3, 4, vertices, thickness=[1, 2, 3], uv=rng.random((3, 2)), colors=rng.random((12, 4))
        )
    )
    c = follicle.load_curves(path)
    np.testing.assert_array_equal(c.offsets, [0, 4, 8, 12])
    np.testing.assert_array_equal(c.points, vertices.astype(np.float32))
    np.testing.assert_array_equal(c.point_data["width"], np.repeat([1, 2, 3], 4))
    assert c.curve_data["root_uv"].shape == (3, 2) and c.point_data["color"].shape == (12, 3)
    # packed: float3 vertices straight after the 144-byte preamble, no offset table
    path.write_bytes(
        struct.pack("<f4I31I", 3.0, 3, 4, 0, 1, *[0] * 31) + vertices.astype("<f4").tobytes()
    )
    c = follicle.load_curves(path)
    np.testing.assert_array_equal(c.points, vertices.astype(np.float32))
    assert set(c.point_data) == set() and c.uniform_count() == 4


def test_tfx4_built_by_hand(tmp_path):
    xyzw = np.arange(2 * 3 * 4, dtype="<f4")
    header = struct.pack("<f7I32I", 4.1, 2, 3, 160, 0, 0, 160 + 96, 0, *[0] * 32)
    path = tmp_path / "t4.tfx"
    path.write_bytes(header + xyzw.tobytes() + struct.pack("<2f", 5e-5, 6e-5))
    c = follicle.load_curves(path)
    np.testing.assert_array_equal(c.points, xyzw.reshape(6, 4)[:, :3])
    np.testing.assert_array_equal(c.point_data["width"], np.float32([5e-5] * 3 + [6e-5] * 3))


@pytest.mark.parametrize(
    ("patch", "message"),
    [
        ({0: struct.pack("<f", 2.0)}, "header version 2.0 is not a TressFX"),
        ({12: struct.pack("<I", 164)}, "positions offset 164 is not a multiple of 8"),
        ({12: struct.pack("<I", 8)}, "positions offset 8 points into the 160-byte header"),
        ({24: struct.pack("<I", 200)}, "positions and thickness sections overlap"),
        ({4: struct.pack("<I", 10**9)}, "numHairStrands 1000000000"),
        ({8: struct.pack("<I", 1)}, "numVerticesPerStrand 1: a strand needs at least 2"),
        ({12: struct.pack("<I", 0)}, "vertex positions offset is 0"),
        ({164: struct.pack("<f", np.nan)}, "positions: entry 0 is not finite"),
    ],
)
def test_tfx_errors_name_the_field(tmp_path, patch, message):
    data = bytearray(follicle.save(hair(counts=(4, 4)), tmp_path / "h.tfx").read_bytes())
    for at, value in patch.items():
        data[at : at + len(value)] = value
    path = tmp_path / "bad.tfx"
    path.write_bytes(bytes(data))
    with pytest.raises(FormatError, match=re.escape(str(path)) + ".*" + re.escape(message)):
        follicle.load_curves(path)


@pytest.mark.parametrize(
    ("patch", "message"),
    [
        ({0: b"HAIX"}, "magic b'HAIX' is not b'HAIR'"),
        ({4: struct.pack("<I", 4)}, "hair_count 4 and point_count 11 (flags 0x1f) need 488 bytes"),
        ({8: struct.pack("<I", 10**7)}, "point_count 10000000 (flags 0x1f) need"),
        ({12: struct.pack("<I", 1)}, "flags 0x1 say the file has no points array"),
        ({128: struct.pack("<2H", 0, 9)}, "hair 0 has 0 segments"),
        ({128: struct.pack("<H", 9)}, "segments add up to 17 points but header point_count is 11"),
        ({132: struct.pack("<f", np.inf)}, "points: entry 0 is not finite"),
    ],
)
def test_cyhair_errors_name_the_field(tmp_path, patch, message):
    data = bytearray(follicle.save(hair(counts=(4, 7)), tmp_path / "h.hair").read_bytes())
    for at, value in patch.items():
        data[at : at + len(value)] = value
    path = tmp_path / "bad.hair"
    path.write_bytes(bytes(data))
    with pytest.raises(FormatError, match=re.escape(str(path)) + ".*" + re.escape(message)):
        follicle.load_curves(path)


def test_missing_file_is_a_format_error(tmp_path):
    for ext in set(OURS) - {".pbrt"}:
        with pytest.raises(FormatError, match="no such file"):
            follicle.load_curves(tmp_path / f"none{ext}")


# ------------------------------------------------------------------ streaming, determinism
@pytest.mark.parametrize("ext", OURS)
def test_chunks_write_the_same_bytes_as_the_whole(tmp_path, ext):
    c = hair(counts=(4, 6, 2, 5, 3, 4))
    whole = follicle.save(c, tmp_path / f"whole{ext}").read_bytes()
    parts = follicle.save(iter([c[:1], c[1:4], c[4:]]), tmp_path / f"parts{ext}").read_bytes()
    again = follicle.save(hair(counts=(4, 6, 2, 5, 3, 4)), tmp_path / f"again{ext}").read_bytes()
    assert parts == whole == again
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        f"again{ext}",
        f"parts{ext}",
        f"whole{ext}",
    ]


@pytest.mark.parametrize("ext", [".hair", ".tfx"])
def test_chunks_with_other_attributes_are_refused_and_nothing_is_written(tmp_path, ext):
    c = hair()
    bare = HairCurves(c.points, c.offsets, {}, dict(c.curve_data))
    with pytest.raises(InputError, match="chunk 1 has attributes"):
        follicle.save(iter([c, bare]), tmp_path / f"x{ext}")
    assert list(tmp_path.iterdir()) == []


def test_cyhair_refuses_hairs_longer_than_uint16_segments(tmp_path):
    long = HairCurves.from_polylines([np.zeros((3, 3)), np.zeros((65537, 3))])
    with pytest.raises(InputError, match="hair 1 has 65537 vertices; cyHair stores at most 65536"):
        follicle.save(long, tmp_path / "x.hair")
    assert list(tmp_path.iterdir()) == []
    follicle.save(long[:1], tmp_path / "ok.hair")


@pytest.mark.parametrize("ext", OURS)
def test_empty_hair_writes_a_valid_file(tmp_path, ext):
    empty = HairCurves(np.zeros((0, 3)), [0])
    path = follicle.save(empty, tmp_path / f"e{ext}")
    if ext in READERS:
        assert follicle.load_curves(path).curve_count == 0


# ------------------------------------------------------------------ guides
@pytest.mark.slow
def test_guides_load_from_a_cyhair_file_onto_the_builtin_head(tmp_path):
    from follicle.groom.builtin_guides import builtin_guides

    mesh = follicle.load_mesh("builtin:head")
    curves = builtin_guides("short", mesh)
    path = follicle.save(curves, tmp_path / "guides.hair")
    guides = follicle.load_guides(path, mesh)  # roots found again from the first vertices
    reference = follicle.load_guides(curves, mesh)  # roots from root_triangle / root_bary
    assert guides.count == reference.count == curves.curve_count
    np.testing.assert_allclose(guides.root_positions, reference.root_positions, atol=1e-5)
    grown = follicle.Groom(mesh, guides).generate(count=200)
    assert grown.curve_count == 200
