import pytest

from follicle import ConfigError, FormatError
from follicle.scene import Scene, load_scene, parse_scene, scene_to_toml


def test_defaults_and_partial_sections(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(
        "[groom]\ncount = 500\nroot_color = [0.5, 0.4, 0.3]\n[render]\nsize = [64, 32]\n"
    )
    scene = load_scene(path)
    assert scene.groom.count == 500
    assert scene.groom.root_color == (0.5, 0.4, 0.3)
    assert scene.groom.seed == 0 and scene.guides.path == "builtin:long"
    assert scene.render.size == (64, 32)
    assert scene.base_dir == tmp_path


def test_relative_paths_resolve_against_the_scene_folder(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[mesh]\npath = "meshes/head.obj"\n')
    scene = load_scene(path)
    assert scene.resolve(scene.mesh.path) == str(tmp_path / "meshes/head.obj")
    assert scene.resolve("builtin:head") == "builtin:head"


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"groom": {"count": -1}}, r"\[groom\]\.count: Input should be greater than or equal to 0"),
        ({"groom": {"cuont": 5}}, r"\[groom\]\.cuont: unknown key; did you mean count or"),
        ({"gromm": {}}, r"\[gromm\]: unknown section; did you mean \[groom\]\?$"),
        ({"render": {"size": [0, 5]}}, r"\[render\]\.size\.0: Input should be greater than or"),
        ({"render": {"shading": "phong"}}, r"\[render\]\.shading: Input should be 'kajiya-kay'"),
        ({"sim": {"solver": "magic"}}, r"\[sim\]\.solver: Input should be 'pbd' or 'dftl'"),
        ({"groom": {"density": -2}}, r"\[groom\]\.density: Input should be greater than 0"),
        ({"groom": {"density_refine": 5}}, r"\[groom\]\.density_refine: .*less than or equal"),
        ({"mesh": {"density": 1}}, r"\[mesh\]\.density: unknown key"),
        ({"groom": {"tip_color": [1, 2, 0]}}, r"\[groom\]\.tip_color: colour components must be"),
        ({"groom": {"cut": 1.5}}, r"\[groom\]\.cut: must be ≤ 1 \(got 1.5\)"),
        ({"groom": {"cut": {"value": 2, "texture": "c.png"}}}, r"\[groom\]\.cut: must be ≤ 1"),
        ({"groom": {"scale": {"texture": "s.png", "warp": 1}}}, r"\[groom\]\.scale: unknown key"),
        ({"groom": {"frizz_tip": {"value": 0.1}}}, r"\[groom\]\.frizz_tip: a table needs texture"),
    ],
)
def test_bad_values_name_the_key_and_the_allowed_range(data, message):
    with pytest.raises(ConfigError, match=message):
        parse_scene(data, "scene.toml")


def test_syntax_error_and_missing_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[groom\ncount = 3\n")
    with pytest.raises(ConfigError, match=r"bad\.toml: TOML syntax error"):
        load_scene(bad)
    with pytest.raises(FormatError, match="no such scene file"):
        load_scene(tmp_path / "missing.toml")


def test_scene_to_toml_roundtrips_every_value(tmp_path):
    scene = parse_scene(
        {"groom": {"count": 7, "scale": 1.5}, "render": {"eye": [0, 1, 2], "target": [0, 0, 0]}}
    )
    text = scene_to_toml(scene)
    assert "count = 7  # number of hairs" in text
    assert "eye = [0.0, 1.0, 2.0]" in text
    path = tmp_path / "back.toml"
    path.write_text(text)
    back = load_scene(path)
    assert back.model_dump() == scene.model_dump()
    assert Scene().model_dump() == load_scene(None).model_dump()


def test_eye_and_target_go_together():
    with pytest.raises(ConfigError, match=r"\[render\]: .*set both eye and target"):
        parse_scene({"render": {"eye": [0, 0, 1]}}, "s.toml")
    scene = parse_scene({"render": {"eye": [0, 0, 1], "target": [0, 0, 0]}})
    assert scene.render.target == (0.0, 0.0, 0.0)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        # a prefix: the keys that begin with it, in the schema's order
        (
            {"groom": {"curl": 1}},
            "[groom].curl: unknown key; did you mean curl_radius or"
            " curl_frequency or curl_frequency_tip?",
        ),
        # a misspelling: the closest first, then the names it begins
        ({"sim": {"gravty": [0, -9.8, 0]}}, "[sim].gravty: unknown key; did you mean gravity?"),
        ({"groom": {"count_max": 5}}, "[groom].count_max: unknown key; did you mean count?"),
        ({"rnder": {}}, "[rnder]: unknown section; did you mean [render]?"),
        (
            {"render": {"lights": [{"colour": [1, 1, 1]}]}},
            "[render].lights.0.colour: unknown key; did you mean color?",
        ),
        # a texture table's key
        (
            {"groom": {"scale": {"texture": "s.png", "warp": 1}}},
            "[groom].scale: unknown key(s) ['warp']; did you mean wrap? a table takes value,"
            " texture, wrap",
        ),
        # nothing close: the table's keys, as before
        (
            {"render": {"glossiness": 3}},
            "[render].glossiness: unknown key; allowed keys: size, engine, shading,",
        ),
        (
            {"whatever": {}},
            "[whatever]: unknown section; allowed sections: mesh, guides, groom,"
            " sim, render, output",
        ),
    ],
)
def test_an_unknown_key_or_section_says_what_was_meant(tmp_path, data, message):
    """One line naming the file, the section and the key, the suggestion first (issue
    46); the allowed keys only when nothing is close."""
    path = tmp_path / "look.toml"
    with pytest.raises(ConfigError) as err:
        parse_scene(data, str(path))
    text = str(err.value)
    assert text.startswith(f"{path}: {message}"), text
    assert "\n" not in text and ("allowed" in text) == ("did you mean" not in text)


def test_a_replaced_section_and_the_viewer_say_what_was_meant():
    from follicle.view.controls import check_key

    with pytest.raises(
        ConfigError,
        match=r"^settings: \[grooom\]: unknown section; did you"
        r" mean \[groom\]\?$",
    ):
        Scene().replace(grooom=None)
    with pytest.raises(
        ConfigError,
        match=r"^viewer: \[rendr\]: unknown section; did you mean"
        r" \[render\]\?$",
    ):
        check_key("rendr", "size")
    with pytest.raises(
        ConfigError,
        match=r"^viewer: \[groom\]\.frizz: unknown key; did you mean"
        r" frizz_\w+( or frizz_\w+){3}\?$",  # four at most
    ):
        check_key("groom", "frizz")


@pytest.mark.parametrize(
    ("data", "allowed"),
    [
        ({"render": {"lights": [{"bogus": 1}]}}, "type, direction, space, color, intensity"),
        ({"sim": {"colliders": [{"bogus": 1}]}}, "kind, centre, a, b, radius, normal, follow"),
    ],
)
def test_an_unknown_key_in_a_list_of_tables_lists_that_tables_keys(data, allowed):
    with pytest.raises(ConfigError, match=f"unknown key; allowed keys: {allowed}$"):
        parse_scene(data)
