"""Stroke logs (follicle.editing.strokes) and ``follicle groom``: a hand-made groom
replayed headless gives the same bytes, opens in usd-core, and a hostile log is one
line and exit 2 — never a crash, a hang or a silent acceptance."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pxr import Usd, UsdGeom

import follicle
from follicle.editing.strokes import load_strokes
from follicle.errors import FormatError, InputError
from hostile import assert_cli_refused, run_api, run_cli, warm

SIZE = (480, 360)


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A short groom by hand (comb, cut, an undo and a redo, add, length), its log and
    the guides it made."""
    folder = tmp_path_factory.mktemp("strokes")
    head = follicle.load_mesh("builtin:head")
    ed = follicle.GuideEditor(follicle.load_guides("builtin:short", head))
    lo, hi = head.bounds("rest")
    centre = (lo + hi) / 2
    cam = follicle.Camera(eye=centre + np.array([0.0, 0.15, 0.7]), target=centre)
    assert len(ed.stroke("comb", [[180, 80], [300, 90]], cam, radius=60, strength=0.8, size=SIZE))
    assert len(ed.stroke("cut", [[150, 120], [330, 120]], cam, radius=5, size=SIZE))
    assert ed.undo() and ed.redo()
    assert len(ed.stroke("add", [[220, 70], [260, 70]], cam, radius=20, size=SIZE))
    ed.stroke("length", [[200, 100], [280, 100]], cam, radius=50, strength=-0.3, size=SIZE)
    log = ed.save_strokes(folder / "groom.json", mesh="builtin:head", guides="builtin:short")
    ed.save(folder / "direct.npz")
    return folder, log, ed


@pytest.mark.slow
def test_a_replayed_log_gives_the_same_guides(made):
    folder, log, ed = made
    doc = load_strokes(log)
    assert [next(iter(e)) for e in doc["strokes"]] == [
        "brush", "brush", "undo", "redo", "brush", "brush",
    ]  # fmt: skip
    head = follicle.load_mesh("builtin:head")
    again = follicle.GuideEditor(follicle.load_guides("builtin:short", head))
    again.replay(log)
    assert again.points.tobytes() == ed.points.tobytes()
    assert again.log == ed.log


@pytest.mark.slow
def test_follicle_groom_replays_on_a_terminal_and_usd_opens_the_result(made):
    folder, log, ed = made
    warm()
    out = run_cli("groom", log.name, "-o", "replayed.usda", cwd=folder, tty=True, timeout=120)
    assert out.rc == 0 and not out.timed_out, out.stdout[-2000:]
    assert f"6 strokes, {ed.guides.count} guides → replayed.usda" in out.stdout
    stage = Usd.Stage.Open(str(folder / "replayed.usda"))
    curves = [UsdGeom.BasisCurves(p) for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves)]
    counts = sum(len(c.GetCurveVertexCountsAttr().Get()) for c in curves)
    assert counts == ed.guides.count
    out = run_cli("groom", log.name, "-o", "replayed.npz", cwd=folder)
    assert out.rc == 0, out.stderr
    a, b = np.load(folder / "direct.npz"), np.load(folder / "replayed.npz")
    assert sorted(a.files) == sorted(b.files)
    assert all(np.array_equal(a[k], b[k]) for k in a.files)


def mutants(text: str) -> dict[str, str]:
    """Real-shaped damage to a stroke log: truncations, flipped bytes, hostile values."""
    doc = json.loads(text)
    stroke = doc["strokes"][0]
    out = {f"cut at {k}": text[: len(text) * k // 8] for k in range(1, 8)}
    for k in (5, 40, 200, len(text) // 2, len(text) - 3):
        out[f"byte {k} flipped"] = text[:k] + chr(ord(text[k]) ^ 0x20) + text[k + 1 :]
    values = {
        "radius tiny": {"radius": 1e-300},
        "radius negative": {"radius": -3},
        "path huge": {"path": [[0, 0], [1e308, 1e308]]},
        "path flat": {"path": [1, 2, 3]},
        "path strings": {"path": [["a", "b"]]},
        "brush unknown": {"brush": "rm -rf"},
        "brush number": {"brush": 7},
        "strength nan": {"strength": float("nan")},
        "size zero": {"size": [0, 0]},
        "size huge": {"size": [10**9, 10**9]},
        "camera same point": {"camera": {"eye": [0, 0, 1], "target": [0, 0, 1]}},
        "camera missing": {"camera": None},
        "options bad": {"options": {"spacing": 1}},
        "extra key": {"colour": 1},
    }
    for name, change in values.items():
        bad = json.loads(text)
        bad["strokes"][0] = {**stroke, **change}
        out[name] = json.dumps(bad)
    deep = "[" * 100_000 + "]" * 100_000
    out["deep nesting"] = f'{{"follicle_strokes": 1, "strokes": {deep}}}'
    out["version 2"] = text.replace('"follicle_strokes": 1', '"follicle_strokes": 2')
    out["not an object"] = "[]"
    out["strokes not a list"] = '{"follicle_strokes": 1, "strokes": 3}'
    return out


@pytest.mark.slow
def test_damaged_logs_are_refused_in_a_child_under_limits(made):
    folder, log, _ = made
    names = []
    for k, (name, text) in enumerate(mutants(log.read_text()).items()):
        (folder / f"bad{k}.json").write_text(text)
        names.append(name)
    res = run_api(
        f"""
        from follicle.editing.editor import replay
        from follicle.editing.strokes import load_strokes
        head = follicle.load_mesh("builtin:head")
        outcome = []
        for k in range({len(names)}):
            ed = follicle.GuideEditor(follicle.load_guides("builtin:short", head))
            try:
                replay(ed, load_strokes(f"bad{{k}}.json"), f"bad{{k}}.json")
                outcome.append("applied")
            except FollicleError as exc:
                assert f"bad{{k}}.json" in str(exc), str(exc)
                outcome.append("refused")
        result = outcome
        """,
        folder,
        timeout=120,
    )
    assert res.kind == "ok", f"{res.kind} {res.error}: {res.message}\n{res.detail}"
    outcome = dict(zip(names, eval(res.detail["result"]), strict=True))
    # a flipped letter may still make a valid log (another brush's name, a digit): those
    # apply; everything structurally or numerically wrong is refused
    refused = {n for n, o in outcome.items() if o == "refused"}
    must = set(names) - {n for n in names if n.startswith("byte")}
    assert must <= refused, sorted(must - refused)


@pytest.mark.slow
def test_the_command_line_says_what_is_wrong_in_one_line(made, tmp_path):
    folder, log, _ = made
    bad = tmp_path / "bad.json"
    doc = json.loads(log.read_text())
    doc["strokes"][1]["radius"] = 0
    bad.write_text(json.dumps(doc))
    line = assert_cli_refused(run_cli("groom", bad, "-o", tmp_path / "g.npz", cwd=tmp_path))
    assert "strokes[1]" in line and "radius" in line
    assert not (tmp_path / "g.npz").exists()
    (tmp_path / "torn.json").write_text(log.read_text()[:100])
    assert_cli_refused(run_cli("groom", "torn.json", "-o", "g.npz", cwd=tmp_path), "torn.json")
    no_guides = tmp_path / "bare.json"
    no_guides.write_text('{"follicle_strokes": 1, "strokes": []}')
    assert_cli_refused(run_cli("groom", no_guides, "-o", "g.npz", cwd=tmp_path), "--guides")


def test_loading_checks_the_structure_and_names_the_entry(tmp_path):
    path = tmp_path / "s.json"
    path.write_text('{"follicle_strokes": 1, "strokes": [{"undo": true}, {"path": []}]}')
    with pytest.raises(InputError, match=r"strokes\[1\]"):
        load_strokes(path)
    path.write_text("{")
    with pytest.raises(FormatError, match="s.json"):
        load_strokes(path)


def test_a_number_of_thousands_of_digits_is_refused_naming_the_log(tmp_path):
    path = tmp_path / "digits.json"
    path.write_text(
        '{"follicle_strokes": 1, "strokes": [{"brush": "comb", "radius": 1%s}]}' % ("0" * 5000)
    )
    with pytest.raises(FormatError, match="digits.json: a number .* thousands of digits"):
        load_strokes(path)


@pytest.mark.slow
def test_a_stroke_of_tens_of_thousands_of_points_is_refused_at_once_on_a_terminal(made, tmp_path):
    """cut, delete and part test every guide against every segment of the path: a log
    whose one stroke has 50,000 points took minutes; refused before any work."""
    folder, log, _ = made
    doc = json.loads(log.read_text())
    stroke = next(s for s in doc["strokes"] if s.get("brush") == "cut")
    xs = np.linspace(150.0, 330.0, 50_000)
    for brush in ("cut", "delete", "part"):
        doc["strokes"] = [{**stroke, "brush": brush, "path": [[x, 120.0] for x in xs]}]
        path = tmp_path / f"{brush}.json"
        path.write_text(json.dumps(doc))
        out = run_cli("groom", path.name, "-o", "g.npz", cwd=tmp_path, tty=True, timeout=60)
        assert not out.timed_out and out.rc == 2, out.stdout[-2000:]
        assert "Traceback" not in out.stdout and "50,000 points" in out.stdout, out.stdout
    assert not (tmp_path / "g.npz").exists()


@pytest.mark.parametrize(
    "key, value", [("guides", ""), ("guides", "buil\x7ft"), ("mesh", "cuiltin8head")]
)
@pytest.mark.slow
def test_a_source_the_log_names_that_cannot_be_read_is_refused_naming_the_log(
    made, tmp_path, key, value
):
    """A damaged log can name guides or a mesh that cannot be read, or an empty name:
    the line names the log and what it names (it said ": cannot read 'no extension'
    files", naming nothing)."""
    folder, log, _ = made
    doc = json.loads(log.read_text())
    doc[key] = value
    (tmp_path / "named.json").write_text(json.dumps(doc))
    line = assert_cli_refused(
        run_cli("groom", "named.json", "-o", "g.npz", cwd=tmp_path), "named.json"
    )
    assert f"named.json: the {key} it names, {value!r}: " in line, line
    assert not (tmp_path / "g.npz").exists()


@pytest.mark.slow
def test_a_path_point_far_off_the_image_is_one_line(made, tmp_path):
    """A path point at 1e308 pixels is finite, but the stroke's length overflows: numpy
    warned on stderr before the refusal, two lines."""
    folder, log, _ = made
    doc = json.loads(log.read_text())
    doc["strokes"][0]["path"] = [[0, 0], [1e308, 1e308]]
    (tmp_path / "far.json").write_text(json.dumps(doc))
    line = assert_cli_refused(run_cli("groom", "far.json", "-o", "g.npz", cwd=tmp_path), "far.json")
    assert "strokes[0]: path: a point lies 1e+308 pixels out" in line, line
