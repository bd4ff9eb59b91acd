"""PropertyMap: global value × texture(uv), scalar and colour, and the scene spec forms."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from follicle.errors import FormatError, InputError
from follicle.mesh.property import PropertyMap
from follicle.mesh.texture import Texture

# texel centres of a 2 x 2 texture: top-left, top-right, bottom-left, bottom-right
UV = np.array([[0.25, 0.75], [0.75, 0.75], [0.25, 0.25], [0.75, 0.25]])


def test_constant_scalar_and_colour():
    scalar = PropertyMap(2.5, name="groom.scale")
    assert scalar.constant and scalar.channels == 1 and scalar.value == 2.5
    out = scalar.evaluate(UV)
    assert out.dtype == np.float64 and out.tolist() == [2.5] * 4

    grey = PropertyMap(0.5, kind="color")
    assert grey.value == (0.5, 0.5, 0.5) and grey.channels == 3
    colour = PropertyMap([0.2, 0.4, 0.6], kind="color")
    out = colour.evaluate(UV[:2])
    assert out.shape == (2, 3) and out.dtype == np.float64
    assert out.tolist() == [[0.2, 0.4, 0.6]] * 2
    assert PropertyMap(1.0).evaluate(np.empty((0, 2))).shape == (0,)


def test_scalar_times_grey_texture():
    tex = Texture(np.array([[0.0, 0.5], [1.0, 0.25]]), wrap="clamp")
    prop = PropertyMap(4.0, tex, name="groom.length")
    assert not prop.constant
    np.testing.assert_array_equal(prop.evaluate(UV), [0.0, 2.0, 4.0, 1.0])
    # halfway between the two top texels
    np.testing.assert_allclose(prop.evaluate([[0.5, 0.75]]), [1.0])


def test_scalar_uses_first_channel():
    data = np.zeros((2, 2, 3))
    data[..., 0] = [[0.1, 0.2], [0.3, 0.4]]
    data[..., 1:] = 9.0
    out = PropertyMap(10.0, Texture(data, wrap="clamp")).evaluate(UV)
    np.testing.assert_allclose(out, [1.0, 2.0, 3.0, 4.0])


def test_colour_times_rgb_texture():
    data = np.zeros((2, 2, 3))
    data[0, 0] = (1.0, 0.5, 0.25)
    data[1, 1] = (0.0, 1.0, 2.0)  # HDR texels keep their range
    prop = PropertyMap([2.0, 4.0, 8.0], Texture(data, wrap="clamp"), kind="color")
    out = prop.evaluate(UV)
    np.testing.assert_array_equal(out, [[2.0, 2.0, 2.0], [0, 0, 0], [0, 0, 0], [0.0, 4.0, 16.0]])


def test_colour_times_grey_texture_is_broadcast():
    tex = Texture(np.array([[0.5, 1.0], [0.0, 0.25]]), wrap="clamp")
    out = PropertyMap([0.2, 0.4, 0.8], tex, kind="color").evaluate(UV)
    assert out.shape == (4, 3)
    np.testing.assert_allclose(out, np.outer([0.5, 1.0, 0.0, 0.25], [0.2, 0.4, 0.8]))


def test_colour_drops_alpha_and_refuses_grey_alpha():
    rgba = np.zeros((2, 2, 4))
    rgba[..., :3] = 0.5
    rgba[..., 3] = 0.0  # alpha must not reach the colour
    out = PropertyMap(1.0, Texture(rgba), kind="color").evaluate(UV)
    assert out.shape == (4, 3)
    np.testing.assert_array_equal(out, np.full((4, 3), 0.5))
    with pytest.raises(InputError, match="groom.color.*2 channels"):
        PropertyMap(1.0, Texture(np.ones((2, 2, 2))), kind="color", name="groom.color")


def test_from_spec_number_list_and_table():
    assert PropertyMap.from_spec(3, name="groom.scale").evaluate(UV[:1]).tolist() == [3.0]
    colour = PropertyMap.from_spec([0.1, 0.2, 0.3], kind="color")
    assert colour.value == (0.1, 0.2, 0.3) and colour.constant
    table = PropertyMap.from_spec({"value": 0.7})
    assert table.value == 0.7 and table.constant
    assert PropertyMap.from_spec({}).value == 1.0


def test_from_spec_texture_path_and_name(tmp_path):
    grey = np.array([[0, 255], [51, 102]], dtype=np.uint8)
    Image.fromarray(grey).save(tmp_path / "len.png")
    resolved = []

    def resolve(p: str) -> str:
        resolved.append(p)
        return str(tmp_path / p)

    spec = {"value": 2.0, "texture": "len.png", "wrap": "clamp"}
    prop = PropertyMap.from_spec(spec, name="groom.length", resolve_path=resolve)
    assert resolved == ["len.png"] and prop.texture.wrap == "clamp"
    np.testing.assert_allclose(prop.evaluate(UV), [0.0, 2.0, 0.4, 0.8], rtol=1e-6)
    # a bare string is a texture with value 1; a file loads with wrap "repeat"
    bare = PropertyMap.from_spec("len.png", resolve_path=resolve)
    assert bare.value == 1.0 and bare.texture.wrap == "repeat"

    named = Texture(np.array([[0.5]]), wrap="clamp", name="scalp")
    textures = {"scalp": named}
    prop = PropertyMap.from_spec({"value": 4.0, "texture": "scalp"}, textures=textures)
    assert prop.texture is named
    np.testing.assert_array_equal(prop.evaluate(UV[:2]), [2.0, 2.0])
    rewrapped = PropertyMap.from_spec({"texture": "scalp", "wrap": "repeat"}, textures=textures)
    assert rewrapped.texture.wrap == "repeat" and named.wrap == "clamp"
    np.testing.assert_array_equal(rewrapped.texture.data, named.data)

    colour = PropertyMap.from_spec(
        {"value": [1.0, 0.5, 0.0], "texture": "scalp"}, kind="color", textures=textures
    )
    np.testing.assert_array_equal(colour.evaluate(UV[:1]), [[0.5, 0.25, 0.0]])


@pytest.mark.parametrize(
    ("spec", "kind", "match"),
    [
        (float("nan"), "scalar", r"groom\.x: must be finite \(got nan\)"),
        (float("inf"), "color", r"groom\.x: must be finite"),
        (True, "scalar", r"groom\.x: expected a number \(got True\)"),
        (None, "scalar", r"groom\.x: expected a number \(got None\)"),
        ([1.0, 2.0, 3.0], "scalar", r"groom\.x: expected a number"),
        ([1.0, 2.0], "color", r"groom\.x: .*needs 3 numbers \(got 2\)"),
        ([1.0, "a", 3.0], "color", r"groom\.x\[1\]: expected a number \(got 'a'\)"),
        ([1.0, 2.0, float("nan")], "color", r"groom\.x\[2\]: must be finite"),
        ({"value": 1.0, "textrue": "a.png"}, "scalar", r"groom\.x: unknown key.*textrue"),
        ({"value": "big"}, "scalar", r"groom\.x: expected a number \(got 'big'\)"),
        ({"texture": 3}, "scalar", r"groom\.x\.texture: expected a texture name"),
        ({"texture": ""}, "scalar", r"groom\.x\.texture: expected a texture name"),
        ({"texture": "a.png", "wrap": "mirror"}, "scalar", r"groom\.x\.wrap: got 'mirror'"),
        ({"value": 2.0, "wrap": "clamp"}, "scalar", r"groom\.x\.wrap: given without a texture"),
        (1.0, "vector", r"groom\.x: kind='vector'"),
    ],
)
def test_from_spec_bad_input(spec, kind, match):
    with pytest.raises(InputError, match=match):
        PropertyMap.from_spec(spec, kind=kind, name="groom.x")


def test_bad_arguments_and_missing_file(tmp_path):
    with pytest.raises(InputError, match="groom.x: texture must be a Texture"):
        PropertyMap(1.0, np.ones((2, 2)), name="groom.x")
    with pytest.raises(InputError, match=r"groom.x: uv must have shape \(n, 2\)"):
        PropertyMap(1.0, name="groom.x").evaluate(np.ones((3, 3)))
    with pytest.raises(InputError, match="groom.x: uv contains NaN"):
        PropertyMap(1.0, name="groom.x").evaluate([[np.nan, 0.5]])
    textures = {"scalp": Texture(np.ones((1, 1)))}
    spec = {"texture": "nope.png"}
    with pytest.raises(FormatError, match=r"groom\.x\.texture: .*nope\.png.*\['scalp'\]"):
        PropertyMap.from_spec(
            spec, name="groom.x", resolve_path=lambda p: str(tmp_path / p), textures=textures
        )


def test_repr_names_the_parts():
    text = repr(
        PropertyMap(
            [1, 0, 0], Texture(np.ones((2, 2)), name="mask"), kind="color", name="groom.color"
        )
    )
    assert "groom.color" in text and "color" in text and "(1.0, 0.0, 0.0)" in text
    assert "mask" in text
