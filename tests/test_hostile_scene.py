"""Hostile scene files and the files a scene names: meshes, textures, guides, curves.

A scene is TOML written by a person or by anyone who can hand one over, so every way
it can be wrong must end in one clear refusal: nesting that breaks the parser's
recursion, bytes that are not UTF-8, a file of gigabytes; NaN, inf, true or "10" where
a number goes (every numeric key, found by walking the models, so a key added later is
covered too); a FIFO, device or folder where a file goes (no reader may block on it);
meshes near float limits; images whose header promises billions of pixels. Strings
with control characters must survive ``scene_to_toml`` (the simulation cache stores
the scene that way), and random documents built from the schema may only end in a
Scene or a FollicleError.
"""

import json
import math
import os
import struct
import sys
import zlib
from pathlib import Path
from typing import Any, Literal, get_args, get_origin

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image
from pydantic import BaseModel

from follicle import ConfigError, FollicleError, FormatError, InputError
from follicle.groom.settings import MELANIN_KEYS
from follicle.io.dispatch import load_curves
from follicle.io.mesh_load import load_mesh
from follicle.mesh.skin import MAX_COORDINATE, SkinMesh
from follicle.mesh.texture import MAX_TEXTURE_PIXELS, Texture
from follicle.scene import MAX_SCENE_BYTES, Scene, load_scene, parse_scene, scene_to_toml
from hostile import assert_api_refused, assert_cli_refused, files, run_api, run_cli

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

SECTIONS: dict[str, type[BaseModel]] = {
    name: field.annotation for name, field in Scene.model_fields.items() if not field.exclude
}


# ------------------------------------------------------------------ the TOML itself
@pytest.mark.parametrize(
    ("text", "problem"),
    [
        (b"a = " + b"[" * 100_000, "nested too deeply"),
        (b"a = " + b"{b = " * 50_000, "nested too deeply"),
        (b"[groom]\ncount = 5\xff\xfe\n", "not a UTF-8 text file"),
        (b"[groom]\ncount = 5\x00\n", "TOML syntax error"),
        (b'[mesh]\npath = "a\x00b"\n', "TOML syntax error"),
        (b"[groom]\ncount = " + b"9" * 5000 + b"\n", "too large to read"),
    ],
    ids=["arrays", "tables", "utf8", "nul", "nul-in-string", "digits"],
)
def test_unparseable_scene_is_a_config_error(tmp_path, text, problem):
    path = tmp_path / "s.toml"
    path.write_bytes(text)
    with pytest.raises(ConfigError, match=rf"s\.toml: .*{problem}") as err:
        load_scene(path)
    assert "\n" not in str(err.value) and "set_int_max_str_digits" not in str(err.value)


def test_oversized_scene_is_refused_before_parsing(tmp_path):
    path = tmp_path / "s.toml"
    with open(path, "wb") as fh:  # a valid TOML comment, one byte over the limit
        fh.write(b"#" + b" " * MAX_SCENE_BYTES + b"\n")
    with pytest.raises(ConfigError, match=r"s\.toml: larger than 1 MiB"):
        load_scene(path)


@pytest.mark.slow
def test_nested_scene_on_the_command_line(tmp_path):
    (tmp_path / "deep.toml").write_bytes(b"[groom]\ncount = " + b"[" * 200_000)
    before = files(tmp_path)
    line = assert_cli_refused(
        run_cli("grow", "deep.toml", "-o", "h.npz", cwd=tmp_path), "deep.toml", "nested too deeply"
    )
    assert files(tmp_path) == before, line


# ------------------------------------------------------------------ every number key
SAMPLES: tuple[Any, ...] = (
    0.5,
    0.01,
    1,
    2,
    12,
    [0.5, 0.5, 0.5],
    [0.25, 0.75],
    [64, 64],
    [2000, 600, 150],  # [cards].counts: one count per level, lods 3
    {"#ff0000": 12},
    {"specular": 0.3},
    {"value": 0.5, "texture": "t.png"},
    512,  # [render].shadow_size: at least 16
)
# a section as it must be for one key to be valid (render: eye needs a target)
CONTEXT = {"render": {"eye": [0, 0, 1], "target": [0, 0, 0]}}
# a key that takes effect only beside another (the melanin keys: with melanin)
NEEDS = {("groom", key): {"melanin": 0.5} for key in MELANIN_KEYS}
BAD = (math.nan, math.inf, -math.inf, 1e300, -1e300, True, "1")


def _valid(section: str, data: dict) -> bool:
    try:
        parse_scene({section: data})
    except ConfigError:
        return False
    return True


def _walk(
    section: str, model: type[BaseModel], base: dict, wrap=lambda d: d, prefix: tuple = ()
) -> tuple[list, list]:
    """(key path, valid section data with a number at it, the key takes a texture path)
    for every numeric key of ``model``, entries of ``[[lists]]`` of tables included
    (``wrap`` puts such an entry's table into its section); and the keys that took no
    sample and no text (a new kind of value: add a sample for it)."""
    found, missing = [], []
    for key, field in model.model_fields.items():
        if field.annotation is bool:
            continue
        tables = [
            a
            for a in get_args(field.annotation)
            if isinstance(a, type) and issubclass(a, BaseModel)
        ]
        if tables:
            sub = _walk(
                section,
                tables[0],
                {},
                lambda d, key=key: wrap({**base, key: [d]}),
                (*prefix, key, 0),
            )
            found += sub[0]
            missing += sub[1]
            continue
        ctx = {**base, **NEEDS.get((section, key), {})}
        text = (  # a text key, or a list of names ([groom].inherit): it takes no number
            _valid(section, wrap({**ctx, key: "t.png"}))
            or _valid(section, wrap({**ctx, key: ["t.png"]}))
            or isinstance(field.default, str)
            or _names(field.annotation)  # an optional choice ([guides].generate)
        )
        sample = next((s for s in SAMPLES if _valid(section, wrap({**ctx, key: s}))), None)
        if sample is not None:
            found.append(((*prefix, key), wrap({**ctx, key: sample}), text))
        elif not text:
            missing.append(f"[{section}]." + ".".join(map(str, (*prefix, key))))
    return found, missing


def _names(annotation: Any) -> bool:
    """Whether a key's type is a choice of names (a Literal of strings), alone or in a
    union (with None: a choice that may be unset): it takes no number."""
    kinds = (annotation, *get_args(annotation))
    return any(
        get_origin(k) is Literal and all(isinstance(v, str) for v in get_args(k)) for k in kinds
    )


def _numbers(value: Any, at: tuple = ()) -> list[tuple]:
    """Paths inside ``value`` (lists, tables) to its numbers."""
    if isinstance(value, bool):
        return []
    if isinstance(value, (int, float)):
        return [at]
    items = (
        value.items()
        if isinstance(value, dict)
        else enumerate(value)
        if isinstance(value, list)
        else ()
    )
    return [p for k, v in items for p in _numbers(v, (*at, k))]


def _replaced(value: Any, path: tuple, new: Any) -> Any:
    if not path:
        return new
    out = dict(value) if isinstance(value, dict) else list(value)
    out[path[0]] = _replaced(value[path[0]], path[1:], new)
    return out


def test_every_number_key_refuses_non_finite_huge_bool_and_text():
    """Walks every section's models: each number (or number inside a list or table) of
    a valid value is replaced by NaN, ±inf, ±1e300, true and "1" in turn; each must be a
    ConfigError naming ``[section].key``. Fails listing every key that takes one."""
    accepted, checked = [], 0
    for section, model in SECTIONS.items():
        found, missing = _walk(section, model, CONTEXT.get(section, {}))
        assert not missing, f"no numeric sample fits {missing}: add one to SAMPLES"
        for path, doc, text in found:
            where = f"[{section}]." + ".".join(map(str, path))
            for at in _numbers(doc[path[0]]):
                for bad in BAD:
                    if bad == "1" and text and len(at) == 0:
                        continue  # a texture path "1": a valid value
                    data = {**doc, path[0]: _replaced(doc[path[0]], at, bad)}
                    checked += 1
                    try:
                        parse_scene({section: data}, "s.toml")
                    except ConfigError as exc:
                        named = tuple(f"s.toml: [{section}]{sep}{path[0]}" for sep in (".", ": "))
                        assert str(exc).startswith(named), (where, exc)
                    else:
                        accepted.append(f"{where}{list(at)} = {bad!r}")
    assert checked > 900
    assert not accepted, f"{len(accepted)} accepted:\n" + "\n".join(accepted)


def test_walk_reaches_nested_and_optional_keys():
    """The walk above covers keys unset by default and those of [[lists]] of tables."""
    keys = {
        f"{s}." + ".".join(map(str, p))
        for s, m in SECTIONS.items()
        for p, _, _ in _walk(s, m, CONTEXT.get(s, {}))[0]
    }
    assert {
        "render.eye",
        "render.target",
        "render.lights.0.direction",
        "render.size",
        "render.msaa",
        "render.shading_params",
        "groom.density",
        "groom.vertices",
        "groom.cut",
        "groom.group_vertices",
        "sim.colliders.0.centre",
        "sim.wind",
        "sim.motion_pivot",
    } <= keys


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (
            {"render": {"eye": [math.nan, 0, 1], "target": [0, 0, 0]}},
            r"\[render\]\.eye\.0: Input should be a finite number \(got nan\)",
        ),
        ({"sim": {"wind": [math.inf, 0, 0]}}, r"\[sim\]\.wind\.0: Input should be a finite"),
        ({"groom": {"count": True}}, r"\[groom\]\.count: Input should be a valid integer"),
        ({"groom": {"count": "10"}}, r"\[groom\]\.count: Input should be a valid integer"),
        ({"render": {"msaa": True}}, r"\[render\]\.msaa: expected a number \(got true\)$"),
        ({"groom": {"count": False}}, r"\[groom\]\.count: .*valid integer \(got false\)$"),
        ({"render": {"size": ["64", 64]}}, r"\[render\]\.size\.0: Input should be a valid int"),
        (
            {"groom": {"frizz_frequency": [1e7, 0, 0]}},
            r"\[groom\]\.frizz_frequency\.0: Input should be less than or equal to 1000000",
        ),
        ({"groom": {"count": "x" * 10_000}}, r"\[groom\]\.count: .*\(got 'xxx.{40,60}\.\.\.\)$"),
        ({"groom": {"a\nb": 1}}, r"\[groom\]\.'a\\nb': unknown key"),
        ({"base_dir": "/etc"}, r"^scene\.toml: \[base_dir\]: unknown key; allowed keys: mesh,"),
        (
            {"render": {"shading_params": {"specular": [1, 2]}}},
            r"\[render\]\.shading_params\.specular: Input should be a valid number"
            r" \(got \[1, 2\]\)$",
        ),
    ],
    ids=[
        "nan-eye",
        "inf-wind",
        "bool-count",
        "text-count",
        "bool-msaa",
        "false-count",
        "text-size",
        "huge-vector",
        "long-value",
        "newline-key",
        "base-dir",
        "list-for-number",
    ],
)
def test_bad_number_messages(data, message):
    with pytest.raises(ConfigError, match=message) as err:
        parse_scene(data, "scene.toml")
    assert "\n" not in str(err.value)


def test_lists_still_fill_tuples():
    scene = parse_scene(
        {
            "render": {
                "size": [64, 32],
                "eye": [0, 1, 2],
                "target": [0, 0, 0],
                "lights": [{"direction": [0, 1, 0], "color": [1, 1, 1]}],
            },
            "groom": {"root_color": [0.1, 0.2, 0.3], "density": 2},
        }
    )
    assert scene.render.size == (64, 32) and scene.render.eye == (0.0, 1.0, 2.0)
    assert scene.render.lights[0].color == (1.0, 1.0, 1.0) and scene.groom.density == 2.0


# ------------------------------------------------------------------ scene_to_toml
def _round_trip(scene: Scene) -> None:
    text = scene_to_toml(scene)
    again = parse_scene(tomllib.loads(text))
    assert again.model_dump() == scene.model_dump()


@pytest.mark.parametrize("value", ["a\nb", "\x00", '"', "\\", 'a\\"b\r\n\t\x7f\x1b', "é😀"])
def test_control_characters_are_written_as_valid_toml(value):
    _round_trip(
        parse_scene(
            {
                "mesh": {"path": value},
                "output": {"image": value},
                "groom": {"group_vertices": {value: 4}},
            }
        )
    )


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(text=st.text(max_size=30), key=st.text(max_size=10))
@pytest.mark.slow
def test_any_string_round_trips_through_scene_to_toml(text, key):
    scene = parse_scene(
        {
            "mesh": {"path": text, "displacement": text},
            "guides": {"path": text},
            "output": {"curves": text, "image": text},
            "groom": {"group_vertices": {key: 3}},
        }
    )
    _round_trip(scene)


def test_unwritable_text_is_a_config_error():
    scene = parse_scene({"mesh": {"path": "bad\udcffname.obj"}})
    with pytest.raises(ConfigError, match="not valid Unicode"):
        scene_to_toml(scene)


# ------------------------------------------------------------------ random documents
def _keys(model: type[BaseModel]) -> list[str]:
    out = []
    for key, field in model.model_fields.items():
        out.append(key)
        out += [
            k
            for a in get_args(field.annotation)
            if isinstance(a, type) and issubclass(a, BaseModel)
            for k in _keys(a)
        ]
    return out


KEYS = {s: _keys(m) for s, m in SECTIONS.items()}
DEFAULTS = [v for m in SECTIONS.values() for v in m().model_dump().values() if v is not None]
LEAVES = st.one_of(
    st.booleans(),
    st.integers(-(2**63), 2**63 - 1),
    st.floats(),
    st.text(max_size=12),
    st.datetimes(),
    st.dates(),
    st.times(),
    st.sampled_from(DEFAULTS + list(SAMPLES)),
    st.sampled_from([1e308, -1e308, 5e-324, 2**63 - 1, "builtin:head", "builtin:nope", ""]),
)
VALUES = st.recursive(
    LEAVES,
    lambda inner: (
        st.lists(inner, max_size=4)
        | st.dictionaries(
            st.sampled_from(sorted({k for ks in KEYS.values() for k in ks})) | st.text(max_size=6),
            inner,
            max_size=4,
        )
    ),
    max_leaves=12,
)
SECTION_DOCS = st.sampled_from(sorted(KEYS)).flatmap(
    lambda s: st.tuples(
        st.just(s),
        st.dictionaries(st.sampled_from(KEYS[s]) | st.text(max_size=6), VALUES, max_size=6),
    )
)
DOCUMENTS = st.lists(SECTION_DOCS | st.tuples(st.text(max_size=6), VALUES), max_size=5).map(dict)


@settings(
    max_examples=200,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(doc=DOCUMENTS)
@pytest.mark.slow
def test_random_documents_give_a_scene_or_a_config_error(doc):
    try:
        scene = parse_scene(doc, "fuzz.toml")
    except ConfigError as exc:
        assert str(exc).startswith("fuzz.toml: ")
        return
    _round_trip(scene)  # whatever is accepted can be written and read back


FRAGMENTS = st.sampled_from(
    [
        "[groom]\n",
        "[render]\n",
        "[sim]\n",
        "[[render.lights]]\n",
        "[[sim.colliders]]\n",
        "[mesh]\n",
        "\n",
        " = ",
        "count",
        "eye",
        "size",
        "cut",
        "density",
        "1",
        "-0.5",
        "nan",
        "inf",
        "1e999",
        "0x7fffffffffffffff",
        "true",
        "1979-05-27T07:32:00Z",
        '"t.png"',
        "[",
        "]",
        "{",
        "}",
        ",",
        '"',
        "'''",
        "\\u0000",
        "\x00",
        "#",
        "a.b.c",
        "\udcff",
        "é",
    ]
)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(parts=st.lists(FRAGMENTS | st.text(max_size=4), max_size=40), junk=st.binary(max_size=4))
def test_random_scene_text_gives_a_scene_or_a_follicle_error(tmp_path_factory, parts, junk):
    path = tmp_path_factory.mktemp("fuzz") / "s.toml"
    path.write_bytes("".join(parts).encode("utf-8", "surrogateescape") + junk)
    try:
        load_scene(path)
    except FollicleError as exc:
        assert "s.toml" in str(exc) and "\n" not in str(exc)


# ------------------------------------------------------------------ files that are not files
NOT_FILES = [  # (scene sections, the path it names, what that path is)
    ({"mesh": {"path": "m.obj"}}, "m.obj", "FIFO"),
    ({"mesh": {"path": "zero.obj"}}, "zero.obj", "device"),
    ({"groom": {"count": 20, "density": "d.png"}}, "d.png", "FIFO"),
    ({"groom": {"count": 20, "groups": "g.png"}}, "g.png", "folder"),
    ({"groom": {"count": 20, "root_color": "c.png"}}, "c.png", "device"),
    ({"mesh": {"displacement": "disp.tif"}}, "disp.tif", "FIFO"),
    ({"guides": {"path": "g.hair"}}, "g.hair", "FIFO"),
    ({"guides": {"path": "g.obj"}}, "g.obj", "device"),
]


def _not_file_scenes(folder: Path) -> list[tuple[str, str, str]]:
    """Writes a scene (s0.toml, s1.toml, ...) for each of NOT_FILES and the FIFO, device
    link or folder it names; returns (scene, name, kind) for each."""
    out = []
    for i, (sections, name, kind) in enumerate(NOT_FILES):
        lines = []
        for section, keys in sections.items():
            lines.append(f"[{section}]")
            lines += [f"{k} = {v!r}".replace("'", '"') for k, v in keys.items()]
        if "groom" not in sections:
            lines.append("[groom]\ncount = 20")
        (folder / f"s{i}.toml").write_text("\n".join(lines) + "\n")
        if kind == "FIFO":
            os.mkfifo(folder / name)
        elif kind == "device":
            os.symlink("/dev/zero", folder / name)
        else:
            (folder / name).mkdir()
        out.append((f"s{i}.toml", name, kind))
    return out


@pytest.mark.slow
def test_scene_paths_that_are_not_files_are_refused_at_once(tmp_path):
    """Every path a scene names (mesh, displacement, density, groups, a property map,
    guides) that is a FIFO, /dev/zero or a folder is refused naming it, not read: one
    child process (under the 2 GiB / 30 s limits) grows each scene in turn."""
    cases = _not_file_scenes(tmp_path)
    res = run_api(
        f"""
        import json
        from follicle.errors import FollicleError
        from follicle.pipeline import grow
        from follicle.scene import load_scene
        result = []
        for scene, _, _ in {cases!r}:
            try:
                grow(load_scene(scene))
            except FollicleError as exc:
                result.append((type(exc).__name__, str(exc)))
            else:
                result.append(("grown", scene))
        print("@@@" + json.dumps(result))
        """,
        tmp_path,
    )
    assert res.kind == "ok", f"{res.kind} {res.error}: {res.message}"
    shown = next(line for line in res.outcome.stdout.splitlines() if line.startswith("@@@"))
    got = json.loads(shown[3:])
    for (scene, name, kind), (error, message) in zip(cases, got, strict=True):
        assert error in ("FormatError", "InputError"), (scene, error, message)
        assert name in message and kind in message and "\n" not in message, (scene, message)


@pytest.mark.slow
def test_scene_path_that_is_a_fifo_on_the_command_line(tmp_path):
    scene, name, kind = _not_file_scenes(tmp_path)[0]  # the mesh, a FIFO
    before = files(tmp_path)
    assert_cli_refused(run_cli("grow", scene, "-o", "h.npz", cwd=tmp_path), name, kind)
    assert files(tmp_path) == before


@pytest.mark.parametrize(
    ("args", "name"),
    [
        (("info", "f.toml"), "f.toml"),
        (("render", "c.obj", "-o", "x.png"), "c.obj"),
    ],
    ids=["info-scene", "render-obj"],
)
@pytest.mark.slow
def test_fifo_inputs_on_the_command_line_do_not_block(tmp_path, args, name):
    os.mkfifo(tmp_path / name)
    before = files(tmp_path)
    assert_cli_refused(run_cli(*args, cwd=tmp_path), name, "FIFO")
    assert files(tmp_path) == before


@pytest.mark.slow
def test_readers_refuse_fifos_and_devices_in_python(tmp_path):
    for name in ("c.hair", "c.tfx", "c.obj", "c.txt"):
        os.mkfifo(tmp_path / name)
        os.symlink("/dev/zero", tmp_path / f"z{name}")
    res = run_api(
        """
        from follicle.io.dispatch import load_curves
        from follicle.errors import FormatError
        result = []
        for name in ("c.hair", "c.tfx", "c.obj", "c.txt", "zc.hair", "zc.obj"):
            try:
                load_curves(name)
            except FormatError as exc:
                result.append(str(exc))
        """,
        tmp_path,
    )
    assert res.kind == "ok", res.message
    shown = res.detail["result"]
    for name in ("c.hair", "c.tfx", "c.obj", "c.txt"):
        assert f"{name}: is a FIFO" in shown
        assert f"z{name}: is a device" in shown or name in ("c.tfx", "c.txt")


def test_scene_that_is_a_folder_or_fifo_in_python(tmp_path):
    (tmp_path / "d.toml").mkdir()
    with pytest.raises(FormatError, match=r"d\.toml: is a folder, not a file; give a scene file"):
        load_scene(tmp_path / "d.toml")
    os.mkfifo(tmp_path / "f.toml")
    with pytest.raises(FormatError, match=r"f\.toml: is a FIFO"):
        load_scene(tmp_path / "f.toml")
    with pytest.raises(FormatError, match=r"f\.toml: is a FIFO"):
        Texture.load(tmp_path / "f.toml")
    with pytest.raises(FormatError, match=r"d\.toml: is a folder, not a file; give a PNG"):
        Texture.load(tmp_path / "d.toml")


def test_nul_in_a_curves_path_is_a_format_error(tmp_path):
    (tmp_path / "s.toml").write_text('[guides]\npath = "a\\u0000b.hair"\n')
    with pytest.raises(FormatError, match="a\x00b.hair"):
        load_curves(load_scene(tmp_path / "s.toml").guides.path)


@pytest.mark.slow
def test_scene_that_is_a_folder_on_the_command_line(tmp_path):
    (tmp_path / "d.toml").mkdir()
    assert_cli_refused(run_cli("grow", "d.toml", "-o", "h.npz", cwd=tmp_path), "d.toml", "folder")


# ------------------------------------------------------------------ meshes
def _obj(path: Path, scale: float) -> Path:
    path.write_text(f"v 0 0 0\nv {scale} 0 0\nv 0 {scale} 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n")
    return path


@pytest.mark.parametrize("scale", [1e38, 3e38, 1e7, -2e6])
def test_mesh_beyond_the_coordinate_limit_is_refused(tmp_path, scale):
    with pytest.raises(
        InputError,
        match=r"far\.obj: mesh 'far': vertex 1 = .* lies beyond"
        r" the limit \|coordinate\| ≤ 1e\+06 m",
    ):
        load_mesh(_obj(tmp_path / "far.obj", scale))
    mesh = load_mesh(_obj(tmp_path / "near.obj", MAX_COORDINATE))
    with pytest.raises(InputError, match="pose vertex 1 .* lies beyond"):
        mesh.posed(transform=np.diag([1e300, 1.0, 1.0, 1.0]))


def test_degenerate_mesh_is_refused(tmp_path):
    (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\nf 3 2 1\n")
    with pytest.raises(InputError, match=r"flat\.obj: .*all 2 faces have zero area"):
        load_mesh(tmp_path / "flat.obj")
    with pytest.raises(InputError, match="all 1 faces have zero area"):
        SkinMesh([[0, 0, 0], [1e-200, 0, 0], [0, 1e-200, 0]], [[0, 1, 2]])


@pytest.mark.slow
def test_far_mesh_in_a_scene_on_the_command_line(tmp_path):
    _obj(tmp_path / "far.obj", 1e38)
    (tmp_path / "s.toml").write_text('[mesh]\npath = "far.obj"\n[groom]\ncount = 20\n')
    before = files(tmp_path)
    assert_cli_refused(run_cli("grow", "s.toml", "-o", "h.npz", cwd=tmp_path), "far.obj", "1e+06")
    assert files(tmp_path) == before


# ------------------------------------------------------------------ images
def _png_header(path: Path, width: int, height: int) -> Path:
    """A PNG whose header promises ``width`` × ``height`` grey pixels and holds none."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b""))
    return path


@pytest.mark.parametrize(
    "size",
    [(8193, 8192), (9500, 9500), (10_000, 10_000), (100_000, 100_000)],
    ids=["just-over", "below-pillow-warning", "pillow-warning", "pillow-bomb"],
)
def test_image_over_the_pixel_limit_is_refused_before_decoding(tmp_path, size):
    path = _png_header(tmp_path / "big.png", *size)
    with pytest.raises(FormatError, match=r"big\.png.*at most 67,108,864 pixels \(8192 × 8192\)"):
        Texture.load(path)
    assert MAX_TEXTURE_PIXELS == 8192 * 8192


def test_image_at_the_limit_side_is_read(tmp_path):
    Image.new("L", (8192, 2), 7).save(tmp_path / "wide.png")
    assert Texture.load(tmp_path / "wide.png").shape == (2, 8192, 1)


def test_truncated_image_is_a_format_error(tmp_path):
    Image.fromarray(np.random.default_rng(1).integers(0, 255, (64, 64), np.uint8)).save(
        tmp_path / "cut.png"
    )
    data = (tmp_path / "cut.png").read_bytes()
    (tmp_path / "cut.png").write_bytes(data[: len(data) // 2])
    with pytest.raises(FormatError, match=r"cut\.png.*cannot be read"):
        Texture.load(tmp_path / "cut.png")


@pytest.mark.slow
def test_huge_density_image_on_the_command_line(tmp_path):
    _png_header(tmp_path / "big.png", 12_000, 12_000)  # in pillow's warning range
    (tmp_path / "s.toml").write_text('[groom]\ncount = 20\ndensity = "big.png"\n')
    before = files(tmp_path)
    assert_cli_refused(
        run_cli("grow", "s.toml", "-o", "h.npz", cwd=tmp_path), "big.png", "8192 × 8192"
    )
    assert files(tmp_path) == before


def test_huge_texture_in_python_within_the_limits(tmp_path):
    _png_header(tmp_path / "big.png", 60_000, 60_000)
    res = run_api("from follicle.mesh.texture import Texture\nTexture.load('big.png')", tmp_path)
    assert_api_refused(res, "big.png", "pixels", error="FormatError")
