"""follicle.validate: one wording for a bad single value, and ResourceError's place."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from follicle import FollicleError, InputError, ResourceError, SimulationError
from follicle.validate import is_whole, number, positive, whole


@pytest.mark.parametrize(
    ("value", "kwargs", "message"),
    [
        (True, {}, r"^x: expected a number \(got True\)$"),
        ("1", {"lo": 0.0, "unit": "s"}, r"^x: expected a number ≥ 0 s \(got '1'\)$"),
        (None, {}, r"^x: expected a number \(got None\)$"),
        (np.array(1.0), {}, r"^x: expected a number"),
        (float("nan"), {}, r"^x: must be finite \(got nan\)$"),
        (float("inf"), {"lo": 0.0}, r"^x: must be finite and ≥ 0 \(got inf\)$"),
        (10**400, {}, r"^x: must be finite \(got 1000.*\.\.\.\)$"),
        (-0.5, {"lo": 0.0, "unit": "s"}, r"^x: must be ≥ 0 s \(got -0.5\)$"),
        (0, {"lo": 0.0, "lo_open": True}, r"^x: must be > 0 \(got 0.0\)$"),
        (2.0, {"hi": 1.0}, r"^x: must be ≤ 1 \(got 2.0\)$"),
        (1.0, {"hi": 1.0, "hi_open": True}, r"^x: must be < 1 \(got 1.0\)$"),
        (1.5, {"lo": 0.0, "hi": 1.0}, r"^x: must be in \[0, 1\] \(got 1.5\)$"),
        (0.0, {"lo": 0.0, "hi": 180.0, "lo_open": True, "hi_open": True}, r"in \(0, 180\)"),
        (1e-7, {"lo": 1e-6}, r"^x: must be ≥ 1e-06 \(got 1e-07\)$"),
        ("x" * 1000, {}, r"^x: expected a number \(got 'x{50,60}\.\.\.\)$"),
    ],
)
def test_number_names_the_value_what_was_expected_and_what_was_got(value, kwargs, message):
    with pytest.raises(InputError, match=message):
        number(value, "x", **kwargs)


def test_number_returns_a_float_and_keeps_inclusive_bounds():
    for value in (0, 1, 0.5, np.float32(0.25), np.int64(1), np.uint8(0)):
        got = number(value, "x", lo=0.0, hi=1.0)
        assert type(got) is float and got == float(value)
    assert positive(0.0, "x", allow_zero=True) == 0.0
    with pytest.raises(InputError, match=r"^x: must be > 0 m \(got 0.0\)$"):
        positive(0.0, "x", unit="m")


@pytest.mark.parametrize(
    ("value", "args", "message"),
    [
        (0, (1, 65536), r"^spp: expected a whole number in 1..65536 \(got 0\)$"),
        (2.5, (1, None), r"^spp: expected a whole number ≥ 1 \(got 2.5\)$"),
        (2.0, (), r"^spp: expected a whole number \(got 2.0\)$"),
        (True, (0, 1), r"^spp: expected a whole number in 0..1 \(got True\)$"),
        (np.bool_(True), (), r"^spp: expected a whole number"),
        (9, (None, 8), r"^spp: expected a whole number ≤ 8 \(got 9\)$"),
    ],
)
def test_whole_refuses_fractions_bools_and_out_of_range(value, args, message):
    with pytest.raises(InputError, match=message):
        whole(value, "spp", *args)


def test_whole_returns_an_int_and_names_its_unit():
    got = whole(np.int64(2**40), "n", 0)
    assert type(got) is int and got == 2**40
    assert whole(2**64 - 1, "seed", 0, 2**64 - 1) == 2**64 - 1
    assert is_whole(np.uint16(3)) and not is_whole(True) and not is_whole(3.0)
    with pytest.raises(InputError, match=r"^shadow_size: expected texels in 16..4096 \(got 8\)$"):
        whole(8, "shadow_size", 16, 4096, what="texels")


def test_allow_none_passes_none_and_says_so_when_refusing():
    assert whole(None, "hair_limit", 0, allow_none=True) is None
    assert number(None, "time", allow_none=True) is None
    assert whole(3, "hair_limit", 0, allow_none=True) == 3
    assert number(0.5, "time", allow_none=True) == 0.5
    with pytest.raises(
        InputError, match=r"^hair_limit: expected a whole number ≥ 0 or None \(got -1\)$"
    ):
        whole(-1, "hair_limit", 0, allow_none=True)
    with pytest.raises(InputError, match=r"^time: expected a number ≥ 0 s or None \(got 'x'\)$"):
        number("x", "time", lo=0.0, unit="s", allow_none=True)
    with pytest.raises(InputError, match=r"^time: must be finite \(got nan\)$"):
        number(float("nan"), "time", allow_none=True)
    with pytest.raises(InputError, match=r"^n: expected a whole number \(got None\)$"):
        whole(None, "n")


def test_resource_error_is_its_own_follicle_error():
    assert issubclass(ResourceError, FollicleError)
    assert not issubclass(ResourceError, (InputError, SimulationError, MemoryError))


@pytest.mark.slow
def test_a_request_too_big_for_memory_is_a_resource_error_and_one_cli_line(monkeypatch, tmp_path):
    from follicle.cli import main
    from follicle.groom import generator

    monkeypatch.setattr(generator, "_available_memory", lambda: 2**20)  # 1 MiB free
    scene = tmp_path / "scene.toml"
    scene.write_text("[groom]\ncount = 1000\n")
    out = tmp_path / "hair.npz"
    result = CliRunner().invoke(main, ["grow", str(scene), "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert result.output.startswith("error:") and result.output.count("\n") == 1
    assert "GiB are free" in result.output and "Groom.chunks()" in result.output
    assert not out.exists()


def _public_calls(tmp_path):
    """Public functions and constructors, each with one argument given wrong: a path that
    is None, a number, bytes or a folder; an array that is text, a dict, ragged lists,
    complex or an object; a settings value out of range."""
    from follicle import (
        Camera,
        Groom,
        HairCurves,
        Light,
        SkinMesh,
        Texture,
        grow,
        load_curves,
        load_guides,
        load_mesh,
        load_scene,
        save,
    )
    from follicle.editing.editor import replay_file
    from follicle.editing.strokes import load_strokes
    from follicle.io.mesh_save import save_mesh
    from follicle.io.sim_cache import load_cache
    from follicle.io.skin_animation import load_skin_animation
    from follicle.render import fit_camera, save_png
    from follicle.scene import ColliderParams, GroomParams, SimParams

    folder = tmp_path / "folder"
    folder.mkdir(exist_ok=True)
    mesh = load_mesh("builtin:head")
    hair = HairCurves.from_array(np.zeros((2, 3, 3), np.float32) + np.arange(3)[None, :, None])
    calls = {
        "load_strokes(folder)": (lambda: load_strokes(folder), "folder"),
        "replay_file(None)": (lambda: replay_file(None), "replay_file path"),
        "GroomParams(count=-1)": (lambda: GroomParams(count=-1), "[groom].count"),
        "SimParams(substep=0)": (lambda: SimParams(substep=0), "[sim].substep"),
        "ColliderParams(kind='box')": (lambda: ColliderParams(kind="box"), "kind"),
        "Guides(vertices='abc')": (lambda: load_guides(hair, mesh, vertices="abc"), "vertices"),
    }
    for bad in (None, 3, b"hair.npz", ["a"]):
        calls |= {
            f"load_curves({bad!r})": (lambda b=bad: load_curves(b), "load_curves path"),
            f"load_mesh({bad!r})": (lambda b=bad: load_mesh(b), "load_mesh path"),
            f"load_guides({bad!r})": (lambda b=bad: load_guides(b, mesh), "load_guides source"),
            f"load_cache({bad!r})": (lambda b=bad: load_cache(b), "load_cache path"),
            f"load_strokes({bad!r})": (lambda b=bad: load_strokes(b), "load_strokes path"),
            f"Texture.load({bad!r})": (lambda b=bad: Texture.load(b), "Texture.load path"),
            f"save(hair, {bad!r})": (lambda b=bad: save(hair, b), "save path"),
            f"save_mesh(mesh, {bad!r})": (lambda b=bad: save_mesh(mesh, b), "save_mesh path"),
            f"save_png({bad!r})": (lambda b=bad: save_png(np.zeros((2, 2, 4)), b), "save_png"),
            f"load_skin_animation({bad!r})": (
                lambda b=bad: load_skin_animation(b, mesh),
                "load_skin_animation path",
            ),
        }
        if bad is not None:
            calls[f"load_scene({bad!r})"] = (lambda b=bad: load_scene(b), "load_scene path")
    for bad in ("abc", {"a": 1}, [[1, 2], [3]], object(), [1, "x", 2], 1j):
        shown = repr(bad)[:12]
        calls |= {
            f"Camera(eye={shown})": (lambda b=bad: Camera(eye=b, target=(0, 0, 0)), "camera eye"),
            f"Camera(up={shown})": (
                lambda b=bad: Camera(eye=(0, 0, 1), target=(0, 0, 0), up=b),
                "camera up",
            ),
            f"Light(direction={shown})": (lambda b=bad: Light(direction=b), "light direction"),
            f"Light.ambient({shown})": (lambda b=bad: Light.ambient(color=b), "light color"),
            f"HairCurves({shown}, offsets)": (lambda b=bad: HairCurves(b, [0, 3]), "points"),
            f"HairCurves(points, {shown})": (
                lambda b=bad: HairCurves(np.zeros((3, 3)), b),
                "offsets",
            ),
            f"HairCurves.from_array({shown})": (lambda b=bad: HairCurves.from_array(b), "array"),
            f"HairCurves.from_polylines([{shown}])": (
                lambda b=bad: HairCurves.from_polylines([b]),
                "polylines[0]",
            ),
            f"SkinMesh({shown}, faces)": (lambda b=bad: SkinMesh(b, [[0, 1, 2]]), "vertices"),
            f"SkinMesh(uvs={shown})": (
                lambda b=bad: SkinMesh(np.eye(3), [[0, 1, 2]], uvs=b),
                "uvs",
            ),
            f"fit_camera({shown})": (lambda b=bad: fit_camera(b), "fit_camera points"),
        }
    calls["Texture(ragged)"] = (lambda: Texture([[1, 2], [3]]), "texture")
    calls["Groom('x', guides)"] = (lambda: Groom("x", load_guides("builtin:short", mesh)), "mesh")
    calls["grow('scene.toml')"] = (lambda: grow("scene.toml"), "scene")
    calls["from_polylines(3)"] = (lambda: HairCurves.from_polylines(3), "polylines")
    return calls


@pytest.mark.slow
def test_public_calls_refuse_a_wrong_argument_with_a_follicle_error_naming_it(tmp_path):
    """Every public call given an argument of the wrong kind raises a FollicleError that
    names the argument, never Python's ValueError, TypeError or IsADirectoryError."""
    crashed = []
    for call, (run, name) in _public_calls(tmp_path).items():
        try:
            run()
        except FollicleError as exc:
            if name not in str(exc):
                crashed.append(f"{call}: {exc} (does not name {name})")
        except Exception as exc:  # noqa: BLE001 - what the test looks for
            crashed.append(f"{call}: {type(exc).__name__}: {exc}")
        else:
            crashed.append(f"{call}: accepted")
    assert not crashed, "\n".join(crashed)
