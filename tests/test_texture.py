"""Texture: bilinear sampling, UV convention, wrap modes, bit depths, loading."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from follicle.errors import FormatError, InputError
from follicle.mesh.texture import Texture


def _write_tiff(path: Path, arr: np.ndarray) -> None:
    """Uncompressed little-endian TIFF of (H, W) or (H, W, 3) samples of any numeric dtype.

    Written by hand because pillow cannot write 16-bit RGB, RGB float or signed TIFFs.
    """
    arr = np.asarray(arr)
    h, w = arr.shape[:2]
    spp = 1 if arr.ndim == 2 else arr.shape[2]
    pixels = np.ascontiguousarray(arr, dtype=arr.dtype.newbyteorder("<")).tobytes()
    bits = [arr.dtype.itemsize * 8] * spp
    sample_format = [{"u": 1, "i": 2, "f": 3}[arr.dtype.kind]] * spp
    ifd_end = 8 + 2 + 12 * 11 + 4
    overflow_size = 0 if spp == 1 else 2 * 2 * spp  # bits and sample format, 2 bytes each
    tags = [  # (tag, SHORT "H" or LONG "I", values), in ascending tag order
        (256, "I", [w]),
        (257, "I", [h]),
        (258, "H", bits),
        (259, "H", [1]),
        (262, "H", [2 if spp == 3 else 1]),
        (273, "I", [ifd_end + overflow_size]),
        (277, "H", [spp]),
        (278, "I", [h]),
        (279, "I", [len(pixels)]),
        (284, "H", [1]),
        (339, "H", sample_format),
    ]
    entries, overflow = b"", b""
    for tag, fmt, values in tags:
        raw = struct.pack(f"<{len(values)}{fmt}", *values)
        if len(raw) > 4:  # stored after the IFD; the entry holds its offset
            raw, overflow = struct.pack("<I", ifd_end + len(overflow)), overflow + raw
        entries += struct.pack("<HHI", tag, 3 if fmt == "H" else 4, len(values))
        entries += raw.ljust(4, b"\0")
    assert len(overflow) == overflow_size
    header = b"II*\0" + struct.pack("<IH", 8, len(tags))
    path.write_bytes(header + entries + b"\0" * 4 + overflow + pixels)


def _write_png16(path: Path, arr: np.ndarray, colour_type: int) -> None:
    """16-bit PNG (colour type 2 = RGB, 6 = RGBA), which pillow cannot write."""
    arr = np.asarray(arr, dtype=">u2")

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + crc

    rows = b"".join(b"\0" + row.tobytes() for row in arr)  # filter type 0 per row
    ihdr = struct.pack(">IIBBBBB", arr.shape[1], arr.shape[0], 16, colour_type, 0, 0, 0)
    idat = zlib.compress(rows)
    png = chunk(b"IHDR", ihdr) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + png)


def _centre(i: int, j: int, h: int, w: int) -> tuple[float, float]:
    """UV of the centre of texel (row i from the top, column j)."""
    return (j + 0.5) / w, 1.0 - (i + 0.5) / h


def test_texel_centres_return_texel_values():
    data = np.arange(12, dtype=np.float64).reshape(3, 4)
    tex = Texture(data)
    uv = [_centre(i, j, 3, 4) for i in range(3) for j in range(4)]
    np.testing.assert_allclose(tex.sample(np.array(uv)), data.ravel(), atol=1e-6)


def test_v_zero_is_the_last_row():
    data = np.array([[1.0, 1.0], [5.0, 5.0]])  # top row 1, bottom row 5
    tex = Texture(data, wrap="clamp")
    np.testing.assert_allclose(tex.sample([[0.5, 0.0], [0.5, 1.0]]), [5.0, 1.0])


def test_bilinear_between_texels():
    data = np.array([[0.0, 1.0], [2.0, 3.0]])
    tex = Texture(data, wrap="clamp")
    # midway between all four centres: the mean
    np.testing.assert_allclose(tex.sample([[0.5, 0.5]]), [1.5])
    # a quarter of the way from column 0 to column 1 on the top row
    u = (0.5 + 0.25) / 2
    np.testing.assert_allclose(tex.sample([[u, 1.0 - 0.5 / 2]]), [0.25])
    # between the two rows of column 1 (bottom row weight 0.75)
    v = 1.0 - (0.5 + 0.75) / 2
    np.testing.assert_allclose(tex.sample([[0.75, v]]), [1.0 * 0.25 + 3.0 * 0.75])


def test_clamp_versus_repeat():
    data = np.array([[0.0, 10.0]])
    clamp, repeat = Texture(data, wrap="clamp"), Texture(data, wrap="repeat")
    np.testing.assert_allclose(clamp.sample([[0.0, 0.5], [1.0, 0.5], [3.2, 0.5]]), [0, 10, 10])
    # at u = 0 repeat blends the last column with the first
    np.testing.assert_allclose(repeat.sample([[0.0, 0.5], [1.0, 0.5]]), [5.0, 5.0])
    np.testing.assert_allclose(repeat.sample([[0.25, 0.5], [1.25, 0.5], [-0.75, 0.5]]), [0, 0, 0])


def test_channels_shape_and_properties():
    data = np.zeros((4, 8, 3), dtype=np.float32)
    data[..., 1] = 1.0
    tex = Texture(data, name="rgb")
    assert (tex.height, tex.width, tex.channels, tex.shape) == (4, 8, 3, (4, 8, 3))
    out = tex.sample([[0.3, 0.7], [0.9, 0.1]])
    assert out.shape == (2, 3) and out.dtype == np.float64
    np.testing.assert_allclose(out, [[0, 1, 0], [0, 1, 0]])
    assert Texture(np.ones((2, 2))).sample([[0.5, 0.5]]).shape == (1,)
    assert tex.data.dtype == np.float32 and tex.data.shape == (4, 8, 3)


def test_integer_scaling():
    assert Texture(np.array([[255, 0]], dtype=np.uint8)).data[0, :, 0].tolist() == [1.0, 0.0]
    t16 = Texture(np.array([[65535, 32768]], dtype=np.uint16))
    np.testing.assert_allclose(t16.data[0, :, 0], [1.0, 32768 / 65535], rtol=1e-6)
    # floats keep their range
    assert Texture(np.array([[-2.0, 7.5]])).data[0, :, 0].tolist() == [-2.0, 7.5]


def test_bad_input():
    with pytest.raises(InputError, match="wrap"):
        Texture(np.ones((2, 2)), wrap="mirror")
    with pytest.raises(InputError, match="NaN"):
        Texture(np.array([[np.nan, 1.0]]))
    with pytest.raises(InputError, match="shape"):
        Texture(np.ones(5))
    with pytest.raises(InputError, match=r"\(n, 2\)"):
        Texture(np.ones((2, 2))).sample(np.ones((3, 3)))


def _scaled(arr: np.ndarray, full: float) -> np.ndarray:
    """What Texture stores for integer pixels: float32 division by the full-scale value."""
    return arr.astype(np.float32) / np.float32(full)


def test_load_8_bit_modes_exact(tmp_path):
    grey = np.array([[0, 1, 128], [200, 254, 255]], dtype=np.uint8)
    rgba = np.stack([grey, grey[::-1], 255 - grey, grey // 2], axis=2)
    cases = {"L": grey, "LA": rgba[..., [0, 3]], "RGB": rgba[..., :3], "RGBA": rgba}
    for mode, arr in cases.items():
        for ext in ("png", "tif"):
            Image.fromarray(arr, mode).save(tmp_path / f"{mode}.{ext}")
            tex = Texture.load(tmp_path / f"{mode}.{ext}")
            expected = _scaled(arr, 255).reshape(tex.shape)
            np.testing.assert_array_equal(tex.data, expected, err_msg=f"{mode}.{ext}")
    _write_tiff(tmp_path / "rgb_by_hand.tif", rgba[..., :3])  # checks the helper for 3 channels
    np.testing.assert_array_equal(
        Texture.load(tmp_path / "rgb_by_hand.tif").data, _scaled(rgba[..., :3], 255)
    )
    # palette images become RGB with the palette colours
    pal = Image.fromarray(np.array([[0, 1], [1, 0]], dtype=np.uint8), "P")
    pal.putpalette([10, 20, 30, 255, 0, 128])
    pal.save(tmp_path / "p.png")
    tex = Texture.load(tmp_path / "p.png")
    assert tex.shape == (2, 2, 3)
    np.testing.assert_array_equal(tex.data[0, 1], _scaled(np.array([255, 0, 128]), 255))
    np.testing.assert_array_equal(tex.data[1, 1], _scaled(np.array([10, 20, 30]), 255))


def test_load_jpeg(tmp_path):
    Image.new("RGB", (8, 8), (200, 100, 50)).save(tmp_path / "c.jpg", quality=100)
    tex = Texture.load(tmp_path / "c.jpg")
    assert tex.shape == (8, 8, 3)
    np.testing.assert_allclose(tex.data[4, 4], [200 / 255, 100 / 255, 50 / 255], atol=2 / 255)


def test_load_png_8_and_16_bit(tmp_path):
    rgb = np.zeros((2, 3, 3), dtype=np.uint8)
    rgb[1, 2] = (255, 128, 0)  # bottom-right texel
    Image.fromarray(rgb).save(tmp_path / "c.png")
    tex = Texture.load(tmp_path / "c.png", wrap="clamp")
    assert tex.shape == (2, 3, 3) and tex.name == "c" and tex.wrap == "clamp"
    np.testing.assert_allclose(tex.sample([[5 / 6, 0.25]])[0], [1.0, 128 / 255, 0.0], atol=1e-6)

    grey = np.array([[0, 65535], [1, 30000]], dtype=np.uint16)
    Image.fromarray(grey).save(tmp_path / "g16.png")
    t16 = Texture.load(tmp_path / "g16.png")
    assert t16.shape == (2, 2, 1)
    np.testing.assert_array_equal(t16.data[..., 0], _scaled(grey, 65535))
    assert t16.data[1, 0, 0] > 0  # 1/65535 survives: no narrowing to 8 bits


@pytest.mark.parametrize("byteorder", ["<", ">"])
def test_load_16_bit_tiff(tmp_path, byteorder):
    grey = np.array([[0, 65535, 1], [257, 30000, 65534]], dtype=f"{byteorder}u2")
    Image.fromarray(grey).save(tmp_path / "g16.tif")
    tex = Texture.load(tmp_path / "g16.tif")
    assert tex.shape == (2, 3, 1)
    np.testing.assert_array_equal(tex.data[..., 0], _scaled(grey.astype(np.uint16), 65535))


def test_load_float_tiff_keeps_hdr_and_negative_values(tmp_path):
    values = np.array([[1e-4, 5000.0, 1.0], [0.0, -2.5, 3.0e7]], dtype=np.float32)
    Image.fromarray(values).save(tmp_path / "f32.tif")
    _write_tiff(tmp_path / "f32_by_hand.tif", values)
    for name in ("f32.tif", "f32_by_hand.tif"):
        tex = Texture.load(tmp_path / name, wrap="clamp")
        assert tex.shape == (2, 3, 1)
        np.testing.assert_array_equal(tex.data[..., 0], values)
    # texel centres give the stored values back: 5e7 : 1 and 3e11 : 1 contrasts survive
    uv = [_centre(0, 0, 2, 3), _centre(0, 1, 2, 3), _centre(1, 1, 2, 3), _centre(1, 2, 2, 3)]
    out = tex.sample(uv)
    np.testing.assert_array_equal(out, values[[0, 0, 1, 1], [0, 1, 1, 2]].astype(np.float64))
    assert out[1] / out[0] == pytest.approx(5.0e7) and out[3] / out[0] == pytest.approx(3.0e11)


@pytest.mark.parametrize(
    ("filename", "write", "problem"),
    [
        ("rgb16.tif", lambda p, a: _write_tiff(p, a), "16-bit samples in 3 channel"),
        ("rgbf32.tif", lambda p, a: _write_tiff(p, a / np.float32(7)), "cannot be read"),
        ("int16.tif", lambda p, a: _write_tiff(p, a[..., 0].astype(np.int16)), "signed integer"),
        ("uint32.tif", lambda p, a: _write_tiff(p, a[..., 0].astype(np.uint32)), "32-bit samples"),
        ("f64.tif", lambda p, a: _write_tiff(p, a[..., 0].astype(np.float64)), "cannot be read"),
        ("rgb16.png", lambda p, a: _write_png16(p, a, 2), "16-bit RGB PNG"),
        ("rgba16.png", lambda p, a: _write_png16(p, np.dstack([a, a[..., 0]]), 6), "RGBA PNG"),
    ],
)
def test_load_refuses_layouts_pillow_cannot_read_faithfully(tmp_path, filename, write, problem):
    # pillow would narrow these to 8 bits (16-bit colour), misread them (signed, 32-bit
    # integers) or not open them (multi-channel or 64-bit float): say what to save instead
    samples = np.arange(12, dtype=np.uint16).reshape(2, 2, 3) * 3001 + 7  # low bytes matter
    write(tmp_path / filename, samples)
    with pytest.raises(FormatError, match=rf"{filename}.*{problem}") as err:
        Texture.load(tmp_path / filename)
    assert "32-bit float" in str(err.value) and "16-bit greyscale" in str(err.value)


def test_load_errors(tmp_path):
    with pytest.raises(FormatError, match="missing.png.*does not exist"):
        Texture.load(tmp_path / "missing.png")
    with pytest.raises(FormatError, match="not a file"):
        Texture.load(tmp_path)
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not an image at all")
    with pytest.raises(FormatError, match="bad.png.*cannot be read"):
        Texture.load(bad)
    truncated = tmp_path / "cut.png"
    Image.new("L", (64, 64), 3).save(truncated)
    truncated.write_bytes(truncated.read_bytes()[:60])
    with pytest.raises(FormatError, match="cut.png"):
        Texture.load(truncated)
    Image.new("RGB", (2, 2)).save(tmp_path / "x.bmp")
    with pytest.raises(FormatError, match="x.bmp.*supported are PNG, JPEG and TIFF"):
        Texture.load(tmp_path / "x.bmp")
    Image.fromarray(np.array([[np.nan, 1.0]], dtype=np.float32)).save(tmp_path / "nan.tif")
    with pytest.raises(FormatError, match="nan.tif.*NaN"):
        Texture.load(tmp_path / "nan.tif")
    Image.new("L", (2, 2)).save(tmp_path / "ok.png")
    with pytest.raises(InputError, match="wrap"):
        Texture.load(tmp_path / "ok.png", wrap="mirror")
