"""follicle's USD and Alembic in the real client, Blender (``bpy`` 5.0.1 from PyPI), both ways.

Blender runs in its own environment (:mod:`blender_env`: bpy needs Python 3.11 and
numpy < 2), one process per direction, running a script of ``tests/blender_scripts/``
that only measures and writes its findings; the asserting is done here.

Ours into Blender (``import_ours.py``): the built-in groom written as USD and Alembic,
for the generic and the blender targets, with guides and skin, imported with Blender's
default importer settings. Checked: the hair's curve count and every point (after the
importer's axis conversion: a Y-up point (x, y, z) lands at (x, -z, y) in Blender's Z up
world), radius = width / 2, ids as INT, ``surface_uv_coordinate`` for the blender
target, colour, the curve type, the guides as their own object and the skin's
vertices, triangles and UVs. What Blender keeps and drops of the attributes we write is
printed and pinned for this bpy version (:data:`KEPT`).

Hair coloured by melanin (``import_ours.py``, ``melanin_render.py``): a groom grown with
per-hair melanin and redness and a dye, as the blender target's USD and Alembic, comes
into Blender with ``melanin``, ``melanin_redness`` and ``dye`` curve attributes holding
each hair's values (from USD; Alembic's are dropped: :data:`PIGMENTS_KEPT`), and Cycles'
Principled Hair, fed by Attribute nodes of those names, renders a half-blond,
half-black groom so, where one melanin in the shader renders both halves alike.

Blender's hair into follicle (``make_hair.py``): a hair Curves object with a ``color``
attribute, and legacy NURBS, poly and Bézier curves, on a Blender UV sphere, exported by
Blender to USD and Alembic, read by follicle (Z up back to Y up: Blender's (x, y, z) is
our (x, z, -y)) and grown on: counts, points, widths, colours and a sensible groom.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import blender_env
from blender_env import blender_python, run_blender
from follicle.cli import main as follicle_cli
from follicle.curves import HairCurves
from follicle.io.alembic import save_abc
from follicle.io.attributes import DEFAULT_WIDTH
from follicle.io.dispatch import load_curves
from follicle.io.mesh_load import load_mesh
from follicle.io.targets import for_target
from follicle.io.usd import save_usd
from follicle.io.usd_payloads import save_usd_payloads
from follicle.pipeline import groom_scene
from follicle.scene import Scene

pytestmark = pytest.mark.slow  # Blender (bpy) in its own venv, in subprocesses

HAIRS = 300
AXES = "xyz"
_EPS32 = float(np.finfo(np.float32).eps)
# Blender's hair curve types (the curve-domain 'curve_type' attribute; absent: Catmull-Rom)
CATMULL_ROM, POLY = 0, 1

# What Blender 5.0.1's importers make of each attribute we write, measured: ours → its
# attribute ("name DOMAIN TYPE"), or None where it is dropped. The hair and guides of
# each file (the blender target leaves out the normals Blender drops); the skin is
# checked in test_skin_mesh. A new bpy version that keeps or
# drops more fails test_what_blender_keeps here, which is the point: update the table.
_USD_HAIR = {
    "width": "radius POINT FLOAT",
    "color": "displayColor POINT FLOAT_COLOR",
    "opacity": "displayOpacity POINT FLOAT",
    "normal": None,
    "hair_id": "hair_id CURVE INT",
    "strand_id": "strand_id CURVE INT",
    "root_triangle": "root_triangle CURVE INT",
    "root_bary": "root_bary CURVE FLOAT2",
    "strand_uv": "strand_uv CURVE FLOAT2",
}
_USD_GUIDES = {
    "width": "radius POINT FLOAT",
    "guide_id": "guide_id CURVE INT",
    "root_triangle": "root_triangle CURVE INT",
    "root_bary": "root_bary CURVE FLOAT2",
}
_ABC_HAIR = {**dict.fromkeys(_USD_HAIR), "width": "radius POINT FLOAT", "root_uv": None}
_ABC_GUIDES = {**dict.fromkeys(_USD_GUIDES), "width": "radius POINT FLOAT", "root_uv": None}
KEPT = {
    ("generic.usdc", "hair"): {**_USD_HAIR, "root_uv": "root_uv CURVE FLOAT2"},
    ("blender.usdc", "hair"): {
        **{k: v for k, v in _USD_HAIR.items() if k != "normal"},
        "surface_uv_coordinate": "surface_uv_coordinate CURVE FLOAT2",
    },
    ("generic.usdc", "guides"): {**_USD_GUIDES, "root_uv": "root_uv CURVE FLOAT2"},
    ("blender.usdc", "guides"): {
        **_USD_GUIDES,
        "surface_uv_coordinate": "surface_uv_coordinate CURVE FLOAT2",
    },
    ("generic.abc", "hair"): _ABC_HAIR,
    ("blender.abc", "hair"): {
        **{k: v for k, v in _ABC_HAIR.items() if k not in ("root_uv", "normal")},
        "surface_uv_coordinate": None,
    },
    ("generic.abc", "guides"): _ABC_GUIDES,
    ("blender.abc", "guides"): {
        **{k: v for k, v in _ABC_GUIDES.items() if k != "root_uv"},
        "surface_uv_coordinate": None,
    },
}
# our attribute → the name Blender's importers give it where not its own
_BLENDER_NAMES = {"width": ("radius",), "color": ("displayColor",), "opacity": ("displayOpacity",)}
FILES = ("generic.usdc", "blender.usdc", "generic.abc", "blender.abc")


def _target(name: str) -> str:
    return name.split(".")[0]


def _to_blender(p: np.ndarray) -> np.ndarray:
    """Y-up points (x, y, z) where Blender's Z-up world puts them: (x, -z, y)."""
    p = np.asarray(p, dtype=np.float64)
    return np.stack([p[:, 0], -p[:, 2], p[:, 1]], axis=1)


def _from_blender(p: np.ndarray) -> np.ndarray:
    """Blender's Z-up world points (x, y, z) in follicle's Y up: (x, z, -y)."""
    p = np.asarray(p, dtype=np.float64)
    return np.stack([p[:, 0], p[:, 2], -p[:, 1]], axis=1)


def _assert_points(got: np.ndarray, want: np.ndarray, what: str, hint: str) -> None:
    """Every point of ``got`` equals ``want`` within float32 rounding (16 ulp of a metre:
    2 µm, where a wrong axis is off by centimetres); else say how many points differ,
    on which axes, and the worst one."""
    got, want = np.asarray(got, np.float64), np.asarray(want, np.float64)
    assert got.shape == want.shape, f"{what}: {got.shape} values, expected {want.shape}"
    err = np.abs(got - want)
    tol = 16 * _EPS32 * max(float(np.abs(want).max()), 1.0)
    if err.max() > tol:
        i, axis = np.unravel_index(int(err.argmax()), err.shape)
        bad = (err > tol).any(axis=0)
        raise AssertionError(
            f"{what}: {int((err > tol).any(axis=1).sum())} of {len(got)} points differ, on"
            f" axes {', '.join(a for a, b in zip(AXES, bad, strict=True) if b)}; worst point"
            f" {i}: {AXES[axis]} is {got[i, axis]:.7g}, expected {want[i, axis]:.7g}"
            f" (got {got[i].round(6).tolist()}, expected {want[i].round(6).tolist()}). {hint}"
        )


def _distance_to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Each point's distance to the polyline through ``line``'s vertices."""
    a, b = line[:-1][None], line[1:][None]
    ab = b - a
    t = np.clip(
        np.einsum("psk,psk->ps", points[:, None] - a, ab)
        / np.maximum(np.einsum("psk,psk->ps", ab, ab), 1e-300),
        0.0,
        1.0,
    )
    closest = a + t[..., None] * ab
    return np.linalg.norm(points[:, None] - closest, axis=2).min(axis=1)


# ------------------------------------------------------------------ the environment
def test_no_wheel_skips_here_and_fails_under_ci(monkeypatch):
    """Without a Python bpy has wheels for, the tests skip with the reason, except under
    CI, where they fail: a missing client must never pass silently."""
    monkeypatch.delenv("FOLLICLE_BLENDER_PYTHON", raising=False)
    monkeypatch.delenv(blender_env.SKIP, raising=False)
    monkeypatch.setattr(blender_env, "BPY_PYTHON", (2, 7))
    monkeypatch.setattr(blender_env.shutil, "which", lambda name: None)
    monkeypatch.delenv("CI", raising=False)
    with pytest.raises(pytest.skip.Exception, match="wheels for Python 2.7 only"):
        blender_env.blender_python()
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="cannot run under CI"):
        blender_env.blender_python()


def test_the_opt_out_skips_saying_how_to_run_them_and_ci_never_uses_it(tmp_path, monkeypatch):
    """FOLLICLE_SKIP_BLENDER=1 skips with how to run the tests and makes nothing (not
    even with a Python for bpy at hand); under CI it fails, and .ci/run, CI's script, does
    not set it (nor does the README's test command it runs)."""
    for name, value in (("VENV", tmp_path / "v"), ("LOCK", tmp_path / "lock")):
        monkeypatch.setattr(blender_env, name, value)
    monkeypatch.setattr(blender_env, "BPY_PYTHON", sys.version_info[:2])  # one is at hand
    monkeypatch.setattr(blender_env, "_run", lambda cmd, what: pytest.fail(f"made: {what}"))
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.setenv("FOLLICLE_BLENDER_PYTHON", "/a/python/with/bpy")  # the opt-out wins
    monkeypatch.setenv(blender_env.SKIP, "1")
    with pytest.raises(pytest.skip.Exception) as skip:
        blender_env.blender_python()
    assert "unset FOLLICLE_SKIP_BLENDER and run .venv/bin/python -m pytest" in str(skip.value)
    assert not (tmp_path / "v").exists() and not (tmp_path / "lock").exists()
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="cannot run under CI: FOLLICLE_SKIP"):
        blender_env.blender_python()
    ci = (Path(blender_env.ROOT) / ".ci" / "run").read_text(encoding="utf-8")
    assert "python -m pytest -q" in ci and "FOLLICLE_SKIP_BLENDER" not in ci
    assert "FOLLICLE_SKIP_BLENDER" in (Path(blender_env.ROOT) / "README.md").read_text()


def test_a_half_made_env_is_made_again_then_reused(tmp_path, monkeypatch):
    """An env without its ready marker (an install killed part way) is deleted and made
    again; a ready one is reused as it is."""
    venv = tmp_path / ".venv-blender"
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "python").touch()
    (venv / "half-installed").touch()
    for name, value in (
        ("VENV", venv),
        ("READY", venv / "ready.txt"),
        ("LOCK", tmp_path / "lock"),
        ("BPY_PYTHON", sys.version_info[:2]),
    ):
        monkeypatch.setattr(blender_env, name, value)
    monkeypatch.delenv("FOLLICLE_BLENDER_PYTHON", raising=False)
    monkeypatch.delenv(blender_env.SKIP, raising=False)
    made = []

    def run(cmd, what):  # instead of venv and pip: record, and make the interpreter
        made.append(cmd[1:4])
        (venv / "bin").mkdir(parents=True, exist_ok=True)
        (venv / "bin" / "python").touch()

    monkeypatch.setattr(blender_env, "_run", run)
    assert blender_env.blender_python() == venv / "bin" / "python"
    assert not (venv / "half-installed").exists()
    assert made == [["-m", "venv", str(venv)], ["-m", "pip", "install"]]
    assert (venv / "ready.txt").read_text().strip() == blender_env.BPY_VERSION
    made.clear()
    assert blender_env.blender_python() == venv / "bin" / "python"
    assert made == [], "a ready env was made again"


# ------------------------------------------------------------------ fixtures
@pytest.fixture(scope="session")
def blender():
    """The Python of .venv-blender, with bpy (made once; see blender_env)."""
    return blender_python()


@pytest.fixture(scope="module")
def groom():
    return groom_scene(Scene())


@pytest.fixture(scope="module")
def hair(groom):
    return groom.generate(count=HAIRS)


@pytest.fixture(scope="module")
def ours(tmp_path_factory, blender, groom, hair):
    """Our groom (hair, guides, skin) as generic.usdc, blender.usdc, generic.abc and
    blender.abc, all imported by one Blender process: (findings, arrays)."""
    folder = tmp_path_factory.mktemp("ours")
    for name in FILES:
        save = save_usd if name.endswith(".usdc") else save_abc
        save(hair, folder / name, guides=groom.guides, mesh=groom.mesh, target=_target(name))
    report = run_blender(
        blender, "import_ours.py", *(folder / n for n in FILES), folder / "findings.json"
    )
    return report, dict(np.load(report["arrays"]))


def _object(ours, name: str, names: tuple[str, ...]) -> dict:
    """The imported object of file ``name`` named one of ``names``: each shape comes in
    as an object named after its prim (USD) or its Xform (Alembic)."""
    report = ours[0]["files"][name]
    assert report["result"] == ["FINISHED"], f"{name}: Blender's import said {report['result']}"
    found = [o for o in report["objects"] if o["name"] in names]
    made = [(o["name"], o["type"], o["data"]) for o in report["objects"]]
    assert len(found) == 1, f"{name}: expected one object named {names}, Blender made {made}"
    return found[0]


def _hair_object(ours, name: str) -> dict:
    return _object(ours, name, ("chunk_0000", "Hair_0000"))


@pytest.mark.parametrize("name", [n for n in FILES if n.endswith(".abc")])
def test_alembic_objects_are_named_for_what_they_hold(ours, name):
    """Each shape under its own Xform: Blender names the objects Hair_0000, Guides and
    Skin under the empty Groom (shapes sharing /Groom came in as Groom, Groom.001, …)."""
    made = {o["name"]: (o["type"], o["parent"]) for o in ours[0]["files"][name]["objects"]}
    assert made == {
        "Groom": ("EMPTY", None),
        "Hair_0000": ("CURVES", "Groom"),
        "Guides": ("CURVES", "Groom"),
        "Skin": ("MESH", "Groom"),
    }, made


def _written(curves, name: str, role: str):
    """What the writer put in ``name`` for ``role``: the target's names and types."""
    return for_target(curves, _target(name), role, in_units=False)


# ------------------------------------------------------------------ ours into Blender
@pytest.mark.parametrize("name", FILES)
def test_hair_curves_and_points(ours, hair, name):
    obj = _hair_object(ours, name)
    arrays = ours[1]
    assert obj["type"] == "CURVES", f"{name}: the hair came in as {obj['type']}, not hair curves"
    assert (obj["curves"], obj["points"]) == (hair.curve_count, hair.point_count), (
        f"{name}: Blender has {obj['curves']} curves / {obj['points']} points"
    )
    np.testing.assert_array_equal(
        arrays[f"{obj['key']}/offsets"], hair.offsets, err_msg=f"{name}: curve sizes differ"
    )
    _assert_points(
        arrays[f"{obj['key']}/position"],
        _to_blender(hair.points),
        f"{name}: hair points in Blender's world",
        "A Y-up (x, y, z) should land at (x, -z, y).",
    )


@pytest.mark.parametrize("name", FILES)
def test_radius_is_half_the_width(ours, hair, name):
    obj = _hair_object(ours, name)
    radius = ours[1].get(f"{obj['key']}/radius")
    assert radius is not None, f"{name}: Blender made no radius of our widths"
    np.testing.assert_allclose(
        radius,
        0.5 * hair.point_data["width"],
        rtol=1e-6,
        err_msg=f"{name}: Blender's radius is not width / 2",
    )


@pytest.mark.parametrize("name", FILES)
def test_curve_type(ours, name):
    """USD's pinned Catmull-Rom comes in as Blender's Catmull-Rom, Alembic's linear curves
    as poly curves: either way through every point we wrote."""
    obj = _hair_object(ours, name)
    types = ours[1].get(f"{obj['key']}/curve_type")
    want = CATMULL_ROM if name.endswith(".usdc") else POLY
    got = np.zeros(1, int) if types is None else np.unique(types)  # absent: Catmull-Rom
    assert got.tolist() == [want], f"{name}: Blender's curve types {got.tolist()}, want {want}"


@pytest.mark.parametrize("name", ["generic.usdc", "blender.usdc"])
def test_ids_and_uvs_kept_as_blender_types(ours, hair, name):
    obj = _hair_object(ours, name)
    arrays, attrs = ours[1], {a["name"]: a for a in obj["attributes"]}
    for key in ("hair_id", "strand_id", "root_triangle"):
        assert key in attrs, f"{name}: Blender dropped '{key}' (it drops 64-bit integers)"
        assert (attrs[key]["domain"], attrs[key]["type"]) == ("CURVE", "INT"), (
            f"{name}: '{key}' is {attrs[key]}, not a per-curve INT"
        )
        np.testing.assert_array_equal(
            arrays[f"{obj['key']}/{key}"], hair.curve_data[key], err_msg=f"{name}: '{key}' values"
        )
    uv = "surface_uv_coordinate" if _target(name) == "blender" else "root_uv"
    other = "root_uv" if uv != "root_uv" else "surface_uv_coordinate"
    assert uv in attrs and other not in attrs, (
        f"{name}: expected the root UVs as '{uv}' only, Blender has {sorted(attrs)}"
    )
    assert (attrs[uv]["domain"], attrs[uv]["type"]) == ("CURVE", "FLOAT2")
    np.testing.assert_array_equal(
        arrays[f"{obj['key']}/{uv}"], hair.curve_data["root_uv"], err_msg=f"{name}: '{uv}' values"
    )


@pytest.mark.parametrize("name", ["generic.usdc", "blender.usdc"])
def test_colour_and_opacity(ours, hair, name):
    obj = _hair_object(ours, name)
    arrays = ours[1]
    colour = arrays.get(f"{obj['key']}/displayColor")
    assert colour is not None, f"{name}: Blender dropped the hair colour (displayColor)"
    np.testing.assert_allclose(
        colour[:, :3], hair.point_data["color"], atol=1e-6, err_msg=f"{name}: colour RGB"
    )
    np.testing.assert_allclose(
        arrays[f"{obj['key']}/displayOpacity"],
        hair.point_data["opacity"],
        atol=1e-6,
        err_msg=f"{name}: opacity",
    )


@pytest.mark.parametrize("name", FILES)
def test_guides_are_their_own_object(ours, groom, name):
    obj = _object(ours, name, ("Guides",))
    hair_obj = _hair_object(ours, name)
    guides = groom.guides.curves
    assert obj["type"] == "CURVES" and obj["name"] != hair_obj["name"]
    assert obj["curves"] == guides.curve_count, (
        f"{name}: {obj['curves']} guides in Blender, {guides.curve_count} written"
    )
    _assert_points(
        ours[1][f"{obj['key']}/position"],
        _to_blender(guides.points),
        f"{name}: guide points in Blender's world",
        "A Y-up (x, y, z) should land at (x, -z, y).",
    )
    radius = ours[1].get(f"{obj['key']}/radius")
    assert radius is not None, (
        f"{name}: the guides have no radius in Blender (its default"
        " is a centimetre): write them widths"
    )
    np.testing.assert_allclose(
        radius, DEFAULT_WIDTH / 2, rtol=1e-6, err_msg=f"{name}: guide radius"
    )


@pytest.mark.parametrize("name", FILES)
def test_skin_mesh(ours, groom, name):
    obj = _object(ours, name, ("Skin",))
    mesh, arrays, key = groom.mesh, ours[1], obj["key"]
    assert obj["type"] == "MESH"
    assert (obj["vertices"], obj["faces"]) == (len(mesh.rest_vertices), mesh.face_count), (
        f"{name}: the skin has {obj['vertices']} vertices / {obj['faces']} faces in Blender"
    )
    assert (arrays[f"{key}/face_sizes"] == 3).all(), f"{name}: the skin's faces are not triangles"
    np.testing.assert_array_equal(
        arrays[f"{key}/corner_vertex"],
        mesh.faces.ravel(),
        err_msg=f"{name}: triangle corners (winding) differ",
    )
    _assert_points(
        arrays[f"{key}/position"],
        _to_blender(mesh.rest_vertices),
        f"{name}: skin vertices in Blender's world",
        "Same axes as the hair.",
    )
    assert len(obj["uv_maps"]) == 1, f"{name}: UV maps {obj['uv_maps']}, expected one"
    uv = arrays[f"{key}/uv:{obj['uv_maps'][0]}"]
    np.testing.assert_allclose(
        uv,
        mesh.uvs[mesh.faces.ravel()],
        atol=1e-6,
        err_msg=f"{name}: the skin's UVs at its corners",
    )


def _measured(obj: dict, written) -> dict[str, str | None]:
    """Ours → Blender's "name DOMAIN TYPE" (None: dropped) for one imported object."""
    attrs = {a["name"]: f"{a['name']} {a['domain']} {a['type']}" for a in obj["attributes"]}
    out = {}
    for ours in sorted({**written.point_data, **written.curve_data}):
        names = (ours, *_BLENDER_NAMES.get(ours, ()))
        out[ours] = next((attrs[n] for n in names if n in attrs), None)
    return out


@pytest.mark.parametrize("name", FILES)
def test_what_blender_keeps(ours, groom, hair, name, capsys):
    """Measure what Blender keeps and drops of each attribute we write (printed), and
    pin it: see :data:`KEPT`."""
    found = {}
    for role, obj, curves in (
        ("hair", _hair_object(ours, name), hair),
        ("guides", _object(ours, name, ("Guides",)), groom.guides.curves),
    ):
        found[role] = _measured(obj, _written(curves, name, role))
        with capsys.disabled():
            kept = ", ".join(f"{k}→{v}" for k, v in found[role].items() if v)
            dropped = ", ".join(k for k, v in found[role].items() if not v) or "nothing"
            print(f"\n[Blender {ours[0]['blender']}] {name} {role}: kept {kept}; dropped {dropped}")
    for role in found:
        want = KEPT[(name, role)]
        diff = {
            k: (found[role].get(k), want.get(k))
            for k in {*found[role], *want}
            if found[role].get(k, "absent") != want.get(k, "absent")
        }
        assert not diff, f"{name} {role}: Blender made (measured, expected) {diff}"


# ------------------------------------------------------------------ the payloads layout
@pytest.fixture(scope="module")
def payloads(tmp_path_factory, blender, groom, hair):
    """Our groom as a root layer over three part files (follicle grow --layout
    payloads), imported by Blender: (findings, arrays, the parts)."""
    folder = tmp_path_factory.mktemp("payloads")
    parts = [hair[a : a + 100] for a in range(0, HAIRS, 100)]
    root = save_usd_payloads(
        parts, folder / "blender.usdc", guides=groom.guides, mesh=groom.mesh, target="blender"
    )
    report = run_blender(blender, "import_ours.py", root, folder / "findings.json")
    return report, dict(np.load(report["arrays"])), parts


def test_blender_opens_the_payloads_layout_as_the_groom(payloads):
    """File → Import of the root layer: Blender loads every payload, one hair object per
    part, with its curves and points where the one-file layout puts them, and the
    guides and the skin beside them."""
    report, arrays, parts = payloads
    made = report["files"]["blender.usdc"]
    assert made["result"] == ["FINISHED"], made["result"]
    objects = {o["name"]: o for o in made["objects"]}
    assert {"Guides", "Skin"} <= set(objects), sorted(objects)
    assert objects["Skin"]["type"] == "MESH"
    for i, part in enumerate(parts):
        obj = objects.get(f"part_{i:04d}")
        assert obj is not None, f"part {i}: no object; Blender made {sorted(objects)}"
        assert obj["type"] == "CURVES"
        assert (obj["curves"], obj["points"]) == (part.curve_count, part.point_count)
        _assert_points(
            arrays[f"{obj['key']}/position"],
            _to_blender(part.points),
            f"part {i}: hair points in Blender's world",
            "A Y-up (x, y, z) should land at (x, -z, y).",
        )


# ------------------------------------------------------------------ hair coloured by melanin
# A groom grown from melanin, each hair's own (random_melanin, random_redness) and dyed
PIGMENT_KEYS = {
    "melanin": 0.5,
    "melanin_redness": 0.4,
    "random_melanin": 0.8,
    "random_redness": 0.5,
    "dye": (1.0, 0.75, 0.55),
}
PIGMENT_FILES = ("blender.usdc", "blender.usda", "blender.abc")
# What Blender 5.0.1's importers make of the pigments (measured: "name DOMAIN TYPE",
# None: dropped). USD's uniform float primvars become FLOAT curve attributes and the
# float3 dye a FLOAT_VECTOR one, which the shader's Attribute node reads by name; its
# Alembic importer reads no attribute of curves but their widths.
_USD_PIGMENTS = {
    "melanin": "melanin CURVE FLOAT",
    "melanin_redness": "melanin_redness CURVE FLOAT",
    "dye": "dye CURVE FLOAT_VECTOR",
}
PIGMENTS_KEPT = {
    "blender.usdc": _USD_PIGMENTS,
    "blender.usda": _USD_PIGMENTS,
    "blender.abc": dict.fromkeys(_USD_PIGMENTS),
}
BLOND, BLACK = 0.15, 0.9  # the two halves' melanin in the rendered groom
RENDER_HAIRS = 1500


@pytest.fixture(scope="module")
def pigmented_groom():
    scene = Scene()
    return groom_scene(scene.replace(groom=scene.groom.replace(**PIGMENT_KEYS)))


@pytest.fixture(scope="module")
def pigmented(tmp_path_factory, blender, pigmented_groom):
    """The melanin groom as the blender target's USD (crate and text) and Alembic, with
    its guides, imported by Blender: (findings, arrays, the hair written)."""
    folder = tmp_path_factory.mktemp("pigmented")
    hair = pigmented_groom.generate(count=HAIRS)
    for name in PIGMENT_FILES:
        save = save_abc if name.endswith(".abc") else save_usd
        save(hair, folder / name, guides=pigmented_groom.guides, target="blender")
    report = run_blender(
        blender, "import_ours.py", *(folder / n for n in PIGMENT_FILES), folder / "findings.json"
    )
    return report, dict(np.load(report["arrays"])), hair


@pytest.mark.parametrize("name", PIGMENT_FILES)
def test_blender_reads_each_hairs_pigments(pigmented, name):
    """Blender makes a melanin groom's ``melanin``, ``melanin_redness`` (FLOAT) and
    ``dye`` (FLOAT_VECTOR) curve attributes of the blender target's USD, under our names,
    with every hair's own values (they differ hair to hair); its Alembic importer drops
    them (pinned: :data:`PIGMENTS_KEPT`)."""
    report, arrays, hair = pigmented
    obj = _object((report, arrays), name, ("chunk_0000", "Hair_0000"))
    found = _measured(
        obj,
        HairCurves(hair.points, hair.offsets, {}, {k: hair.curve_data[k] for k in _USD_PIGMENTS}),
    )
    print(f"\n[Blender {report['blender']}] {name} pigments: {found}")
    assert found == PIGMENTS_KEPT[name], f"{name}: Blender made {found}"
    if name.endswith(".abc"):
        return
    assert np.ptp(hair.curve_data["melanin"]) > 0.5, "the hairs' melanin should differ"
    for key in _USD_PIGMENTS:
        np.testing.assert_array_equal(
            arrays[f"{obj['key']}/{key}"],
            hair.curve_data[key],
            err_msg=f"{name}: Blender's '{key}' of each hair",
        )


@pytest.fixture(scope="module")
def halves(tmp_path_factory, blender, pigmented_groom):
    """The melanin groom with the hairs left of its centre (mean X) blond and the rest
    black, all else alike (redness 0.3, no dye, one grey ``color``), as the blender
    target's USD with its guides (which have no pigments), rendered by Blender with
    Cycles (``melanin_render.py``): per hair by Attribute nodes, then with one melanin
    in the shader. (findings, the hair)."""
    folder = tmp_path_factory.mktemp("halves")
    hair = pigmented_groom.generate(count=RENDER_HAIRS)
    x = np.add.reduceat(hair.points[:, 0].astype(np.float64), hair.offsets[:-1]) / hair.counts
    mid = 0.5 * (float(hair.points[:, 0].min()) + float(hair.points[:, 0].max()))
    curve_data = {
        **hair.curve_data,
        "melanin": np.where(x < mid, BLOND, BLACK).astype(np.float32),
        "melanin_redness": np.full(hair.curve_count, 0.3, np.float32),
        "dye": np.ones((hair.curve_count, 3), np.float32),
    }
    point_data = {**hair.point_data, "color": np.full((hair.point_count, 3), 0.2, np.float32)}
    two = HairCurves(hair.points, hair.offsets, point_data, curve_data)
    save_usd(two, folder / "halves.usdc", guides=pigmented_groom.guides, target="blender")
    report = run_blender(
        blender, "melanin_render.py", folder / "halves.usdc", folder / "halves.json"
    )
    return report, two


def _half_brightness(png: str) -> tuple[float, float, int, int]:
    """Mean brightness (0-1, of the PNG's RGB) of the hair pixels (alpha > 1/2) in the
    left and right 40 % of the image, and how many there are."""
    rgba = np.asarray(Image.open(png).convert("RGBA"), np.float64) / 255.0
    hair = rgba[..., 3] > 0.5
    width = rgba.shape[1]
    cols = np.arange(width)[None, :]
    left, right = hair & (cols < 0.4 * width), hair & (cols >= 0.6 * width)
    value = rgba[..., :3].mean(axis=2)
    return float(value[left].mean()), float(value[right].mean()), int(left.sum()), int(right.sum())


def test_principled_hair_reads_each_hairs_melanin(halves, capsys):
    """Blender's Principled Hair BSDF (Melanin concentration), its Melanin, Melanin
    Redness and Tint fed by Attribute nodes ``melanin``, ``melanin_redness`` and ``dye``,
    renders the blond half of the groom (melanin 0.15, image left: the camera looks
    along +Y) much lighter than the black half (0.9); the same file with one melanin
    in the shader renders both halves alike, so the difference is the attributes'."""
    report, _ = halves
    assert report["pigments"], "Blender made no melanin attributes of the groom"
    got = {mode: _half_brightness(r["png"]) for mode, r in report["renders"].items()}
    with capsys.disabled():
        for mode, (lo, hi, n_lo, n_hi) in got.items():
            print(
                f"\n[Blender {report['blender']}] {mode}: blond half {lo:.3f} ({n_lo} px),"
                f" black half {hi:.3f} ({n_hi} px), ratio {lo / max(hi, 1e-9):.2f}"
            )
    for *_, n_lo, n_hi in got.values():
        assert min(n_lo, n_hi) > 200, f"too few hair pixels to compare: {n_lo}, {n_hi}"
    blond, black = got["attributes"][:2]
    assert blond > 2.0 * black, f"by attributes: blond {blond:.3f} is not ≫ black {black:.3f}"
    left, right = got["constant"][:2]
    assert 0.8 < left / right < 1.25, f"one melanin: halves {left:.3f} and {right:.3f} differ"


# ------------------------------------------------------------------ Blender's hair into ours
@pytest.fixture(scope="module")
def made(tmp_path_factory, blender):
    """Hair, curves and a head made in Blender and exported by it: (findings, arrays)."""
    folder = tmp_path_factory.mktemp("made")
    report = run_blender(blender, "make_hair.py", folder, folder / "findings.json")
    for obj, files in report["files"].items():
        for fmt, (path, result) in files.items():
            assert result == ["FINISHED"], f"Blender's {fmt} export of {obj} said {result}"
            assert Path(path).stat().st_size > 0, f"Blender's {fmt} export of {obj}: no file"
    return report, dict(np.load(report["arrays"]))


def _made_file(made, obj: str, fmt: str) -> str:
    return made[0]["files"][obj][fmt][0]


# What Blender 5.0.1's exporters write of the Curves object's attributes, as follicle
# reads them (measured): USD writes 'color' as a color4f primvar, Alembic not at all.
MADE_POINT_DATA = {"usd": ["color", "opacity", "width"], "abc": ["width"]}


@pytest.mark.parametrize("fmt", ["usd", "abc"])
def test_blender_hair_curves_load(made, fmt):
    report, truth = made
    curves = load_curves(_made_file(made, "Hair", fmt))
    assert curves.curve_count == report["objects"]["Hair"]["curves"]
    np.testing.assert_array_equal(
        curves.offsets, truth["Hair/offsets"], err_msg=f"{fmt}: curve sizes differ"
    )
    _assert_points(
        curves.points,
        _from_blender(truth["Hair/position"]),
        f"{fmt}: Blender's hair points in follicle",
        "Blender's Z-up (x, y, z) with its object transform should read as (x, z, -y).",
    )
    np.testing.assert_allclose(
        curves.point_data["width"],
        2 * truth["Hair/radius"],
        rtol=1e-6,
        err_msg=f"{fmt}: width is not 2 × Blender's radius",
    )
    assert sorted(curves.point_data) == MADE_POINT_DATA[fmt], (
        f"{fmt}: follicle read {sorted(curves.point_data)} of Blender's hair"
    )
    if "color" in curves.point_data:
        rgba = truth["Hair/color"]
        np.testing.assert_allclose(
            curves.point_data["color"],
            rgba[:, :3],
            atol=1e-6,
            err_msg=f"{fmt}: RGB of Blender's 4-channel colour",
        )
        np.testing.assert_allclose(
            curves.point_data["opacity"],
            rgba[:, 3],
            atol=1e-6,
            err_msg=f"{fmt}: opacity from the colour's alpha",
        )


@pytest.mark.parametrize("fmt", ["usd", "abc"])
@pytest.mark.parametrize("kind", ["Nurbs", "Poly", "Bezier"])
def test_blender_legacy_curves_load(made, fmt, kind):
    """Poly splines read as their points, Bézier ones as their knots (not the handles),
    NURBS (rational, endpoint knots) as points on the curve Blender draws, ends included."""
    truth = made[1]
    curves = load_curves(_made_file(made, kind, fmt))
    cvs = _from_blender(truth[f"{kind}/control_points"])
    drawn = _from_blender(truth[f"{kind}/evaluated"])
    assert curves.curve_count == 1, f"{fmt} {kind}: {curves.curve_count} curves, expected 1"
    if kind == "Nurbs":
        assert curves.point_count >= len(cvs)
        off = _distance_to_polyline(curves.points.astype(np.float64), drawn)
        assert off.max() < 1e-5, (
            f"{fmt} {kind}: point {int(off.argmax())} is {off.max():.3g} m off Blender's curve"
        )
        _assert_points(
            curves.points[[0, -1]],
            drawn[[0, -1]],
            f"{fmt} {kind}: curve ends",
            "Endpoint knots: the curve starts and ends at its end CVs.",
        )
    else:
        _assert_points(
            curves.points,
            cvs,
            f"{fmt} {kind}: curve points",
            "Poly: the points; Bézier: the knots, not their handles.",
        )
    np.testing.assert_allclose(
        curves.point_data["width"],
        2e-4,
        rtol=1e-6,
        err_msg=f"{fmt} {kind}: width is not 2 × radius 1e-4",
    )


@pytest.mark.parametrize("fmt", ["usd", "abc"])
def test_blender_head_mesh_loads(made, fmt):
    """The sphere as follicle reads it: Blender's vertices (split at UV seams), its quads
    as two triangles each, and the same surface area."""
    report, truth = made
    mesh = load_mesh(_made_file(made, "Head", fmt))
    head = report["objects"]["Head"]
    quads = head["faces"] - 2 * 24  # a UV sphere: triangle fans at its two poles
    assert mesh.face_count == 2 * quads + 2 * 24, f"{fmt}: {mesh.face_count} triangles"
    assert mesh.uvs is not None, f"{fmt}: the sphere's UV map was not read"
    blender_vertices = _from_blender(truth["Head/position"])
    gap = np.linalg.norm(mesh.rest_vertices[:, None] - blender_vertices[None], axis=2).min(1)
    assert gap.max() < 1e-6, f"{fmt}: vertex {int(gap.argmax())} is not one of Blender's"
    assert len(np.unique(mesh.rest_vertices.round(7), axis=0)) == head["vertices"]
    np.testing.assert_allclose(
        mesh.face_areas().sum(), head["area"], rtol=1e-6, err_msg=f"{fmt}: surface area"
    )
    # each (vertex, UV) follicle has is one of Blender's corners: the seams split right
    corners = np.hstack([_from_blender(truth["Head/corner_position"]), truth["Head/corner_uv"]])
    ours = np.hstack([mesh.rest_vertices, mesh.uvs])
    miss = np.abs(ours[:, None] - corners[None]).max(axis=2).min(axis=1)
    assert miss.max() < 1e-6, (
        f"{fmt}: vertex {int(miss.argmax())} (position, UV) {ours[miss.argmax()].round(5)} is"
        " no corner of Blender's sphere"
    )


@pytest.mark.parametrize("fmt", ["usd", "abc"])
def test_grows_on_blender_hair(made, fmt, tmp_path):
    """`follicle grow` with Blender's head as [mesh] and Blender's hair as [guides]."""
    ext = {"usd": "usda", "abc": "abc"}[fmt]
    head, hair_file = _made_file(made, "Head", fmt), _made_file(made, "Hair", fmt)
    scene = tmp_path / "scene.toml"
    scene.write_text(
        f"[mesh]\npath = {json.dumps(head)}\n\n[guides]\npath ="
        f" {json.dumps(hair_file)}\n\n[groom]\ncount = 500\nseed = 3\n"
    )
    out = tmp_path / "grown.npz"
    result = CliRunner().invoke(follicle_cli, ["grow", str(scene), "-o", str(out)])
    assert result.exit_code == 0, f"follicle grow on Blender's {ext} files: {result.output}"
    grown = load_curves(out)
    guides = load_curves(hair_file)
    mesh = load_mesh(head)
    assert grown.curve_count == 500
    assert np.isfinite(grown.points).all()
    roots = grown.points[grown.offsets[:-1]]
    _, _, dist = mesh.closest_points(roots)
    assert dist.max() < 1e-6, f"{fmt}: a root is {dist.max():.3g} m off Blender's head"

    def lengths(c):
        seg = np.linalg.norm(np.diff(c.points.astype(np.float64), axis=0), axis=1)
        inside = np.ones(len(seg), bool)
        inside[c.offsets[1:-1] - 1] = False  # the steps between curves
        return np.add.reduceat(np.where(inside, seg, 0.0), c.offsets[:-1])

    g, h = lengths(guides), lengths(grown)
    assert g.min() * 0.5 < np.median(h) < g.max() * 1.5, (
        f"{fmt}: median hair length {np.median(h):.3g} m, guides {g.min():.3g}–{g.max():.3g}"
    )

    def fall(c):  # tip − root in Y: negative where a curve hangs down
        return c.points[c.offsets[1:] - 1, 1] - c.points[c.offsets[:-1], 1]

    hang, guide_hang = float(np.median(fall(grown))), float(np.median(fall(guides)))
    assert guide_hang < 0 and hang < 0.5 * guide_hang, (
        f"{fmt}: the median hair ends {hang:.3g} m below its root in Y, the guides"
        f" {guide_hang:.3g} m: Blender's guides fall (−Z), so our hair should hang (−Y)"
    )
