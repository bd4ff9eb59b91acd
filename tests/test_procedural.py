"""RenderMan render-time hair: the voxel RIB of export_rib and the follicle-procedural
RunProgram protocol, whose voxels together regrow exactly the whole groom."""

import io
import os
import re
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from follicle import FormatError, HairCurves, InputError, spline
from follicle.apps.procedural import Procedural, export_rib, frame_scene, parse_request, serve
from follicle.cli import main
from follicle.io.procedural_data import FrameData
from follicle.io.rib import write_block
from follicle.pipeline import groom_scene
from follicle.scene import parse_scene
from hairfiles import check_counts, close7, curves_requests, strip_ends

SCENE = {
    "groom": {
        "count": 3000,
        "clump_count": 40,
        "kink_tip": 0.002,
        "frizz_tip": 0.002,
        "hue_variation": 8.0,
        "cut": "builtin:parting",
    }
}
PROCEDURAL = Path(sys.executable).with_name("follicle-procedural")


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("rib")
    scene = parse_scene(SCENE)
    return export_rib(scene, out / "frame.rib", voxels=4), groom_scene(scene).generate()


@pytest.fixture(scope="module")
def procedural():
    return Procedural()


def _request(done, voxel, detail="310.5"):
    return f"{detail} {done.frame.resolve()} {voxel}\n".encode()


@pytest.mark.slow
def test_voxels_regrow_the_whole_groom_bit_for_bit(exported, procedural):
    done, whole = exported
    frame = procedural.frame(str(done.frame))
    parts = [chunk for v in done.voxels for chunk in frame.curves(v)]
    joined = HairCurves.concatenate(parts)
    joined = joined[np.argsort(joined.curve_data["hair_id"], kind="stable")]
    assert joined.curve_count == whole.curve_count > 1000  # the parting map cuts some away
    assert np.array_equal(joined.offsets, whole.offsets)
    assert joined.points.dtype == np.float32 and np.array_equal(joined.points, whole.points)
    for kind in ("point_data", "curve_data"):
        a, b = getattr(joined, kind), getattr(whole, kind)
        assert a.keys() == b.keys()
        for key in a:
            assert a[key].dtype == b[key].dtype and np.array_equal(a[key], b[key]), key
    assert [p.curve_count for p in parts] == done.curves


@pytest.mark.slow
def test_replies_are_the_rib_of_the_whole_groom(exported, procedural, tmp_path):
    done, whole = exported
    ids = []
    for v in done.voxels:
        reply = procedural.reply(_request(done, v))
        (tmp_path / "voxel.rib").write_bytes(reply)
        ((nverts, wrap, params),) = curves_requests(tmp_path / "voxel.rib")
        mine = params["uniform int hair_index"].astype(np.int64)
        part = whole[np.flatnonzero(np.isin(whole.curve_data["hair_id"], mine))]
        check_counts(nverts, wrap, params, part)
        close7(strip_ends(params["P"], nverts), part.points)
        close7(params["Cs"], part.point_data["color"])
        expected = io.BytesIO()
        write_block(expected, part)
        assert reply == expected.getvalue()  # the whole groom's RIB of these hairs, byte for byte
        ids.append(mine)
    assert np.array_equal(np.sort(np.concatenate(ids)), whole.curve_data["hair_id"])


@pytest.mark.slow
def test_rib_names_each_voxel_its_box_and_counts(exported):
    done, whole = exported
    text = done.rib.read_text()
    assert text.startswith("##RenderMan RIB\nversion 3.04\n# follicle 3,000 hairs: ")
    calls = re.findall(
        r'Procedural "RunProgram" \["follicle-procedural" "(.+) (\d+)"\] \[(.+)\]', text
    )
    assert [int(v) for _, v, _ in calls] == done.voxels and len(done.voxels) > 4
    assert {path for path, _, _ in calls} == {str(done.frame.resolve())}
    boxes = np.array([[float(x) for x in box.split()] for _, _, box in calls])
    assert np.array_equal(boxes.reshape(-1, 3, 2).transpose(0, 2, 1), done.boxes)  # exact repr
    for v, roots, expect, curves in zip(
        done.voxels, done.roots, done.expected, done.curves, strict=True
    ):
        assert (
            f"# voxel {v} " in text
            and f": {roots} hairs (count × P(voxel) = {expect:.1f}), {curves} curves" in text
        )
        assert abs(roots - expect) < 4 * np.sqrt(expect) + 1  # binomial noise
    assert sum(FrameData.load(done.frame).roots.values()) == 3000  # some voxels' hair is all cut
    assert sum(done.curves) == whole.curve_count
    assert len(text) < 3000 and "Curves" not in text  # no geometry in the RIB


@pytest.mark.slow
def test_boxes_hold_the_curves_and_are_their_bezier_hulls(exported, procedural):
    done, _ = exported
    frame = procedural.frame(str(done.frame))
    for v, box in zip(done.voxels, done.boxes, strict=True):
        part = HairCurves.concatenate(list(frame.curves(v)))
        half = 0.5 * float(part.point_data["width"].max())
        dense = spline.resample(part.points, part.offsets, 16)[0]  # along the curves
        assert (dense >= box[0] + half).all() and (dense <= box[1] - half).all()
        bezier = spline.to_bezier(part.points, part.offsets).reshape(-1, 3)
        slack = 1e-6 * np.abs(box).max(axis=0) + 1e-6 * half
        np.testing.assert_array_less(np.abs(box[0] + half - bezier.min(axis=0)), slack)
        np.testing.assert_array_less(np.abs(box[1] - half - bezier.max(axis=0)), slack)


@pytest.mark.slow
def test_posed_mesh_and_time_are_regrown_exactly(tmp_path):
    scene = parse_scene(
        {
            "guides": {"path": "builtin:short"},
            "groom": {"count": 800, "frizz_tip": 0.003, "frizz_speed": 2.0, "frizz_blend": 1.0},
        }
    )
    groom = groom_scene(scene)
    turn = np.array([[0.8, 0.0, 0.6], [0.0, 1.0, 0.0], [-0.6, 0.0, 0.8]])
    pose = groom.mesh.rest_vertices @ turn.T + [0.1, 0.2, 0.0]
    done = export_rib(scene, tmp_path / "posed.rib", voxels=3, pose=pose, time=0.25)
    frame = Procedural().frame(str(done.frame))
    assert np.array_equal(frame.pose.vertices, pose) and frame.time == 0.25
    assert frame.groom.mesh.at_rest
    joined = HairCurves.concatenate([c for v in done.voxels for c in frame.curves(v)])
    joined = joined[np.argsort(joined.curve_data["hair_id"], kind="stable")]
    whole = groom.generate(time=0.25, pose=groom.mesh.posed(vertices=pose))
    assert np.array_equal(joined.points, whole.points)
    assert np.array_equal(joined.point_data["normal"], whole.point_data["normal"])
    assert not np.array_equal(whole.points, groom_scene(scene).generate(time=0.25).points)
    lo, hi = whole.bounds()
    assert (done.boxes[:, 0].min(axis=0) < lo).all() and (done.boxes[:, 1].max(axis=0) > hi).all()


@pytest.mark.slow
def test_protocol_answers_every_line_and_survives_bad_ones(exported):
    done, _ = exported
    lines = [
        _request(done, done.voxels[0]),
        b"garbage\n",
        _request(done, done.voxels[1], "1e9"),
        b"\n",
        b"1 " + b"x" * 70000 + b" 3\n",
        _request(done, 999),
        b"1.5 /no/such/frame 0\n",
        b"2 \xff\xfe 1\n",
        b"nan " + _request(done, 0)[6:],
        _request(done, done.voxels[0])[:-1],
    ]
    out, errors = io.BytesIO(), io.StringIO()
    serve(io.BytesIO(b"".join(lines)), out, errors)
    replies = out.getvalue().split(b"\xff")
    assert len(replies) == len(lines) + 1 and replies[-1] == b""
    good = {0, 2, 9}
    for i, reply in enumerate(replies[:-1]):
        if i in good:
            assert reply.startswith(b"AttributeBegin\n") and reply.endswith(b"AttributeEnd\n"), i
        else:
            assert re.fullmatch(rb"# follicle-procedural: [^\n]+\n", reply), reply
    assert replies[0] == replies[9]
    text = errors.getvalue()
    assert text.count("follicle-procedural: ") == len(lines) - len(good)
    for message in (
        "malformed request 'garbage'",
        "longer than 65536 bytes",
        "voxels 0 … ",
        "/no/such/frame: cannot read the frame file",
    ):
        assert message in text


@pytest.mark.slow
def test_corrupt_frame_files_are_errors_not_crashes(exported, tmp_path):
    done, _ = exported
    good = done.frame.read_bytes()
    header = zlib.decompress(good[17:])
    cases = {
        "empty": b"",
        "magic": b"x" + good[1:],
        "truncated": good[:-5],
        "flipped": good[:40] + bytes([good[40] ^ 1]) + good[41:],
        "trailing": good + b"\0",
        "json": good[:17] + zlib.compress(b"{not json\n"),
        "fields": good[:17] + zlib.compress(b'{"scene_toml": ""}\n'),
        "pose": good[:17] + zlib.compress(header + b"\0" * 24),
        "scene": good[:17] + zlib.compress(header.replace(b"[groom]", b"[groom")),
    }
    procedural = Procedural()
    for name, data in cases.items():
        path = tmp_path / f"{name}.follicle.z"
        path.write_bytes(data)
        with pytest.raises(FormatError if name != "scene" else Exception):
            frame_scene(FrameData.load(path), str(path))
        reply = procedural.reply(f"1 {path} {done.voxels[0]}\n".encode())
        assert reply.startswith(f"# follicle-procedural: {path}".encode()), (name, reply)
    stale = FrameData.load(done.frame)
    stale.roots[done.voxels[0]] += 1
    (tmp_path / "stale.follicle.z").write_bytes(stale.to_bytes())
    reply = procedural.reply(f"1 {tmp_path / 'stale.follicle.z'} 0\n".encode())
    assert b"differ from the exported ones" in reply
    assert b"not a regular file" in procedural.reply(f"1 {tmp_path} 0\n".encode())


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=300))
def test_any_request_line_parses_or_is_refused(line):
    try:
        request = parse_request(line)
    except InputError:
        return
    assert request.voxel >= 0 and request.frame and "\n" not in request.frame


@settings(max_examples=150, deadline=2000)
@given(
    st.lists(
        st.one_of(
            st.binary(max_size=60), st.from_regex(rb"\A[0-9.e+-]{1,6} [ -~]{1,20} [0-9]{1,3}\Z")
        ),
        max_size=8,
    )
)
@pytest.mark.slow
def test_random_request_streams_get_one_answer_a_line(lines):
    stream = b"\n".join(lines)
    out = io.BytesIO()
    serve(io.BytesIO(stream), out, io.StringIO())
    expected = len(io.BytesIO(stream).readlines())
    assert out.getvalue().count(b"\xff") == expected
    for reply in out.getvalue().split(b"\xff")[:-1]:
        assert reply.startswith(b"# follicle-procedural: ")


def _installed(command: list[str]) -> None:
    """Skip where the console script ``command`` names is not installed (a checkout run
    without ``pip install -e .``); under CI, which installs it, its absence fails."""
    if Path(command[0]).exists():
        return
    if os.environ.get("CI"):
        pytest.fail(f"{command[0]} is not installed under CI (.ci/run: pip install -e .)")
    pytest.skip("follicle-procedural is not installed: pip install -e .")


@pytest.mark.parametrize(
    "command", [[str(PROCEDURAL)], [sys.executable, "-m", "follicle.apps.procedural"]]
)
@pytest.mark.slow
def test_the_program_speaks_runprogram(exported, procedural, command):
    _installed(command)
    done, _ = exported
    v = done.voxels[-1]
    proc = subprocess.run(
        command, input=_request(done, v) + b"0.5 bad request\n", capture_output=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    first, second, rest = proc.stdout.split(b"\xff")
    assert first == procedural.reply(_request(done, v)) and rest == b""
    assert second.startswith(b"# follicle-procedural: malformed request '0.5 bad request'")
    assert b"malformed request" in proc.stderr and b"Traceback" not in proc.stderr


@pytest.mark.parametrize(
    "command", [[str(PROCEDURAL)], [sys.executable, "-m", "follicle.apps.procedural"]]
)
def test_the_installed_program_prints_its_help_and_exits_0(command):
    """`follicle-procedural --help`, as a user types it (issue 46): its usage on stdout,
    exit 0, nothing read from stdin (closed here: a read would see EOF, not hang)."""
    _installed(command)
    proc = subprocess.run(
        [*command, "--help"], stdin=subprocess.DEVNULL, capture_output=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith(b"usage: follicle-procedural\n") and proc.stderr == b""


@pytest.mark.slow
def test_export_arguments_are_checked_and_writes_are_all_or_nothing(tmp_path):
    scene = parse_scene({"groom": {"count": 50}})
    for voxels in (0, 257, True, 2.5):
        with pytest.raises(InputError, match="voxels"):
            export_rib(scene, tmp_path / "a.rib", voxels=voxels)
    with pytest.raises(InputError, match="quotes"):
        export_rib(scene, tmp_path / 'say "hi".rib')
    (tmp_path / "b.follicle.z").mkdir()  # the frame file cannot be written: no RIB either
    with pytest.raises(OSError):
        export_rib(scene, tmp_path / "b.rib", voxels=2)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.follicle.z"]


@pytest.mark.slow
def test_cli_export_rib(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text("[groom]\ncount = 400\n")
    runner = CliRunner()
    result = runner.invoke(
        main,
        [
            "export-rib",
            str(scene),
            "-o",
            str(tmp_path / "f.rib"),
            "--voxels",
            "3",
            "--count",
            "300",
            "--seed",
            "2",
        ],
    )
    assert result.exit_code == 0, result.output
    assert re.match(
        r"300 hairs in \d+ voxels \(\d×\d×\d grid\) → .*f\.rib \([\d,]+ bytes\) \+"
        r" .*f\.follicle\.z \([\d,]+ bytes\)",
        result.output,
    )
    stored = frame_scene(FrameData.load(tmp_path / "f.follicle.z"))
    assert (stored.groom.count, stored.groom.seed) == (300, 2)
    (tmp_path / "bad.toml").write_text("[groom]\ncount = -1\n")
    proc = subprocess.run(
        [sys.executable, "-m", "follicle.cli", "export-rib", "bad.toml", "-o", "g.rib"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.startswith("error:") and "[groom].count" in proc.stderr, proc.stderr
    for args, message in (
        (["-o", str(tmp_path / "g.txt")], "must end in .rib"),
        (["-o", str(tmp_path / "g.rib"), "--voxels", "0"], "voxels: expected"),
    ):
        result = runner.invoke(main, ["export-rib", str(scene), *args])
        assert result.exit_code == 2 and message in result.output, result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "bad.toml",
        "f.follicle.z",
        "f.rib",
        "scene.toml",
    ]
