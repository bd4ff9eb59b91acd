"""Units: files in other units are converted to metres once, at load, when the user says
so ([mesh].units, [guides].units, units= on the loaders); sizes that suggest another unit
are one warning line naming the file and the setting that fixes them."""

from __future__ import annotations

import logging
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import follicle
from follicle import ConfigError, HairCurves, InputError
from follicle.groom.builtin_guides import builtin_guides
from follicle.groom.guides import load_guides
from follicle.io.dispatch import load_curves, save
from follicle.io.mesh_load import load_mesh
from follicle.mesh.skin import SkinMesh
from follicle.pipeline import groom_scene, grow
from follicle.scene import Scene, load_scene, parse_scene, scene_from_toml
from follicle.units import DECLARED_UNITS, metres_per_unit
from hairfiles import hair
from meshes import plane

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
ACCEPTED = '"m", "cm", "mm", "in" or a positive number of metres per unit'


def save_mesh(vertices: np.ndarray, faces: np.ndarray, uvs: np.ndarray | None, path: Path) -> Path:
    """An OBJ file of the mesh, every coordinate written exactly (20 decimals)."""
    SkinMesh(vertices, faces, uvs).to_trimesh().export(path, digits=20)
    return path


def strands(roots: object, length: float, vertices: int = 5) -> HairCurves:
    """Straight guides of ``length`` rising along +Y from ``roots``."""
    steps = np.linspace(0.0, length, vertices)[None, :, None] * np.array([0.0, 1.0, 0.0])
    return HairCurves.from_array(np.asarray(roots, np.float64)[:, None, :] + steps)


def floor(size: float = 10.0) -> SkinMesh:
    """A plausible mesh: the XZ square [0, size]² (metres), 14.1 m across at size 10."""
    p = plane(4)
    return SkinMesh(p.rest_vertices * size, p.faces, p.uvs, name="floor")


def warnings_of(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]


# ---------------------------------------------------------------- accepted units


def test_named_units_and_numbers_of_metres():
    assert [metres_per_unit(u) for u in ("m", "cm", "mm", "in")] == [1.0, 0.01, 0.001, 0.0254]
    assert metres_per_unit(0.3048) == 0.3048 and metres_per_unit(2) == 2.0
    assert metres_per_unit(np.float32(0.5)) == 0.5


BAD = [
    ("furlong", "'furlong'"),
    (-1, "-1"),
    (0, "0"),
    (math.nan, "nan"),
    (math.inf, "inf"),
    (["cm"], "['cm']"),
    (True, "true"),
    ("CM", "'CM'"),
]


@pytest.mark.parametrize("section", ["mesh", "guides"])
@pytest.mark.parametrize(("value", "shown"), BAD)
def test_bad_units_are_one_line_naming_the_key_and_the_accepted_values(section, value, shown):
    with pytest.raises(ConfigError) as err:
        parse_scene({section: {"units": value}}, "scene.toml")
    assert str(err.value) == f"scene.toml: [{section}].units: expected {ACCEPTED} (got {shown})"


@pytest.mark.parametrize(("value", "shown"), BAD)
def test_bad_units_on_the_python_functions_are_input_errors_before_reading(tmp_path, value, shown):
    missing = tmp_path / "missing"  # units are checked first: no FormatError for the file
    for call in (
        lambda: load_mesh(missing.with_suffix(".obj"), units=value),
        lambda: load_curves(missing.with_suffix(".hair"), units=value),
        lambda: load_guides(missing.with_suffix(".obj"), floor(), units=value),
        lambda: load_guides(strands([[1, 0, 1]], 0.1), floor(), units=value),
    ):
        with pytest.raises(InputError) as err:
            call()
        assert str(err.value) == f"units: expected {ACCEPTED} (got {shown})"


@pytest.mark.parametrize("text", ["nan", "inf", "-inf", '"furlong"', "[1, 2]"])
def test_bad_units_in_a_scene_file(text):
    with pytest.raises(ConfigError, match=r"^s\.toml: \[guides\]\.units: expected \"m\""):
        scene_from_toml(f'[guides]\npath = "g.hair"\nunits = {text}\n', "s.toml")


def test_units_of_a_scene_read_back_and_write_out():
    scene = scene_from_toml(
        '[mesh]\npath = "a.obj"\nunits = "cm"\n[guides]\npath = "g.tfx"\nunits = 0.0254\n', "s.toml"
    )
    assert (scene.mesh.units, scene.guides.units) == ("cm", 0.0254)
    assert Scene().mesh.units == "m" and Scene().guides.units == "m"
    from follicle.scene import scene_to_toml

    assert scene_from_toml(scene_to_toml(scene), "back").model_dump() == scene.model_dump()


def test_the_viewer_saves_units_as_names_not_as_paths(tmp_path):
    from follicle.view.scenefile import save_scene

    scene = parse_scene(
        {
            "mesh": {"path": "head.obj", "units": "cm"},
            "guides": {"path": "g.hair", "units": 0.0254},
        },
        "s",
        tmp_path,
    )
    back = load_scene(save_scene(scene, tmp_path / "sub" / "saved.toml"))
    assert (back.mesh.path, back.mesh.units, back.guides.units) == ("../head.obj", "cm", 0.0254)


def test_builtins_are_metres_and_take_no_other_units():
    with pytest.raises(ConfigError) as err:
        parse_scene({"mesh": {"units": "cm"}}, "s.toml")
    assert str(err.value) == (
        "s.toml: [mesh].units: builtin:bust is in metres; units apply to"
        ' files only: remove it (got "cm")'
    )
    with pytest.raises(ConfigError, match=r"^s\.toml: \[guides\]\.units: builtin:short is in"):
        parse_scene({"guides": {"path": "builtin:short", "units": 0.001}}, "s.toml")
    parse_scene({"mesh": {"units": "m"}, "guides": {"units": 1.0}})  # metres: fine
    with pytest.raises(InputError, match=r"^units: builtin:head is in metres"):
        load_mesh("builtin:head", units="mm")
    with pytest.raises(InputError, match=r"^units: builtin:long is in metres"):
        load_guides("builtin:long", load_mesh("builtin:head"), units="cm")


def test_formats_that_declare_a_unit_refuse_another():
    """USD applies the stage's metersPerUnit and glTF is metres: units would count twice."""
    with pytest.raises(ConfigError) as err:
        parse_scene({"guides": {"path": "groom.usda", "units": "cm"}}, "s.toml")
    assert str(err.value).startswith(
        "s.toml: [guides].units: USD files declare their own unit (metersPerUnit; unset means"
        " centimetres), which follicle applies when reading 'groom.usda'; more units would"
        " count twice: remove them"
    )
    with pytest.raises(ConfigError, match=r"^s\.toml: \[mesh\]\.units: glTF files are in metres"):
        parse_scene({"mesh": {"path": "head.glb", "units": 0.01}}, "s.toml")
    with pytest.raises(InputError, match=r"^units: USD files declare their own unit"):
        load_curves("nowhere.usdc", units="mm")
    # units = "m" (the default) stays allowed for them
    parse_scene({"mesh": {"path": "head.gltf", "units": "m"}, "guides": {"path": "g.usd"}})


def test_every_usd_suffix_is_a_declared_unit_format():
    from follicle.io.usd import SUFFIXES

    assert set(SUFFIXES) <= set(DECLARED_UNITS)


# ---------------------------------------------------------------- conversion at load


def test_load_mesh_converts_vertices_to_metres(tmp_path):
    p = plane(2)
    path = save_mesh(p.rest_vertices * 40.0, p.faces, p.uvs, tmp_path / "square.obj")
    for units, scale in (("cm", 0.4), (0.01, 0.4), ("mm", 0.04), ("in", 40 * 0.0254)):
        mesh = load_mesh(path, units=units)
        np.testing.assert_allclose(mesh.rest_vertices, p.rest_vertices * scale, rtol=1e-15)
        np.testing.assert_array_equal(mesh.uvs, p.uvs)  # UVs carry no length
    np.testing.assert_array_equal(load_mesh(path).rest_vertices, p.rest_vertices * 40.0)


@pytest.mark.parametrize("suffix", [".npz", ".hair"])
def test_load_curves_converts_points_and_widths(tmp_path, suffix):
    original = hair()
    path = save(original, tmp_path / f"h{suffix}")
    as_is = load_curves(path)
    for units, factor in (("mm", 0.001), ("in", 0.0254), (3.0, 3.0)):
        got = load_curves(path, units=units)
        np.testing.assert_array_equal(got.offsets, as_is.offsets)
        # float32 of the exact product: within half a float32 step (6e-8 relative)
        np.testing.assert_allclose(got.points, as_is.points.astype(np.float64) * factor, rtol=6e-8)
        np.testing.assert_allclose(
            got.point_data["width"],  # a diameter: a length
            as_is.point_data["width"].astype(np.float64) * factor,
            rtol=6e-8,
        )
        np.testing.assert_array_equal(got.point_data["color"], as_is.point_data["color"])
        assert got.points.dtype == np.float32 and got.point_data["width"].dtype == np.float32


def test_load_guides_converts_hair_curves_too():
    mesh = floor()
    given = strands([[1.0, 0.0, 1.0], [5.0, 0.0, 5.0]], 0.3)
    cm = given.with_points(given.points * 100)
    guides = load_guides(cm, mesh, units="cm")
    np.testing.assert_allclose(guides.curves.points, given.points, rtol=1e-7)
    np.testing.assert_allclose(guides.rest_shapes(5)[:, -1], [[0, 0.3, 0], [0, 0.3, 0]], atol=1e-7)


# ---------------------------------------------------------------- the acceptance check


@pytest.fixture(scope="module")
def twins(tmp_path_factory) -> Path:
    """The built-in head and its long guides as OBJ files in metres (``*_m.obj``) and times
    100 in centimetres (``*_cm.obj``). Positions are first put on a binary grid (2⁻²⁰ m for
    the mesh, 2⁻¹⁶ m for the float32 guides) where ×100 in the file and ×0.01 on loading
    are exact, so the two load alike and only the conversion can make their hair differ."""
    out = tmp_path_factory.mktemp("twins")
    head = load_mesh("builtin:head")
    guides = builtin_guides("long", head)
    vertices = np.round(head.rest_vertices * 2.0**20) / 2.0**20
    points = np.round(guides.points.astype(np.float64) * 2.0**16) / 2.0**16
    for tag, scale in (("m", 1.0), ("cm", 100.0)):
        save_mesh(vertices * scale, head.faces, head.uvs, out / f"head_{tag}.obj")
        save(HairCurves(points * scale, guides.offsets), out / f"long_{tag}.obj")
    return out


def twin_scene(folder: Path, mesh: str, guides: str, units: str | None = None) -> Scene:
    def section(name: str) -> dict:
        return {"path": str(folder / name), **({"units": units} if units else {})}

    return parse_scene(
        {
            "mesh": section(mesh),
            "guides": section(guides),
            "groom": {"count": 400, "density": "builtin:scalp", "groups": "builtin:parting"},
        }
    )


@pytest.mark.slow
def test_a_centimetre_scene_with_units_grows_the_metre_scene_hair(twins, caplog):
    with caplog.at_level(logging.WARNING, logger="follicle"):
        _, metre = grow(twin_scene(twins, "head_m.obj", "long_m.obj"))
        _, cm = grow(twin_scene(twins, "head_cm.obj", "long_cm.obj", units="cm"))
    assert warnings_of(caplog) == []
    assert cm.curve_count == metre.curve_count == 400
    np.testing.assert_array_equal(cm.offsets, metre.offsets)
    reach = float(np.abs(metre.points).max())
    assert 0.2 < reach < 1.0  # metres: a head's hair, not 100× that
    tolerance = 4 * np.finfo(np.float32).eps * reach
    np.testing.assert_allclose(cm.points, metre.points, rtol=0, atol=tolerance)
    np.testing.assert_array_equal(cm.point_data["width"], metre.point_data["width"])
    assert 89e-6 < cm.point_data["width"].min() < cm.point_data["width"].max() < 241e-6


@pytest.mark.slow
def test_the_python_loaders_take_units(twins):
    mesh_m = load_mesh(twins / "head_m.obj")
    for units in ("cm", 0.01):
        mesh = load_mesh(twins / "head_cm.obj", units=units)
        np.testing.assert_array_equal(mesh.rest_vertices, mesh_m.rest_vertices)
    assert load_curves(twins / "long_cm.obj", units="cm") == load_curves(twins / "long_m.obj")
    guides = load_guides(twins / "long_cm.obj", mesh_m, units="cm")
    reference = load_guides(twins / "long_m.obj", mesh_m)
    np.testing.assert_array_equal(guides.triangles, reference.triangles)
    np.testing.assert_array_equal(guides.local, reference.local)


def test_centimetre_files_without_units_warn_naming_cm_and_the_keys(twins, caplog):
    with caplog.at_level(logging.WARNING, logger="follicle"):
        groom_scene(twin_scene(twins, "head_cm.obj", "long_cm.obj"))
    assert warnings_of(caplog) == [
        f"{twins / 'head_cm.obj'}: the mesh is 46 m across, outside 1 cm to 20 m: if the mesh"
        ' is in centimetres, set [mesh].units = "cm" (load_mesh(..., units="cm"))',
        f"{twins / 'long_cm.obj'}: the guides' median length is 30.2 m, outside 1 mm to 2 m:"
        ' if the guides are in centimetres, set [guides].units = "cm" (load_guides(...,'
        ' units="cm"))',
    ]


@pytest.mark.slow
def test_one_file_in_centimetres_gets_one_warning_naming_its_key(twins, caplog):
    """The roots of metre guides lie far inside a centimetre head, and centimetre guides'
    roots far outside a metre head: the size warning says so, the off-mesh one is not
    repeated."""
    with caplog.at_level(logging.WARNING, logger="follicle"):
        groom_scene(twin_scene(twins, "head_cm.obj", "long_m.obj"))
    assert [w.split(": ", 1)[1][:14] for w in warnings_of(caplog)] == ["the mesh is 46"]
    assert '[mesh].units = "cm"' in warnings_of(caplog)[0]
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="follicle"):
        groom_scene(twin_scene(twins, "head_m.obj", "long_cm.obj"))
    (line,) = warnings_of(caplog)
    assert line.startswith(f"{twins / 'long_cm.obj'}: the guides' median length is 30.2 m")
    assert line.endswith('[guides].units = "cm" (load_guides(..., units="cm"))')


# ---------------------------------------------------------------- plausibility


@pytest.mark.parametrize(
    ("scale", "units", "expected"),
    [
        (
            30.0,
            "m",
            "is 42.4 m across, outside 1 cm to 20 m: if the mesh is in centimetres, set"
            ' [mesh].units = "cm" (load_mesh(..., units="cm"))',
        ),
        (
            3000.0,
            "m",
            "is 4.24e+03 m across, outside 1 cm to 20 m: if the mesh is in"
            ' millimetres, set [mesh].units = "mm" (load_mesh(..., units="mm"))',
        ),
        (
            0.25,
            "cm",
            'is 0.00354 m across (read with units = "cm"), outside 1 cm to 20 m: if'
            ' the mesh is in metres, set [mesh].units = "m" (load_mesh(..., units="m"))',
        ),
        # a metre mesh read as millimetres is 1000× too small: "m", not units of 0.1 m
        (
            0.25,
            "mm",
            'is 0.000354 m across (read with units = "mm"), outside 1 cm to 20 m: if'
            ' the mesh is in metres, set [mesh].units = "m" (load_mesh(..., units="m"))',
        ),
        (
            0.25,
            0.0001,
            "is 3.54e-05 m across (read with units = 0.0001), outside 1 cm to 20 m:"
            " if the mesh is in units of 0.1 m, set [mesh].units = 0.1"
            " (load_mesh(..., units=0.1))",
        ),
    ],
)
def test_a_mesh_of_implausible_size_warns_with_the_likely_units(
    tmp_path, caplog, scale, units, expected
):
    p = plane(1)  # the unit square, 1.41 across
    path = save_mesh(p.rest_vertices * scale, p.faces, p.uvs, tmp_path / "square.obj")
    with caplog.at_level(logging.WARNING, logger="follicle"):
        load_mesh(path, units=units)
    assert warnings_of(caplog) == [f"{path}: the mesh {expected}"]


@pytest.mark.parametrize(
    ("scale", "units"), [(1.0, "m"), (1000.0, "mm"), (14.0, "m"), (0.008, "m"), (1.0, "in")]
)
def test_a_mesh_of_plausible_size_does_not_warn(tmp_path, caplog, scale, units):
    p = plane(1)
    path = save_mesh(p.rest_vertices * scale, p.faces, p.uvs, tmp_path / "square.obj")
    with caplog.at_level(logging.WARNING, logger="follicle"):
        load_mesh(path, units=units)
    assert warnings_of(caplog) == []


ROOTS = [[1.0, 0.0, 1.0], [3.0, 0.0, 7.0], [8.0, 0.0, 2.0]]


@pytest.mark.parametrize(
    ("mesh_size", "in_file", "length", "units", "expected"),
    [
        (
            10.0,
            100.0,
            30.0,
            "m",
            "the guides' median length is 30 m, outside 1 mm to 2 m: if the"
            ' guides are in centimetres, set [guides].units = "cm"'
            ' (load_guides(..., units="cm"))',
        ),
        (
            10.0,
            1.0,
            0.3,
            "mm",
            "the guides' median length is 0.0003 m (read with units ="
            ' "mm"), outside 1 mm to 2 m: if the guides are in metres, set'
            ' [guides].units = "m"',
        ),
        # far longer than the mesh: centimetre guides on a small metre mesh
        (
            0.5,
            1.0,
            1.5,
            "m",
            "the guides' median length 1.5 m is 2.12× the mesh's size (0.707 m"
            " across): if the guides are in centimetres, set [guides].units"
            ' = "cm"',
        ),
        # far shorter: metre guides on a centimetre mesh read as metres
        (
            10.0,
            1.0,
            0.005,
            "m",
            "the guides' median length 0.005 m is 0.000354× the mesh's size"
            " (14.1 m across): if the mesh was read as metres but is in"
            ' centimetres, set [mesh].units = "cm" (load_mesh(...,'
            ' units="cm"))',
        ),
    ],
)
def test_guides_of_implausible_size_warn_once_with_the_likely_units(
    tmp_path, caplog, mesh_size, in_file, length, units, expected
):
    """``in_file``: how many file units make a metre of the mesh (100: a centimetre file)."""
    roots = np.array(ROOTS) * mesh_size / 10 * in_file
    path = save(strands(roots, length), tmp_path / "guides.hair")
    with caplog.at_level(logging.WARNING, logger="follicle"):
        load_guides(path, floor(mesh_size), units=units)
    (line,) = warnings_of(caplog)
    assert line.startswith(f"{path}: {expected}")


def test_roots_off_the_mesh_by_100_name_the_units(tmp_path, caplog):
    """Guides of plausible length whose roots lie 100× too far out: 1 cm fur in centimetres
    on a 5 m metre mesh reads as 1 m long, but its roots miss the mesh."""
    roots = np.array(ROOTS) / 2
    path = save(strands(roots * 100, 1.0), tmp_path / "fur.hair")
    with caplog.at_level(logging.WARNING, logger="follicle"):
        load_guides(path, floor(5.0))
    (line,) = warnings_of(caplog)
    assert line.startswith(
        f"{path}: 3 root(s) lie off mesh 'floor' (farthest: guide 2, 406.3"
        " away, 5745.4% of the mesh size)"
    )
    assert line.endswith(
        "they are bound to the closest surface point; scaled by 0.01 they lie"
        ' on it: if the guides are in centimetres, set [guides].units = "cm"'
        ' (load_guides(..., units="cm"))'
    )
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="follicle"):
        guides = load_guides(path, floor(5.0), units="cm")
    assert warnings_of(caplog) == []
    np.testing.assert_allclose(guides.root_positions, roots, atol=1e-6)


def test_roots_off_the_mesh_for_no_units_reason_warn_as_before(caplog):
    shifted = strands(np.array(ROOTS) + [0.0, 2.0, 0.0], 0.5)  # 2 m above the floor
    with caplog.at_level(logging.WARNING, logger="follicle"):
        load_guides(shifted, floor())
    (line,) = warnings_of(caplog)
    assert line == (
        "guides: 3 root(s) lie off mesh 'floor' (farthest: guide 0, 2 away, 14.1% of"
        " the mesh size); they are bound to the closest surface point"
    )


@pytest.mark.slow
def test_no_units_warning_for_the_defaults_and_the_examples(caplog):
    scenes = [Scene()] + [load_scene(p) for p in sorted(EXAMPLES.glob("*.toml"))]
    assert len(scenes) >= 7
    with caplog.at_level(logging.WARNING, logger="follicle"):
        for scene in scenes:
            groom_scene(scene)
    assert warnings_of(caplog) == []


@pytest.mark.slow
def test_follicle_grow_prints_the_warning_without_units_and_nothing_with(twins, tmp_path):
    def grow_cli(units: str) -> subprocess.CompletedProcess:
        scene = tmp_path / "cm.toml"
        scene.write_text(
            f'[mesh]\npath = "{twins / "head_cm.obj"}"\n{units}'
            f'[guides]\npath = "{twins / "long_cm.obj"}"\n{units}'
            "[groom]\ncount = 50\n"
        )
        return subprocess.run(
            [
                sys.executable,
                "-m",
                "follicle.cli",
                "grow",
                str(scene),
                "-o",
                str(tmp_path / "h.npz"),
            ],
            capture_output=True,
            text=True,
        )

    bare = grow_cli("")
    assert bare.returncode == 0, bare.stderr
    lines = bare.stderr.splitlines()
    assert len(lines) == 2
    assert lines[0].startswith(f"follicle: {twins / 'head_cm.obj'}: the mesh is 46 m across")
    assert lines[0].endswith('set [mesh].units = "cm" (load_mesh(..., units="cm"))')
    assert lines[1].endswith('set [guides].units = "cm" (load_guides(..., units="cm"))')
    with_units = grow_cli('units = "cm"\n')
    assert with_units.returncode == 0 and with_units.stderr == ""
    grown = follicle.load_curves(tmp_path / "h.npz")
    assert grown.curve_count == 50 and np.abs(grown.points).max() < 1.0
