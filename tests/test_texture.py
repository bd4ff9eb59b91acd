"""Texture: bilinear sampling, UV convention, wrap modes, bit depths, loading."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from follicle.errors import FormatError, InputError
from follicle.mesh.texture import Texture


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


def test_load_png_8_and_16_bit(tmp_path):
    rgb = np.zeros((2, 3, 3), dtype=np.uint8)
    rgb[1, 2] = (255, 128, 0)  # bottom-right texel
    Image.fromarray(rgb).save(tmp_path / "c.png")
    tex = Texture.load(tmp_path / "c.png", wrap="clamp")
    assert tex.shape == (2, 3, 3) and tex.name == "c"
    np.testing.assert_allclose(tex.sample([[5 / 6, 0.25]])[0], [1.0, 128 / 255, 0.0], atol=1e-6)

    grey = np.array([[0, 65535], [1000, 30000]], dtype=np.uint16)
    Image.fromarray(grey).save(tmp_path / "g16.png")
    t16 = Texture.load(tmp_path / "g16.png")
    assert t16.channels == 1
    np.testing.assert_allclose(t16.data[..., 0], grey / 65535.0, rtol=1e-6)


def test_load_errors(tmp_path):
    with pytest.raises(FormatError, match="missing.png"):
        Texture.load(tmp_path / "missing.png")
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not an image at all")
    with pytest.raises(FormatError, match="bad.png"):
        Texture.load(bad)
