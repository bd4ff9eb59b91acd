"""Fuzzing the readers: damaged files give a FormatError and nothing else.

Every file starts valid and is then truncated, has header bytes or fields overwritten
(counts larger than the file, offsets that are negative as int32, overlapping or
misaligned), NaN/inf written into it, or is replaced by random bytes. A reader must
return curves or raise FormatError, and must not allocate much more than the file:
at most 16 × its size + 1 MB (measured with tracemalloc, which sees numpy's arrays).
"""

import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import follicle
from follicle import FormatError, HairCurves
from follicle.io.dispatch import load_curves  # imported now: imports would count as memory
from hairfiles import hair, tfx3_table
from hostile import read_within

FIELDS = [0, 1, 2, 3, 7, 8, 144, 160, 296, 2**16, 2**31 - 1, 2**31, 2**32 - 8, 2**32 - 1]
SPECIALS = [np.nan, np.inf, -np.inf, 3e38, -0.0]


def _valid(tmp):
    c = hair(counts=(3, 5, 4))
    files = {
        "hair": (".hair", follicle.save(c, tmp / "v.hair").read_bytes()),
        "hair uniform": (".hair", follicle.save(hair(counts=(4, 4)), tmp / "u.hair").read_bytes()),
        "tfx4": (".tfx", follicle.save(c, tmp / "v.tfx", vertices=4).read_bytes()),
        "tfx3": (
            ".tfx",
            tfx3_table(
                2, 4, np.ones((8, 3)), thickness=[1, 2], uv=np.ones((2, 2)), colors=np.ones((8, 4))
            ),
        ),
        "tfx3 packed": (
            ".tfx",
            struct.pack("<f4I31I", 3.0, 2, 4, 0, 0, *[0] * 31) + np.ones((8, 3), "<f4").tobytes(),
        ),
        "obj": (".obj", follicle.save(c, tmp / "v.obj").read_bytes()),
        "mitsuba": (".txt", follicle.save(c, tmp / "v.txt").read_bytes()),
    }
    for ext, data in files.values():  # the starting points read
        (tmp / f"check{ext}").write_bytes(data)
        assert load_curves(tmp / f"check{ext}").curve_count > 0
    return files


@pytest.fixture(scope="module")
def valid(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fuzz")
    return tmp, _valid(tmp)


@st.composite
def damage(draw, data: bytes, binary: bool) -> bytes:
    """``data`` damaged in one of several ways."""
    out = bytearray(data)
    how = draw(
        st.sampled_from(
            ["truncate", "bytes", "field", "float", "random"]
            if binary
            else ["truncate", "bytes", "text", "random"]
        )
    )
    if how == "truncate":
        return bytes(out[: draw(st.integers(0, len(out) - 1))])
    if how == "bytes":
        head = min(len(out), 300) if binary else len(out)
        for _ in range(draw(st.integers(1, 8))):
            out[draw(st.integers(0, head - 1))] = draw(st.integers(0, 255))
    elif how == "field":
        at = 4 * draw(st.integers(0, min(len(out), 300) // 4 - 1))
        value = draw(
            st.sampled_from(FIELDS + [len(out), len(out) - 8, len(out) + 8])
            | st.integers(0, 2**32 - 1)
        )
        out[at : at + 4] = struct.pack("<I", value % 2**32)
    elif how == "float":
        at = 4 * draw(st.integers(0, len(out) // 4 - 1))
        out[at : at + 4] = struct.pack("<f", draw(st.sampled_from(SPECIALS)))
    elif how == "text":
        at = draw(st.integers(0, len(out)))
        token = draw(
            st.sampled_from(
                [
                    b"nan",
                    b"inf",
                    b"-",
                    b"1e99999",
                    b"\\",
                    b"\n",
                    b"l 0",
                    b"l -99",
                    b"99999999999999999999999",
                    b"1.5",
                    b"/",
                    b" ",
                    b"\x00",
                    b"v",
                    b"l",
                ]
            )
        )
        out[at:at] = token
    else:
        return draw(st.binary(max_size=400))
    return bytes(out)


def _read_within_budget(path):
    assert isinstance(read_within(path, load_curves, 2**20), (HairCurves, FormatError))


@pytest.mark.parametrize(
    "name", ["hair", "hair uniform", "tfx4", "tfx3", "tfx3 packed", "obj", "mitsuba"]
)
@pytest.mark.slow
def test_damaged_files_give_format_errors_only(valid, name):
    tmp, files = valid
    ext, data = files[name]
    path = tmp / f"fuzz{ext}"

    @settings(
        max_examples=200,
        deadline=None,
        derandomize=True,
        suppress_health_check=[HealthCheck.too_slow],
    )
    @given(damage(data, binary=ext in (".hair", ".tfx")))
    def check(damaged):
        path.write_bytes(damaged)
        _read_within_budget(path)

    check()


@pytest.mark.parametrize(
    "header",
    [
        struct.pack("<4s4I5f88s", b"HAIR", 2**32 - 1, 2**32 - 1, 31, 0, 0, 0, 0, 0, 0, b""),
        struct.pack("<f7I32I", 4.0, 2**32 - 1, 2**32 - 1, 160, 0, 0, 0, 0, *[0] * 32),
        struct.pack("<f4I31I", 3.0, 2**31, 64, 0, 0, *[0] * 31)
        + struct.pack("<6I32I", 296, *[0] * 37),
    ],
)
def test_absurd_counts_are_refused_before_allocating(tmp_path, header):
    path = tmp_path / ("x.hair" if header.startswith(b"HAIR") else "x.tfx")
    path.write_bytes(header + bytes(64))
    _read_within_budget(path)
    with pytest.raises(FormatError, match=r"numHairStrands|hair_count .* need \d+ bytes"):
        load_curves(path)
