"""Hostile .npz files: follicle's native curves files and simulation caches.

Every file starts valid (written by ``follicle.save`` or ``save_cache``) and is then
damaged on purpose: wrong dtypes and shapes, crafted ``.npy`` headers (a shape of 10¹²
points, tokenizer-breaking text), single bytes changed in the zip directory, junk member
names, decompression bombs, or random damage (hypothesis). Each must end in a FormatError
that names the file and what is wrong, in-process within a small memory budget, and in a
child process under the 2 GiB / 30 s limits for the bombs.
"""

import io
import struct
import tracemalloc
import warnings
import zipfile
import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import follicle
from follicle import FormatError, HairCurves
from follicle.io.npz import load_npz
from follicle.io.sim_cache import SimCache, is_cache, load_cache, save_cache
from follicle.pipeline import describe_cache
from hostile import assert_api_refused, assert_cli_refused, files, read_within, run_api, run_cli

P, C = 12, 3  # points and curves of the valid file


def _curves():
    rng = np.random.default_rng(7)
    return HairCurves.from_array(
        rng.normal(size=(C, P // C, 3)),
        point_data={
            "width": rng.random(P).astype(np.float32),
            "color": rng.random((P, 3)).astype(np.float32),
        },
        curve_data={"hair_id": np.arange(C)},
    )


def _arrays():
    """The arrays ``follicle.save`` writes for the valid curves."""
    c = _curves()
    return {
        "format_version": np.array(1, np.int64),
        "points": c.points,
        "offsets": c.offsets,
        "point_data.color": c.point_data["color"],
        "point_data.width": c.point_data["width"],
        "curve_data.hair_id": c.curve_data["hair_id"],
    }


def _npy(arr=None, *, header=None, data=b"", version=(1, 0)):
    """The bytes of an .npy file: of ``arr``, or a raw ``header`` (dict text) and ``data``."""
    if arr is not None:
        out = io.BytesIO()
        np.lib.format.write_array(out, arr, allow_pickle=False)
        return out.getvalue()
    magic = np.lib.format.magic(*version)
    size = 2 if version == (1, 0) else 4
    pad = -(len(magic) + size + len(header) + 1) % 64
    head = header + b" " * pad + b"\n"
    return magic + len(head).to_bytes(size, "little") + head + data


def _header(descr, shape, fortran=False):
    return repr({"descr": descr, "fortran_order": fortran, "shape": shape}).encode()


def _zip(path, members, method=zipfile.ZIP_STORED, level=None):
    """An archive of ``members`` (name → .npy bytes or array; a list of pairs allows twice
    the same name), as zipfile writes it."""
    pairs = members.items() if isinstance(members, dict) else members
    with warnings.catch_warnings(), zipfile.ZipFile(path, "w", method, compresslevel=level) as zf:
        warnings.simplefilter("ignore")  # duplicate names
        for name, value in pairs:
            zf.writestr(name, value if isinstance(value, bytes) else _npy(value))
    return path


def _curves_file(path, **changes):
    """The valid curves file with some arrays replaced (None: removed) or added."""
    arrays = {**_arrays(), **changes}
    return _zip(path, {f"{k}.npy": v for k, v in arrays.items() if v is not None})


def _refused(path, *fragments, read=load_npz):
    """The FormatError ``read(path)`` raises: it starts with the path and has every
    fragment, on one line."""
    with pytest.raises(FormatError) as err:
        read(path)
    text = str(err.value)
    assert text.startswith(f"{path}: "), text
    assert "\n" not in text, text
    for fragment in fragments:
        assert fragment in text, text
    return text


def test_valid_files_still_load(tmp_path):
    c = _curves()
    assert load_npz(follicle.save(c, tmp_path / "a.npz")) == c
    np.savez_compressed(tmp_path / "z.npz", **_arrays())  # deflated members
    assert load_npz(tmp_path / "z.npz") == c
    big = {k: v.astype(v.dtype.newbyteorder(">")) for k, v in _arrays().items()}
    assert load_npz(_curves_file(tmp_path / "b.npz", **big)) == c  # big-endian
    fortran = np.asfortranarray(c.point_data["color"])
    assert load_npz(_curves_file(tmp_path / "f.npz", **{"point_data.color": fortran})) == c


# ---------------------------------------------------------------------- dtypes and shapes
@pytest.mark.parametrize(
    ("value", "message"),
    [
        (
            np.array(np.nan),
            "format_version: expected an integer scalar, got float64 array of shape ()",
        ),
        (np.array(1.0), "format_version: expected an integer scalar, got float64"),
        (
            np.array([1]),
            "format_version: expected an integer scalar, got int64 array of shape (1,)",
        ),
        (np.array(1 + 0j), "format_version: expected an integer scalar, got complex128"),
        (np.array(True), "format_version: expected an integer scalar, got bool"),
        (np.array("1"), "format_version: expected an integer scalar, got <U1"),
        (np.array(0), "format_version 0 is not a follicle format version"),
        (np.array(-5, np.int8), "format_version -5 is not a follicle format version"),
        (np.array(2**63, np.uint64), "format_version 9223372036854775808 is newer"),
    ],
)
def test_format_version_must_be_an_integer_scalar(tmp_path, value, message):
    _refused(_curves_file(tmp_path / "v.npz", format_version=value), message)


POINTS = _arrays()["points"]


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        (
            "points",
            POINTS.astype("U8"),
            "points: expected a float32 or float64 (P, 3) array, got <U8",
        ),
        (
            "points",
            POINTS.astype(np.complex64),
            "points: expected a float32 or float64 (P, 3) array",
        ),
        ("points", POINTS.astype(np.float16), "got float16 array of shape (12, 3)"),
        ("points", POINTS.astype(np.int64), "got int64 array"),
        ("points", POINTS[:, :2], "got float32 array of shape (12, 2)"),
        ("points", POINTS[..., None], "got float32 array of shape (12, 3, 1)"),
        ("offsets", np.array([0.0, 4, 8, 12]), "offsets: expected a 1-D integer array"),
        ("offsets", np.array([[0, 4, 8, 12]]), "got int64 array of shape (1, 4)"),
        ("offsets", np.array(["0", "4", "8", "12"]), "got <U2 array"),
        ("offsets", np.array([False, True]), "got bool array"),
        (
            "point_data.width",
            np.ones(P, np.complex64),
            "point_data['width']: complex64 attributes are not supported; store bool, integer",
        ),
        ("point_data.width", np.array(["x"] * P), "point_data['width']: <U1 attributes"),
        ("point_data.width", np.ones(P, "S3"), "point_data['width']: |S3 attributes"),
        ("point_data.width", np.ones(P, np.float16), "float16 attributes are not supported"),
        ("point_data.width", np.ones(P, np.longdouble), "float128 attributes are not supported"),
        (
            "point_data.width",
            np.ones(P - 1, np.float32),
            "point_data['width']: expected shape (12,) or (12, k), got float32 array of"
            " shape (11,)",
        ),
        (
            "point_data.width",
            np.ones((P, 2, 2), np.float32),
            "got float32 array of shape (12, 2, 2)",
        ),
        ("point_data.width", np.ones((P, 0), np.float32), "got float32 array of shape (12, 0)"),
        ("point_data.width", np.float32(1), "got float32 array of shape ()"),
        ("curve_data.hair_id", np.arange(C + 1), "curve_data['hair_id']: expected shape (3,)"),
        ("curve_data.", np.arange(C), "curve_data.: an attribute needs a name"),
        (
            "point_data.width",
            np.array([np.nan] * P, np.float32),
            "point_data['width']: contains NaN",
        ),
    ],
)
def test_wrong_dtypes_and_shapes_are_refused(tmp_path, key, value, message):
    _refused(_curves_file(tmp_path / "d.npz", **{key: value}), message)


@pytest.mark.parametrize(
    ("header", "message"),
    [
        (_header("|O", (P,)), "has dtype object: Python objects, records and sub-arrays are not"),
        (_header([("a", "<f4"), ("b", "<i4")], (P,)), "has dtype [('a', '<f4'), ('b', '<i4')]:"),
        (_header("V8", (P,)), "has dtype |V8: Python objects"),
        (_header(("<f4", (3,)), (P,)), "has dtype ('<f4', (3,)): Python objects"),
    ],
)
def test_object_and_record_members_are_refused(tmp_path, header, message):
    path = _curves_file(
        tmp_path / "o.npz", **{"point_data.width": _npy(header=header, data=bytes(8 * P))}
    )
    _refused(path, "member 'point_data.width.npy'", message)


# ---------------------------------------------------------------------- crafted .npy headers
TERA = 10**12


@pytest.mark.parametrize(
    ("npy", "message"),
    [
        (
            _npy(header=_header("<f4", (TERA, 3)), data=bytes(36)),
            "declares a float32 array of shape (1000000000000, 3) (12,000,000,000,000 bytes) but"
            " holds 36",
        ),
        (
            _npy(header=_header("<f4", (TERA, 3)), data=bytes(36), version=(2, 0)),
            "(12,000,000,000,000 bytes) but holds 36",
        ),
        (_npy(header=_header("<f4", (-1, -3)), data=bytes(12)), "negative dimension"),
        (
            _npy(header=b"{'descr': '<f4', 'fortran_order': False, 'shape': (4, 3), "),
            "has no valid .npy header (TokenError: ('EOF in multi-line statement'",
        ),
        (_npy(header=b"{'descr': <f4 garbage}}}", data=bytes(48)), "has no valid .npy header"),
        (
            _npy(
                header=b"{'descr': '<f4', 'fortran_order': False, 'shape': "
                + b"(" * 300
                + b"4,"
                + b")" * 300
                + b"}"
            ),
            "has no valid .npy header",
        ),
        (
            _npy(
                header=b"{'descr': '<f4', 'fortran_order': False, 'shape': ("
                + b"-" * 5000
                + b"4, 3)}"
            ),
            "has no valid .npy header",
        ),
        (
            _npy(header=b"{'descr': '\xff\xfe\x00', 'fortran_order': False, 'shape': (4, 3)}"),
            "has no valid .npy header",
        ),
        (
            _npy(header=b"{'descr': '<f4', 'fortran_order': False, 'shape': (4, 3), 'x': 1}"),
            "has no valid .npy header",
        ),
        (
            _npy(header=b"{'descr': 'q8', 'fortran_order': 0, 'shape': (4, 3)}"),
            "has no valid .npy header",
        ),
        (
            np.lib.format.magic(2, 0) + struct.pack("<I", 2**32 - 1) + b"{",
            "has no valid .npy header",
        ),
        (np.lib.format.magic(3, 0) + struct.pack("<I", 10) + b"{}        ", ".npy version 3.0"),
        (b"\x93NUMPY", "has no valid .npy header"),
        (b"PK\x03\x04 not npy at all", "has no valid .npy header"),
    ],
)
def test_crafted_npy_headers_are_refused(tmp_path, npy, message):
    _refused(_curves_file(tmp_path / "h.npz", points=npy), "member 'points.npy'", message)


def test_text_beyond_unicode_is_refused(tmp_path):
    codes = np.array([[0x110000], [0xD800]], np.uint32)
    for i, code in enumerate(codes):
        npy = _npy(header=_header("<U1", (1,)), data=code.tobytes())
        path = _curves_file(tmp_path / f"u{i}.npz", **{"point_data.name": npy})
        _refused(path, "member 'point_data.name.npy' holds text that is not valid Unicode")


# ---------------------------------------------------------------------- the zip itself
def _central(data):
    """Offset of the first central directory entry of zip ``data``."""
    with zipfile.ZipFile(io.BytesIO(data)) as zf:
        return zf.start_dir


def _patched(path, at, value, size=2):
    data = bytearray(path.read_bytes())
    start = _central(bytes(data)) + at
    data[start : start + size] = value.to_bytes(size, "little")
    path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize(
    ("at", "value", "message"),
    [
        (
            10,
            99,
            "member 'format_version.npy' uses zip compression method 99; follicle reads stored",
        ),
        (10, 14, "uses zip compression method 14"),  # LZMA: zipfile could, follicle need not
        (6, 99, "not a readable .npz archive (NotImplementedError: zip file version 9.9)"),
        (8, 0x01, "member 'format_version.npy' is encrypted; save it again without a password"),
        (
            8,
            0x20,
            "member 'format_version.npy': not a readable .npz archive (NotImplementedError:"
            " compressed patched data",
        ),
        (8, 0x40, "(NotImplementedError: strong encryption"),
        (24, 2**31, "stored uncompressed but declares 2,147,483,648 bytes in 136"),
        (20, 2**31, "claims 2,147,483,648 bytes at offset 0, past the end"),
        (42, 2**31, "past the end"),
        (
            16,
            0,
            "not a readable .npz archive (BadZipFile: Bad CRC-32 for file 'format_version.npy')",
        ),
    ],
)
def test_one_byte_in_the_zip_directory(tmp_path, at, value, message):
    path = follicle.save(_curves(), tmp_path / "z.npz")
    _refused(_patched(path, at, value, 4 if at in (16, 20, 24, 42) else 2), message)


def test_names_and_members(tmp_path):
    npy = _npy(np.zeros(3))
    arrays = [(f"{k}.npy", v) for k, v in _arrays().items()]
    cases = {
        "twice": (arrays + [arrays[1]], "member 'points.npy' appears twice"),
        "text": (arrays + [("readme.txt", b"hi")], "member 'readme.txt' is not a named .npy"),
        "bare": (arrays + [(".npy", npy)], "member '.npy' is not a named .npy array"),
        "escape": (arrays + [("\x1b[2J.npy", npy)], "member '\\x1b[2J.npy' is not a named"),
        "rtl": (arrays + [("\u202egpj.npy", npy)], "member '\\u202egpj.npy' is not a named"),
    }
    for name, (members, message) in cases.items():
        _refused(_zip(tmp_path / f"{name}.npz", members), message)
    path = _zip(tmp_path / "utf8.npz", arrays + [("ü.npy", npy)])
    path.write_bytes(path.read_bytes().replace("ü".encode(), b"\xff\xfe"))
    _refused(path, "not a readable .npz archive (UnicodeDecodeError")


def test_truncated_and_empty_archives(tmp_path):
    data = follicle.save(_curves(), tmp_path / "a.npz").read_bytes()
    for cut in (0, 10, len(data) // 2, len(data) - 1):
        (tmp_path / "t.npz").write_bytes(data[:cut])
        _refused(tmp_path / "t.npz", "not a readable .npz archive")
    _refused(_zip(tmp_path / "e.npz", {}), "missing array 'format_version'")


# ---------------------------------------------------------------------- decompression bombs
BLOCK = 16 << 20  # zeros deflated once and repeated: 16 MiB in about 16 kB


def _deflated_zeros(header, blocks):
    """A raw deflate stream of ``header`` and ``blocks`` × BLOCK zero bytes, built from one
    compressed block (a full flush resets the compressor, so the blocks are identical)."""
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    head = c.compress(header) + c.flush(zlib.Z_FULL_FLUSH)
    block = c.compress(bytes(BLOCK)) + c.flush(zlib.Z_FULL_FLUSH)
    return head + block * blocks + c.flush()


def _bomb(path, blocks, declared=None):
    """A curves file whose points member is ``blocks`` × 16 MiB of deflated zeros under a
    consistent float32 (N, 3) header; the directory declares ``declared`` bytes (default:
    the truth) with a CRC of 0, so only the checks before inflating can pass it."""
    size = declared or blocks * BLOCK
    header = _npy(header=_header("<f4", (size // 12, 3)))
    stream = _deflated_zeros(header, blocks)
    arrays = _arrays()
    del arrays["points"]
    _zip(path, {f"{k}.npy": v for k, v in arrays.items()})
    with zipfile.ZipFile(path, "a") as zf:
        info = zipfile.ZipInfo("points.npy", date_time=(1980, 1, 1, 0, 0, 0))
        with zf.open(info, "w", force_zip64=True) as fh:
            fh.write(stream)  # written stored: the deflate stream as it is
        info.compress_type = zipfile.ZIP_DEFLATED
        info.file_size = len(header) + size // 12 * 12
        info.CRC = 0
    return path


@pytest.fixture(scope="module")
def bombs(tmp_path_factory):
    """(folder, {name: path}): a 2 MB file declaring 7 GB, and a 2 MB one that truly
    inflates to 2 GiB (its directory honest but for the CRC)."""
    tmp = tmp_path_factory.mktemp("bombs")
    made = {
        "liar": _bomb(tmp / "liar.npz", 128, declared=7 * 10**9),
        "honest": _bomb(tmp / "honest.npz", 128),
    }
    for path in made.values():
        assert 1.9e6 < path.stat().st_size < 2.2e6
    header = tmp / "tera.npz"
    _curves_file(header, points=_npy(header=_header("<f4", (TERA, 3)), data=bytes(36)))
    return tmp, {**made, "tera": header}


def test_bombs_are_refused_before_inflating(bombs):
    _, made = bombs
    for name in ("liar", "honest"):
        path = made[name]
        tracemalloc.start()
        try:
            text = _refused(path, "member 'points.npy' declares", "decompression bomb")
        finally:
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
        assert "beyond the 1000:1 limit" in text
        assert peak < 16 << 20, peak


def test_total_declared_size_is_capped(tmp_path):
    """Members each within 1000:1 but together far beyond what a small file may hold."""
    stream = _npy(np.zeros((4 << 20) // 8))  # 4 MiB of zeros: deflated fast, about 20 kB
    members = [(f"point_data.a{i}.npy", stream) for i in range(40)]
    path = _zip(tmp_path / "many.npz", members, method=zipfile.ZIP_DEFLATED, level=1)
    assert path.stat().st_size < 1 << 20
    _refused(path, "its members declare 167,77", "(64 × its size + 67,108,864); a decompression")


def test_a_directory_that_understates_reads_no_more(tmp_path):
    """A member declaring 48 bytes of a stream inflating to 64 MiB: read 48, then CRC."""
    path = _bomb(tmp_path / "small.npz", 4, declared=48)
    tracemalloc.start()
    try:
        _refused(path, "member 'points.npy': not a readable .npz archive (BadZipFile: Bad CRC")
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert peak < 4 << 20, peak


@pytest.mark.parametrize(
    ("name", "how"),
    [
        ("liar", "api"),
        ("liar", "info"),
        ("liar", "export"),
        ("honest", "info"),
        ("tera", "export"),
    ],
)
@pytest.mark.slow
def test_bombs_in_a_child_under_the_limits(bombs, name, how):
    """Refused within 2 GiB and 30 s, one line naming the file and member, nothing written.
    (A child costs about 4 s here, so each file meets the ways it matters most.)"""
    tmp, made = bombs
    path = made[name].name
    before = files(tmp)
    if how == "api":
        res = run_api(f"follicle.load_curves({path!r})", tmp)
        assert_api_refused(res, path, "points.npy", error="FormatError")
    else:
        args = ("info", path) if how == "info" else ("export", path, "-o", "out.hair")
        assert_cli_refused(run_cli(*args, cwd=tmp), path, "points.npy")
    assert files(tmp) == before


# ---------------------------------------------------------------------- simulation caches
TOML = '[groom]\ncount = 100\n\n[sim]\nmotion = "turn"\n'


def _frames(count=3, strands=4, vertices=5):
    pos = np.random.default_rng(1).normal(size=(count, strands, vertices, 3)).astype(np.float32)
    return pos, np.repeat(np.eye(4)[None], count, axis=0)


def _cache(path, **changes):
    """A valid cache written by save_cache, then some arrays replaced (None: removed)."""
    save_cache(path, *_frames(), 24.0, TOML, ".")
    if not changes:
        return path
    with np.load(path) as npz:
        arrays = {k: npz[k] for k in npz.files}
    arrays.update(changes)
    return _zip(path, {f"{k}.npy": v for k, v in arrays.items() if v is not None})


def _nan_positions():
    pos = _frames()[0]
    pos[1, 2, 3, 0] = np.nan
    return pos


def _inf_transforms():
    tr = _frames()[1]
    tr[2, 1, 3] = -np.inf
    return tr


def _text_npy(codes):
    return _npy(header=_header("<U1", ()), data=np.uint32(codes).tobytes())


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"positions": _nan_positions()}, "positions: frame 1 contains NaN or inf"),
        ({"transforms": _inf_transforms()}, "transforms: frame 2: expected a finite 4×4 matrix"),
        ({"positions": _frames()[0].astype(np.complex64)}, "positions: expected a float32"),
        ({"positions": _frames()[0].astype("U3")}, "positions: expected a float32 (F, S, N, 3)"),
        (
            {"positions": _npy(header=_header("<f4", (TERA, 4, 5, 3)), data=bytes(240))},
            "member 'positions.npy' declares a float32 array of shape (1000000000000, 4, 5, 3)",
        ),
        ({"fps": np.array(0.0)}, "fps: must be > 0 (got 0.0)"),
        ({"fps": np.array(-24.0)}, "fps: must be > 0 (got -24.0)"),
        ({"fps": np.array(np.nan)}, "fps: must be finite and > 0 (got nan)"),
        ({"fps": np.array(np.inf)}, "fps: must be finite and > 0 (got inf)"),
        ({"fps": np.array("24")}, "fps: expected a float, got <U2"),
        ({"version": np.array(1.5)}, "version: expected an integer, got float64"),
        ({"version": np.array(True)}, "version: expected an integer, got bool"),
        ({"scene_toml": np.array(7)}, "scene_toml: expected a text string, got int64"),
        ({"scene_toml": np.array(b"[groom]")}, "scene_toml: expected a text string, got |S7"),
        ({"scene_toml": _text_npy(0xDFFF)}, "member 'scene_toml.npy' holds text that is not valid"),
        ({"scene_toml": _text_npy(0x7FFFFFFF)}, "holds text that is not valid Unicode"),
        ({"scene_toml": np.array("[groom]\0\ncount = 1")}, "scene_toml: contains a NUL character"),
        ({"base_dir": np.array("a\0b")}, "base_dir: contains a NUL character"),
        ({"format": _text_npy(0x110000)}, "member 'format.npy' holds text that is not valid"),
    ],
)
def test_hostile_caches_are_refused(tmp_path, changes, message):
    path = _cache(tmp_path / "c.npz", **changes)
    _refused(path, message, read=load_cache)
    assert is_cache(path) == ("format" not in changes)


@pytest.mark.parametrize(
    ("toml", "message"),
    [
        ("[groom\n", "c.npz: stored scene: TOML syntax error"),
        ("a = " + "[" * 5000, "c.npz: stored scene: arrays or tables nested too deeply"),
    ],
)
def test_unparsable_stored_scene_is_refused_by_describe(tmp_path, toml, message):
    path = _cache(tmp_path / "c.npz", scene_toml=np.array(toml))
    assert isinstance(load_cache(path), SimCache)  # the scene is read when it is needed
    _refused(path, message, read=describe_cache)


def test_describe_cache(tmp_path):
    path = _cache(tmp_path / "c.npz")
    assert describe_cache(path) == (
        f"{path}: simulation cache, 3 frames at 24 fps (0.0833 s after the rest frame),"
        " 4 guides × 5 vertices, head motion 'turn' (40° over 2 s); `follicle render` grows"
        " 100 hairs on every frame"
    )


def test_a_cache_read_as_curves_says_what_it_is(tmp_path):
    path = _cache(tmp_path / "sim.npz")
    _refused(
        path,
        "a follicle simulation cache (3 frames of 4 guides × 5 vertices), not a"
        f" curves file; `follicle render {path} -o frames/` draws it and `follicle export"
        f" {path} -o anim.usdc` writes it as animated USD",
    )
    with pytest.raises(FormatError, match="a follicle simulation cache"):
        follicle.load_curves(path)


def test_is_cache_never_raises(tmp_path):
    assert is_cache(_cache(tmp_path / "c.npz"))
    (tmp_path / "d").mkdir()
    assert not is_cache(tmp_path / "d")
    assert not is_cache(tmp_path / "missing.npz")
    assert not is_cache(follicle.save(_curves(), tmp_path / "h.npz"))
    assert not is_cache(_patched(_cache(tmp_path / "p.npz"), 10, 99))


# ---------------------------------------------------------------------- random damage
def _regions(data):
    """(start, end) byte ranges worth damaging: every local header with its .npy header,
    and the central directory with the end record."""
    with zipfile.ZipFile(io.BytesIO(data)) as zf:
        local = [
            (i.header_offset, i.header_offset + 30 + len(i.filename) + 128) for i in zf.infolist()
        ]
        return [*local, (zf.start_dir, len(data))]


DTYPES = ["<f4", "<f8", "<f2", "<c8", "<i8", "|b1", "<U3", "|S2", "|O", "<M8[s]", ">f4", "|V4"]
SHAPES = st.lists(st.sampled_from([0, 1, 2, 3, 4, 12, 2**31, 2**40, TERA, -1]), max_size=4)


@st.composite
def damaged(draw, data):
    """``data`` (a zip) damaged one way: bytes flipped in a header, fields overwritten,
    truncated, or a member replaced by a random .npy header, dtype and shape."""
    how = draw(st.sampled_from(["flip", "field", "truncate", "member"]))
    out = bytearray(data)
    if how == "truncate":
        return bytes(out[: draw(st.integers(0, len(out) - 1))])
    if how == "member":
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            names = zf.namelist()
            members = {n: zf.read(n) for n in names}
        shape = tuple(draw(SHAPES))
        header = _header(draw(st.sampled_from(DTYPES)), shape, draw(st.booleans()))
        body = draw(st.sampled_from([b"", bytes(48), bytes(4096)]) | st.binary(max_size=64))
        members[draw(st.sampled_from(names))] = _npy(header=header, data=body)
        method = draw(st.sampled_from([zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED]))
        buf = io.BytesIO()
        _zip(buf, members, method)
        return buf.getvalue()
    start, end = draw(st.sampled_from(_regions(data)))
    end = min(end, len(out))
    for _ in range(draw(st.integers(1, 6))):
        at = draw(st.integers(start, end - 1))
        if how == "flip":
            out[at] ^= 1 << draw(st.integers(0, 7))
        else:
            value = draw(st.sampled_from([0, 1, 8, 99, 0xFFFF, 2**31, 2**32 - 1, len(data)]))
            out[at : at + 4] = struct.pack("<I", value)[: len(out) - at]
    return bytes(out[: len(data)])


def _read_within_budget(path, read, ok):
    result = read_within(path, read, 16 << 20)
    assert isinstance(result, (ok, FormatError)), result
    if isinstance(result, FormatError):
        with pytest.raises(FormatError) as again:  # the same file, the same answer
            read(path)
        assert str(again.value) == str(result)


@pytest.mark.parametrize("kind", ["curves", "compressed", "cache"])
def test_random_damage_gives_format_errors_only(tmp_path, kind):
    valid = tmp_path / "valid.npz"
    if kind == "curves":
        follicle.save(_curves(), valid)
    elif kind == "compressed":
        np.savez_compressed(valid, **_arrays())
    else:
        _cache(valid)
    data = valid.read_bytes()
    path = tmp_path / "fuzz.npz"
    read, ok = (load_cache, SimCache) if kind == "cache" else (load_npz, HairCurves)

    @settings(
        max_examples=100,
        deadline=None,
        derandomize=True,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(damaged(data))
    def check(bad):
        path.write_bytes(bad)
        _read_within_budget(path, read, ok)
        assert isinstance(is_cache(path), bool)

    check()
