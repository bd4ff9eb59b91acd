"""USD hair as a root layer with one payload per part file (issue: beyond one machine):
usd-core composes it into the groom the one-file layout holds, opens it with the parts
unloaded, and follicle reads it back the same; writing again replaces the parts whole;
a folder in the way, a .usdz or a part gone missing is one clean refusal."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd, UsdGeom

from follicle.errors import FormatError
from follicle.io.usd import load_usd, save_usd
from follicle.io.usd_payloads import (
    check_payloads_target,
    part_file,
    payloads_folder,
    save_usd_part,
    save_usd_payloads,
)
from follicle.pipeline import groom_scene
from follicle.scene import Scene
from hostile import assert_cli_refused, run_cli, warm

HAIRS = 2500


@pytest.fixture(scope="module")
def groom():
    return groom_scene(Scene())


def _parts(groom, size, count=HAIRS):
    """The groom's hairs in parts of ``size``, as `follicle grow --layout payloads` cuts."""
    return [groom.generate(min(size, count - a), a) for a in range(0, count, size)]


def _same_curves(a, b):
    assert (a.curve_count, a.point_count) == (b.curve_count, b.point_count)
    np.testing.assert_array_equal(a.offsets, b.offsets)
    np.testing.assert_array_equal(a.points, b.points)
    assert sorted(a.point_data) == sorted(b.point_data)
    assert sorted(a.curve_data) == sorted(b.curve_data)
    for name in a.point_data:
        np.testing.assert_array_equal(a.point_data[name], b.point_data[name], err_msg=name)
    for name in a.curve_data:
        np.testing.assert_array_equal(a.curve_data[name], b.curve_data[name], err_msg=name)


@pytest.mark.parametrize("ext, target", [(".usdc", "generic"), (".usda", "unreal")])
@pytest.mark.slow
def test_usd_core_composes_the_parts_into_the_one_file_groom(tmp_path, groom, ext, target):
    parts = _parts(groom, 1000)
    root = save_usd_payloads(
        parts, tmp_path / f"fox{ext}", guides=groom.guides, mesh=groom.mesh, target=target
    )
    one = save_usd(
        parts, tmp_path / "one.usdc", guides=groom.guides, mesh=groom.mesh, target=target
    )
    folder = payloads_folder(root)
    assert folder.name == f"fox{ext}.payloads"
    assert sorted(p.name for p in folder.iterdir()) == [f"part_000{i}.usdc" for i in range(3)]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [f"fox{ext}", folder.name, "one.usdc"]
    )
    # usd-core's own API: the composed stage, every part loaded, in id order
    stage = Usd.Stage.Open(str(root))
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    assert stage.GetDefaultPrim().GetPath() == "/Groom"
    hair = stage.GetPrimAtPath("/Groom/Hair")
    names = [p.GetName() for p in hair.GetChildren() if p.IsA(UsdGeom.BasisCurves)]
    assert names[-3:] == ["part_0000", "part_0001", "part_0002"]
    for i, part in enumerate(parts):
        prim = UsdGeom.BasisCurves(stage.GetPrimAtPath(f"/Groom/Hair/part_000{i}"))
        assert prim.GetPrim().HasPayload() and prim.GetPrim().IsLoaded()
        assert list(prim.GetCurveVertexCountsAttr().Get()) == part.counts.tolist()
        np.testing.assert_array_equal(np.asarray(prim.GetPointsAttr().Get()), part.points)
        assert prim.GetBasisAttr().Get() == "catmullRom" and prim.GetExtentAttr().Get()
    unreal = "GroomAPI" in hair.GetPrimTypeInfo().GetAppliedAPISchemas()
    assert unreal == (target == "unreal")
    assert stage.GetPrimAtPath("/Groom/Skin").IsA(UsdGeom.Mesh)
    # opened with its payloads unloaded: the guides and skin, none of the hair's points
    light = Usd.Stage.Open(str(root), Usd.Stage.LoadNone)
    assert not light.GetPrimAtPath("/Groom/Hair/part_0001").IsLoaded()
    points = UsdGeom.BasisCurves(light.GetPrimAtPath("/Groom/Hair/part_0001")).GetPointsAttr()
    assert not points.HasAuthoredValue()
    # follicle reads the same hair, the same guides, from either layout
    _same_curves(load_usd(root), load_usd(one))
    _same_curves(load_usd(root, guides=True), load_usd(one, guides=True))


def test_the_same_parts_are_the_same_bytes_and_writing_again_replaces_them(tmp_path, groom):
    first = save_usd_payloads(_parts(groom, 1000), tmp_path / "a.usdc", guides=groom.guides)
    again = save_usd_payloads(_parts(groom, 1000), tmp_path / "b.usdc", guides=groom.guides)
    assert first.read_bytes().replace(b"a.usdc.payloads", b"b.usdc.payloads") == (
        again.read_bytes()
    )
    for i in range(3):
        assert part_file(payloads_folder(first), i).read_bytes() == (
            part_file(payloads_folder(again), i).read_bytes()
        )
    # a part is one whole file of its own: its default prim, named for it
    part = Usd.Stage.Open(str(part_file(payloads_folder(first), 1)))
    assert part.GetDefaultPrim().GetPath() == "/part_0001"
    # fewer, bigger parts written over it: the old folder goes whole, nothing else stays
    save_usd_payloads(_parts(groom, 2000, 3000), first, guides=groom.guides)
    assert sorted(p.name for p in payloads_folder(first).iterdir()) == [
        "part_0000.usdc",
        "part_0001.usdc",
    ]
    assert load_usd(first).curve_count == 3000
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["a.usdc", "a.usdc.payloads", "b.usdc", "b.usdc.payloads"]
    )


def test_what_is_in_the_way_is_refused_before_anything_is_written(tmp_path, groom):
    theirs = tmp_path / "fox.usdc.payloads"
    theirs.mkdir()
    (theirs / "notes.txt").write_text("mine")
    with pytest.raises(FormatError, match=r"fox.usdc.payloads: exists and holds more"):
        save_usd_payloads(_parts(groom, 1000), tmp_path / "fox.usdc")
    (tmp_path / "file.usdc.payloads").write_text("a file, not a folder")
    with pytest.raises(FormatError, match="file.usdc.payloads: exists"):
        check_payloads_target(tmp_path / "file.usdc")
    with pytest.raises(FormatError, match=r"\.usdz is one package"):
        check_payloads_target(tmp_path / "fox.usdz")
    with pytest.raises(FormatError, match=r"fox.abc: the payloads layout .* writes USD"):
        check_payloads_target(tmp_path / "fox.abc")
    assert (theirs / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.usdc.payloads", "fox.usdc.payloads"]


def test_a_part_gone_or_not_usd_is_one_clean_refusal(tmp_path, groom):
    root = save_usd_payloads(_parts(groom, 1000), tmp_path / "fox.usdc")
    part_file(payloads_folder(root), 1).unlink()
    with pytest.raises(
        FormatError,
        match=r"fox.usdc: @./fox.usdc.payloads/part_0001.usdc@.*"
        "cannot be opened",
    ):
        load_usd(root)
    part_file(payloads_folder(root), 2).write_bytes(b"PXR-USDC" + bytes(80))  # a cut crate
    with pytest.raises(
        FormatError,
        match=r"fox.usdc: @./fox.usdc.payloads/part_0002.usdc@.*cannot be read \(Cannot read asset",
    ):
        load_usd(root)
    # a part cut short, as a copy that stopped part way leaves it
    root = save_usd_payloads(_parts(groom, 1000), tmp_path / "cut.usdc")
    part = part_file(payloads_folder(root), 2)
    part.write_bytes(part.read_bytes()[:3000])
    with pytest.raises(FormatError, match=r"part_0002.usdc@.*cannot be read \(Sdf crate file"):
        load_usd(root)
    save_usd_part(groom.generate(10), tmp_path / "alone.usdc")
    assert load_usd(tmp_path / "alone.usdc").curve_count == 10  # a part reads on its own


@pytest.mark.slow
def test_the_cli_writes_payloads_in_a_terminal_and_refuses_bad_options(tmp_path):
    (tmp_path / "s.toml").write_text(f"[groom]\ncount = {HAIRS}\n")
    warm()
    grow = "grow s.toml -o h.usda --layout payloads --chunk 1000".split()
    out = run_cli(*grow, cwd=tmp_path, tty=True, timeout=300)
    assert out.rc == 0, out.stdout + out.stderr
    assert f"{HAIRS:,} hairs" in out.stdout and "Traceback" not in out.stdout
    assert sorted(p.name for p in (tmp_path / "h.usda.payloads").iterdir()) == [
        "part_0000.usdc",
        "part_0001.usdc",
        "part_0002.usdc",
    ]
    one = run_cli("grow", "s.toml", "-o", "one.usdc", cwd=tmp_path, timeout=300)
    assert one.rc == 0
    _same_curves(load_usd(tmp_path / "h.usda"), load_usd(tmp_path / "one.usdc"))
    refused = run_cli("grow", "s.toml", "-o", "x.usdz", "--layout", "payloads", cwd=tmp_path)
    assert_cli_refused(refused, "x.usdz", ".usdz is one package")
    refused = run_cli("grow", "s.toml", "-o", "x.abc", "--layout", "payloads", cwd=tmp_path)
    assert_cli_refused(refused, "x.abc", "payloads layout")
    refused = run_cli(
        "grow", "s.toml", "-o", "x.usdc", "--layout", "payloads", "--chunk", 0, cwd=tmp_path
    )
    assert_cli_refused(refused, "--chunk")
    refused = run_cli("grow", "s.toml", "-o", "x.usdc", "--layout", "parts", cwd=tmp_path)
    assert refused.rc == 2 and "payloads" in refused.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["s.toml", "h.usda", "h.usda.payloads", "one.usdc"]
    )


@pytest.mark.slow
def test_ctrl_c_leaves_neither_root_nor_parts(tmp_path):
    """SIGINT once parts are on disk: the hidden folder of parts and the root's
    temporary name go; exit 130; an older groom of the same name stays as it was."""
    (tmp_path / "s.toml").write_text("[groom]\ncount = 1000000\n")
    warm()
    small = run_cli(
        "grow", "s.toml", "-o", "h.usdc", "--layout", "payloads", "--count", 500, cwd=tmp_path
    )
    assert small.rc == 0
    before = {p.name: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    proc = subprocess.Popen(
        [sys.executable, "-m", "follicle.cli", "grow", "s.toml", "-o", "h.usdc"]
        + ["--layout", "payloads", "--chunk", "20000"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 120
    while not list(tmp_path.glob(".h.usdc.payloads-*/part_0001.usdc")):
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    after = {p.name: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert after == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.usdc", "h.usdc.payloads", "s.toml"]


@pytest.mark.slow
def test_a_scene_asks_for_payloads_and_a_batch_refuses_them(tmp_path):
    """[output].layout = "payloads" is what `follicle grow SCENE` writes (--layout file
    overrides it); a batch, whose manifest hashes one file per variant, refuses it."""
    (tmp_path / "s.toml").write_text(
        '[groom]\ncount = 300\n[output]\ncurves = "h.usdc"\nlayout = "payloads"\n'
    )
    assert run_cli("grow", "s.toml", cwd=tmp_path, timeout=300).rc == 0
    assert [p.name for p in (tmp_path / "h.usdc.payloads").iterdir()] == ["part_0000.usdc"]
    assert run_cli("grow", "s.toml", "-o", "f.usdc", "--layout", "file", cwd=tmp_path).rc == 0
    assert not (tmp_path / "f.usdc.payloads").exists()
    _same_curves(load_usd(tmp_path / "h.usdc"), load_usd(tmp_path / "f.usdc"))
    refused = run_cli("batch", "s.toml", "-o", "ds", "--no-image", cwd=tmp_path)
    assert_cli_refused(refused, "s.toml", "[output].layout")
    assert not (tmp_path / "ds").exists()


def test_the_reading_limits_follow_the_parts_the_stage_loads(tmp_path, groom, monkeypatch):
    """The root of a payloads layout is a few kilobytes; the child reading it is given
    memory and time for the root and its part files (sized from the root alone, a 1 M
    hair groom failed: out of memory, or a healthy part called corrupt)."""
    from follicle.io import guard

    root = save_usd_payloads(_parts(groom, 1000), tmp_path / "fox.usdc", guides=groom.guides)
    parts = sum(p.stat().st_size for p in payloads_folder(root).iterdir())
    assert parts > 20 * root.stat().st_size
    asked = []
    real = guard.read_guarded

    def spy(kind, path, size, *args, **options):
        asked.append(size)
        return real(kind, path, size, *args, **options)

    monkeypatch.setattr(guard, "read_guarded", spy)
    back = load_usd(root)
    assert back.curve_count == HAIRS
    assert asked == [root.stat().st_size + parts]


def _snapshot(folder):
    """Every file under ``folder`` (links as links) and its bytes or link target."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_symlink():
            out[str(p.relative_to(folder))] = ("link", str(p.readlink()))
        elif p.is_file():
            out[str(p.relative_to(folder))] = p.read_bytes()
    return out


@pytest.mark.slow
def test_nothing_follicle_did_not_write_is_deleted_by_a_payloads_layout(tmp_path, groom):
    """A payloads folder is replaced only when all it holds are part files follicle wrote,
    judged by their contents: a part_0000.usdc that is a folder of the user's files, a
    part file that is not a crate, a link among the parts, or the payloads folder itself
    a symbolic link is refused before anything is written, and everything stays."""
    root = tmp_path / "fox.usdc"
    parts = payloads_folder(root)
    theirs = part_file(parts, 0)
    theirs.mkdir(parents=True)
    (theirs / "thesis.txt").write_text("five years of work")
    before = _snapshot(tmp_path)
    with pytest.raises(FormatError, match=r"fox.usdc.payloads: exists .* part_0000.usdc is a fold"):
        save_usd_payloads(_parts(groom, 1000), root)
    assert _snapshot(tmp_path) == before
    theirs.joinpath("thesis.txt").unlink()
    theirs.rmdir()
    theirs.write_text("not a crate, but named like a part")
    with pytest.raises(FormatError, match=r"part_0000.usdc is not a USD crate follicle wrote"):
        check_payloads_target(root)
    theirs.unlink()
    (tmp_path / "mine.usdc").write_bytes(b"mine")
    theirs.symlink_to(tmp_path / "mine.usdc")
    with pytest.raises(FormatError, match=r"part_0000.usdc is a symbolic link"):
        save_usd_payloads(_parts(groom, 1000), root)
    assert (tmp_path / "mine.usdc").read_bytes() == b"mine" and theirs.is_symlink()
    # the payloads folder a symbolic link to a folder of the user's: refused, no stray link
    theirs.unlink()
    parts.rmdir()
    elsewhere = tmp_path / "elsewhere"
    save_usd_payloads(_parts(groom, 1000), tmp_path / "made.usdc")
    payloads_folder(tmp_path / "made.usdc").rename(elsewhere)  # part files it wrote, even
    parts.symlink_to(elsewhere, target_is_directory=True)
    before = _snapshot(tmp_path)
    with pytest.raises(FormatError, match=r"fox.usdc.payloads: exists and is a symbolic link"):
        save_usd_payloads(_parts(groom, 1000), root)
    assert _snapshot(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["elsewhere", "fox.usdc.payloads", "made.usdc", "mine.usdc"]
    )


def test_writing_again_removes_only_the_part_files(tmp_path, groom, monkeypatch):
    """A file that lands in an older payloads folder after it was checked stays: of the
    old folder only its part files are removed, and the folder only when empty."""
    import os

    root = save_usd_payloads(_parts(groom, 1000), tmp_path / "fox.usdc")
    late = payloads_folder(root) / "late.txt"
    rename = os.rename

    def then_a_file_lands(src, dst):
        if Path(src) == payloads_folder(root) and not late.exists():
            late.write_text("written meanwhile")  # after the checks, before the move aside
        rename(src, dst)

    monkeypatch.setattr(os, "rename", then_a_file_lands)
    save_usd_payloads(_parts(groom, 2000), root)
    kept = [p for p in tmp_path.iterdir() if p.name.startswith(".fox.usdc.payloads.old-")]
    assert len(kept) == 1 and [p.name for p in kept[0].iterdir()] == ["late.txt"]
    assert sorted(p.name for p in payloads_folder(root).iterdir()) == [
        "part_0000.usdc",
        "part_0001.usdc",
    ]


@pytest.mark.slow
def test_a_name_usd_cannot_hold_is_refused_naming_the_character(tmp_path):
    """A newline in the root's name (its payload arcs name the folder by it, and a USD
    asset path holds no control character) is one line saying so, not "free disk
    space", on a terminal too, with nothing written."""
    (tmp_path / "s.toml").write_text("[groom]\ncount = 300\n")
    warm()
    for tty in (False, True):
        out = run_cli(
            "grow", "s.toml", "-o", "a\nb.usdc", "--layout", "payloads", cwd=tmp_path, tty=tty
        )
        text = out.stdout + out.stderr
        assert out.rc == 2 and "Traceback" not in text, text
        assert "a\\nb.usdc" in text and "character that is not allowed" in text, text
        assert "disk space" not in text
        if not tty:
            assert_cli_refused(out, "a\\nb.usdc", "not allowed")
    with pytest.raises(FormatError, match="not allowed"):
        check_payloads_target(tmp_path / "tab\there.usda")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]
