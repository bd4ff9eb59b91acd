"""Issue 41's mutation-fuzz campaign, seeded and small enough to run every time: real
files follicle writes (an Alembic groom, a GuideEditor's stroke log), damaged as bytes
and as documents, and stroke logs made up from scratch by hypothesis, each read in a
child process under the README's limits through the Python API (``load_curves``,
``replay_file``) and the command line (``follicle info``, ``follicle groom``). Each must
read, or be one FollicleError line naming the file; never a traceback, another
exception, a signal, a time-out or a file left behind."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import follicle
from follicle.groom.brushes import BRUSHES
from follicle.io.alembic import save_abc
from hostile import HOSTILE_VALUES, byte_damage, files, json_damage, run_api, run_cli, screen

CASES = 10  # of each kind, through the API; two of them through the command line


def _drawn(strategy, count: int) -> list:
    """``count`` examples of ``strategy``, the same on every run (derandomized)."""
    found: list = []

    @settings(
        max_examples=count,
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(strategy)
    def collect(example):
        found.append(example)

    collect()
    return found[:count]


@pytest.fixture(scope="module")
def originals(tmp_path_factory):
    """An Alembic groom (two hair chunks with widths and root UVs, guides, a skin) and a
    GuideEditor's stroke log (comb, cut, undo, redo, add, length), as follicle writes them."""
    folder = tmp_path_factory.mktemp("originals")
    rng = np.random.default_rng(41)
    hair = follicle.HairCurves.from_array(
        rng.random((40, 6, 3), dtype=np.float32),
        point_data={"width": np.full(240, 1e-3, np.float32)},
        curve_data={"root_uv": rng.random((40, 2), np.float32)},
    )
    skin = follicle.SkinMesh(
        [[0, 0, 0], [1, 0, 0], [0, 0, -1]], [[0, 1, 2]], [[0, 0], [1, 0], [0, 1]]
    )
    abc = save_abc([hair, hair[:10]], folder / "groom.abc", guides=hair[:5], mesh=skin)
    head = follicle.load_mesh("builtin:head")
    editor = follicle.GuideEditor(follicle.load_guides("builtin:short", head))
    lo, hi = head.bounds("rest")
    centre = (lo + hi) / 2
    cam = follicle.Camera(eye=centre + np.array([0.0, 0.15, 0.7]), target=centre)
    size = (480, 360)
    editor.stroke("comb", [[180, 80], [300, 90]], cam, radius=60, strength=0.8, size=size)
    editor.stroke("cut", [[150, 120], [330, 120]], cam, radius=5, size=size)
    editor.undo()
    editor.redo()
    editor.stroke("add", [[220, 70], [260, 70]], cam, radius=20, size=size)
    editor.stroke("length", [[200, 100], [280, 100]], cam, radius=50, strength=-0.3, size=size)
    log = editor.save_strokes(folder / "groom.json", mesh="builtin:head", guides="builtin:short")
    return abc.read_bytes(), log.read_text()


def _number():
    return st.sampled_from([0.0, 1.0, 5.0, 60.0, -3.0, 1e-300, 1e308]) | st.sampled_from(
        HOSTILE_VALUES
    )


def _point():
    return st.lists(st.sampled_from([0.0, 120.0, 240.0, 1e6, -1.0]), min_size=2, max_size=2)


_CAMERA = {"eye": [0.0, 0.09, 0.7], "target": [0.0, -0.05, 0.0], "up": [0.0, 1.0, 0.0]}


@st.composite
def stroke_logs(draw) -> str:
    """A stroke log made up from scratch: brush strokes whose every field may be right,
    wrong in type or out of range, undo and redo, and what the format does not know."""
    entry = st.fixed_dictionaries(
        {
            "brush": st.sampled_from(BRUSHES) | st.sampled_from(HOSTILE_VALUES),
            "path": st.lists(_point(), max_size=6) | st.sampled_from(HOSTILE_VALUES),
            "radius": _number(),
            "strength": _number(),
            "size": st.just([480, 360]) | st.sampled_from(HOSTILE_VALUES),
            "camera": st.just(_CAMERA) | st.sampled_from(HOSTILE_VALUES),
        },
        optional={"options": st.sampled_from([{}, {"spacing": 1}, None]), "zz": st.just(1)},
    )
    strokes = st.lists(entry | st.sampled_from([{"undo": True}, {"redo": True}]), max_size=4)
    doc = {
        "follicle_strokes": draw(st.sampled_from([1, 1, 1, 2, "1", None])),
        "mesh": "builtin:head",
        "guides": "builtin:short",
        "strokes": draw(strokes),
    }
    return json.dumps(doc)


def _write(folder, name: str, items: list) -> list[str]:
    """Each item (bytes: an archive; text: a log) as ``name<k>.abc`` / ``.json``."""
    names = []
    for k, data in enumerate(items):
        path = folder / f"{name}{k}.{'abc' if isinstance(data, bytes) else 'json'}"
        if isinstance(data, bytes):
            path.write_bytes(data)
        else:
            path.write_text(data)
        names.append(path.name)
    return names


_READ_ALL = """
from follicle.editing.editor import replay_file
outcome = []
for name in {names!r}:
    try:
        follicle.load_curves(name) if name.endswith(".abc") else replay_file(name)
        outcome.append("ok")
    except FollicleError as exc:
        assert name in str(exc) and "\\n" not in str(exc), f"{{name}}: {{exc}}"
        outcome.append("refused")
result = outcome
"""


def _cases(originals: tuple[bytes, str]) -> dict[str, list]:
    """The seeded cases of each kind: damaged archives, damaged logs, made-up logs."""
    abc, log = originals
    return {
        "abc": _drawn(byte_damage(abc), CASES),
        "log": _drawn(json_damage(log), CASES),
        "made": _drawn(stroke_logs(), CASES),
    }


@pytest.mark.parametrize("kind", ["abc", "log", "made"])
@pytest.mark.slow
def test_damaged_files_through_the_api_read_or_are_one_follicle_error(tmp_path, originals, kind):
    """Every case, in one child under the limits: a result or one FollicleError line
    naming the file (any other exception, a signal or the time limit fails it)."""
    names = _write(tmp_path, kind, _cases(originals)[kind])
    res = run_api(_READ_ALL.format(names=names), tmp_path, timeout=120)
    assert res.kind == "ok", f"{res.kind} {res.error}: {res.message}\n{res.detail}"
    assert "refused" in res.detail["result"]  # the damage reached the readers' checks


@pytest.mark.parametrize("kind", ["abc", "log", "made"])
@pytest.mark.slow
def test_damaged_files_on_the_command_line_are_one_line_and_leave_nothing(
    tmp_path, originals, kind
):
    """Two cases on the command line (piped, then on a terminal): exit 0, or
    exit 2 with one line naming the file; no traceback, nothing written on a refusal."""
    items = _cases(originals)[kind][:2]
    for k, name in enumerate(_write(tmp_path, kind, items)):
        args = ["info", name] if kind == "abc" else ["groom", name, "-o", f"{name}.npz"]
        before = files(tmp_path)
        out = run_cli(*args, cwd=tmp_path, tty=k == 1, timeout=60)
        said = screen(out.stdout) if out.tty else out.stderr.splitlines()
        said = [line.strip() for line in said if line.strip()]
        shown = f"{name}: rc={out.rc} {out.stdout[-1500:]} {out.stderr[-1500:]}"
        assert not out.timed_out and out.rc in (0, 2), shown
        assert "Traceback" not in out.stdout + out.stderr, shown
        if out.rc == 2:
            assert len(said) == 1 and said[0].startswith("error: ") and name in said[0], shown
            assert files(tmp_path) == before, shown
