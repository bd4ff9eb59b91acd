"""`follicle batch`: variants of a sweep, their folders and manifest, the same bytes here
and on a local Dask cluster, kept on a second run, and bad sweeps refused by name."""

from __future__ import annotations

import csv
import filecmp
import re
import sys

import pytest
from click.testing import CliRunner

from follicle.cli import main
from follicle.distributed.batch import Outputs, parse_seeds, parse_vary, run_batch, variants
from follicle.errors import ConfigError, FollicleError
from follicle.scene import Scene
from hostile import assert_api_refused, run_api, run_cli


def _scene() -> Scene:
    s = Scene()
    return s.replace(groom=s.groom.replace(count=300), render=s.render.replace(size=(64, 48)))


def test_a_sweep_gives_every_combination_in_order() -> None:
    sweep = parse_vary("groom.curl_radius=0.002:0.01:5")
    assert sweep.values == (0.002, 0.004, 0.006, 0.008, 0.01)
    assert parse_vary("groom.count=10:30:3").values == (10, 20, 30)
    assert parse_vary("render.shading=kajiya,marschner").values == ("kajiya", "marschner")
    batch = variants([("a", _scene())], [sweep], parse_seeds("0:3"))
    assert [v.name for v in batch][:2] == ["v00000", "v00001"] and len(batch) == 15
    assert [(v.seed, v.scene.groom.curl_radius) for v in batch[:4]] == [
        (0, 0.002),
        (1, 0.002),
        (2, 0.002),
        (0, 0.004),
    ]


@pytest.mark.parametrize(
    "text, match",
    [
        ("groom.curl_radius", "KEY=START"),
        ("groom.nope=1", r"\[groom\]\.nope: unknown key"),
        ("nosuch.key=1", r"\[nosuch\]: unknown section"),
        ("groom.curl_radius=a:b:3", "two numbers"),
    ],
)
def test_bad_sweeps_are_refused_by_name(text: str, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        parse_vary(text)


def test_a_value_its_section_refuses_is_named_before_anything_grows(tmp_path) -> None:
    with pytest.raises(ConfigError, match="count"):
        variants([("a", _scene())], [parse_vary("groom.count=-5,10")])
    with pytest.raises(ConfigError, match="--seeds"):
        parse_seeds("5:2")


@pytest.mark.slow
def test_serial_and_cluster_batches_are_the_same_bytes_and_a_rerun_keeps_them(tmp_path) -> None:
    batch = variants([("a", _scene())], [parse_vary("groom.curl_radius=0.002,0.008")], range(2))
    one = run_batch(batch, tmp_path / "one", Outputs(".usdc"))
    rows = list(csv.DictReader(one.open()))
    assert [r["variant"] for r in rows] == ["v00000", "v00001", "v00002", "v00003"]
    assert rows[2]["groom.curl_radius"] == "0.008" and rows[3]["seed"] == "1"
    assert all(int(r["hairs"]) == 300 for r in rows)
    assert len({r["curves_sha256"] for r in rows}) == 4  # every variant its own hair
    many = run_batch(batch, tmp_path / "many", Outputs(".usdc"), scheduler="local:2")
    cmp = filecmp.dircmp(tmp_path / "one", tmp_path / "many")
    assert not cmp.diff_files and not cmp.left_only and not cmp.right_only
    for name in ("v00000", "v00003"):
        sub = filecmp.cmpfiles(
            one.parent / name, many.parent / name, ["hair.usdc", "hair.png"], False
        )
        assert sub[0] == ["hair.usdc", "hair.png"]
    before = (one.parent / "v00001" / "hair.usdc").stat().st_mtime_ns
    assert run_batch(batch, tmp_path / "one", Outputs(".usdc")).read_bytes() == one.read_bytes()
    assert (one.parent / "v00001" / "hair.usdc").stat().st_mtime_ns == before  # kept
    with pytest.raises(ConfigError, match="v00000: holds something other"):
        run_batch(batch, tmp_path / "one", Outputs(".abc"))
    assert not [p for p in tmp_path.rglob(".*pending*")]


@pytest.mark.slow
def test_the_cli_writes_the_manifest_and_refuses_a_bad_sweep_in_one_line(
    tmp_path, monkeypatch
) -> None:
    runner = CliRunner()
    args = ["batch", "-o", str(tmp_path / "b"), "--count", "200", "--size", "48", "32"]
    result = runner.invoke(main, [*args, "--seeds", "0:2", "--curves", "none"])
    assert result.exit_code == 0, result.output
    rows = list(csv.DictReader((tmp_path / "b" / "manifest.csv").open()))
    assert [r["seed"] for r in rows] == ["0", "1"] and "curves" not in rows[0]
    # the manifest's path as the folder was given (here absolute); a relative one stays so
    assert result.output.strip().endswith(f"2 variants → {tmp_path / 'b' / 'manifest.csv'}")
    monkeypatch.chdir(tmp_path)
    relative = runner.invoke(main, ["batch", "-o", "r", *args[3:], "--seeds", "0:1"])
    assert relative.output.strip().endswith("1 variants → r/manifest.csv"), relative.output
    bad = runner.invoke(main, [*args, "--vary", "groom.nope=1"])
    assert bad.exit_code == 2 and "[groom].nope: unknown key" in bad.output


@pytest.mark.slow
def test_a_parquet_manifest_keeps_the_types_and_is_the_same_bytes_again(tmp_path) -> None:
    """`--manifest parquet`: the rows of the CSV manifest, with integer, float and text
    columns (a sweep mixing numbers and words is text), and the same bytes when written
    again from the kept variants."""
    import pyarrow.parquet as pq

    runner = CliRunner()
    args = ["batch", "--count", "200", "--size", "48", "32", "--seeds", "0:2", "--no-image"]
    args += ["--curves", "none", "--vary", "groom.curl_radius=0.002,0.008"]
    for name, manifest in (("c", "csv"), ("p", "parquet")):
        done = runner.invoke(main, [*args, "-o", str(tmp_path / name), "--manifest", manifest])
        assert done.exit_code == 0, done.output
    table = pq.read_table(tmp_path / "p" / "manifest.parquet")
    assert str(table.schema.field("seed").type) == "int64"
    assert str(table.schema.field("hairs").type) == "int64"
    assert str(table.schema.field("groom.curl_radius").type) == "double"
    assert table.column("groom.curl_radius").to_pylist() == [0.002, 0.002, 0.008, 0.008]
    rows = list(csv.DictReader((tmp_path / "c" / "manifest.csv").open()))
    assert [str(v) for v in table.column("scene_sha256").to_pylist()] == [
        r["scene_sha256"] for r in rows
    ]
    first = (tmp_path / "p" / "manifest.parquet").read_bytes()
    again = runner.invoke(main, [*args, "-o", str(tmp_path / "p"), "--manifest", "parquet"])
    assert again.exit_code == 0 and (tmp_path / "p" / "manifest.parquet").read_bytes() == first
    batch = variants([("a", _scene())], [parse_vary("groom.density=builtin:scalp,0.5")], None)
    mixed = run_batch(batch, tmp_path / "m", Outputs(None, image=False), manifest="parquet")
    assert pq.read_table(mixed).column("groom.density").to_pylist() == ["builtin:scalp", "0.5"]


def test_a_parquet_manifest_without_pyarrow_is_refused_before_the_batch(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import pyarrow raises ImportError
    batch = variants([("a", _scene())], [], range(2))
    with pytest.raises(ConfigError, match="needs pyarrow; pip install pyarrow"):
        run_batch(batch, tmp_path / "b", Outputs(None, image=False), manifest="parquet")
    assert not (tmp_path / "b").exists()


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("0:100000000000000000000", "0 <= A < B <= 2^63"),  # len(range) would overflow
        ("0:" + "9" * 5000, "0 <= A < B <= 2^63"),
        ("0:1000000", "more than 100,000 variants"),
        ("5:", "0 <= A < B"),
    ],
)
def test_seed_ranges_too_large_for_a_batch_are_refused(text, words):
    with pytest.raises(ConfigError, match=f"^--seeds .*{re.escape(words)}"):
        parse_seeds(text)


@pytest.mark.parametrize(
    "spec",
    ["1" + "0" * 400 + ":2:3", "0:1" + "0" * 400 + ":3", "-1" + "0" * 30 + ":0:2"],
)
def test_sweep_bounds_with_hundreds_of_digits_are_refused(spec):
    with pytest.raises(ConfigError, match=r"^--vary groom\.curl_radius=.{0,80}: START and STOP"):
        parse_vary(f"groom.curl_radius={spec}")


@pytest.mark.parametrize(
    ("arg", "message"),
    [
        (
            "groom.curl=0.001,0.002",
            "--vary groom.curl: [groom].curl: unknown key; did you mean"
            " curl_radius or curl_frequency or curl_frequency_tip?",
        ),
        ("gromm.count=5,6", "--vary gromm.count: [gromm]: unknown section; did you mean [groom]?"),
        (
            "kink_tip=0.001,0.002",
            "--vary kink_tip: expected section.key; did you mean groom.kink_tip?",
        ),
        ("groom.zzz=1,2", "--vary groom.zzz: [groom].zzz: unknown key; allowed keys: count, seed,"),
    ],
)
def test_an_unknown_swept_key_says_what_was_meant(arg, message):
    """The command line's override (`follicle batch --vary section.key=…`) says what was
    meant, as a scene file's unknown key does (issue 46)."""
    with pytest.raises(ConfigError) as err:
        parse_vary(arg)
    assert str(err.value).startswith(message), str(err.value)


def test_a_batch_past_the_cap_is_refused_before_any_variant_is_made(tmp_path):
    """Two sweeps of 1,000 values: a million variants, refused from the sizes alone in a
    child under the memory limit (built first, they were gigabytes: a scene each)."""
    res = run_api(
        """
        from follicle.distributed.batch import parse_vary, variants
        from follicle.scene import Scene
        sweeps = [parse_vary("groom.curl_radius=0.001:0.01:1000"),
                  parse_vary("groom.kink_tip=0.001:0.003:1000")]
        variants([("default", Scene())], sweeps)
        """,
        tmp_path,
        timeout=60,
    )
    assert_api_refused(res, "1,000,000 variants", "more than 100,000", error="ConfigError")


@pytest.mark.slow
def test_the_cli_refuses_huge_seeds_and_sweeps_in_one_line_on_a_terminal(tmp_path):
    for args in (
        ("--seeds", "0:100000000000000000000"),
        ("--vary", "groom.curl_radius=1" + "0" * 400 + ":2:3"),
    ):
        out = run_cli("batch", "-o", "b", *args, cwd=tmp_path, tty=True, timeout=60)
        assert out.rc == 2 and "Traceback" not in out.stdout, out.stdout[-2000:]
        plain = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", out.stdout)  # the terminal's colours
        lines = [line for line in plain.splitlines() if line.strip()]
        assert len(lines) == 1 and "error: " in lines[0] and args[0] in lines[0], out.stdout
    assert not (tmp_path / "b").exists()


def test_a_url_sweep_is_values_not_a_range() -> None:
    """A value with :// (a URL, whose port has a colon) is one value, never START:STOP:N."""
    one = "http://127.0.0.1:8000/head.obj"
    assert parse_vary(f"mesh.path={one}").values == (one,)
    two = f"{one},s3://bucket/b.obj"
    assert parse_vary(f"mesh.path={two}").values == (one, "s3://bucket/b.obj")
    assert parse_vary("groom.count=10:30:3").values == (10, 20, 30)


@pytest.mark.parametrize("tty", [False, True])
@pytest.mark.slow
def test_the_manifest_never_replaces_an_input_in_the_batch_folder(tmp_path, tty) -> None:
    """A scene (or a file it reads) in the batch folder under the manifest's name is one
    line naming it, before any variant is made; the folder stays as it was."""
    from hostile import assert_cli_refused, run_cli, warm

    ds = tmp_path / "ds"
    ds.mkdir()
    (ds / "manifest.csv").write_text("[groom]\ncount = 50\n")  # a scene, as its name says not
    (ds / "scene.toml").write_text('[groom]\ncount = 50\ndensity = "manifest.parquet"\n')
    (ds / "manifest.parquet").write_bytes(b"\x89PNG, say")
    before = {p.name: p.read_bytes() for p in ds.iterdir()}
    warm()
    for args, names in (
        (["ds/manifest.csv", "-o", "ds"], ["manifest.csv", "would replace the scene"]),
        (["ds/scene.toml", "-o", "ds", "--manifest", "parquet"], ["[groom].density"]),
    ):
        out = run_cli("batch", *args, "--no-image", "--curves", "none", cwd=tmp_path, tty=tty)
        if tty:
            assert out.rc == 2 and "Traceback" not in out.stdout, out.stdout
            assert all(name in out.stdout for name in names), out.stdout
        else:
            assert_cli_refused(out, *names)
    assert {p.name: p.read_bytes() for p in ds.iterdir()} == before
    swept = variants([("a", _scene())], [parse_vary(f"mesh.path={ds}/manifest.csv")])
    with pytest.raises(
        FollicleError, match=r"manifest.csv: the output would replace .*\[mesh\].path"
    ):
        run_batch(swept, ds, Outputs(None, image=False))
    assert {p.name: p.read_bytes() for p in ds.iterdir()} == before


@pytest.mark.slow
def test_a_stopped_batch_says_which_variants_it_kept(tmp_path) -> None:
    """SIGTERM after a variant is made: exit 143, and the line says the finished variants
    are kept in the folder (not "no output was written"); they are there, whole."""
    import signal
    import subprocess
    import time

    from hostile import FOLLICLE, warm

    (tmp_path / "s.toml").write_text("[groom]\ncount = 30000\n")
    warm()
    proc = subprocess.Popen(
        [*FOLLICLE, "batch", "s.toml", "-o", "ds", "--seeds", "0:40", "--no-image"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 120
    while not (tmp_path / "ds" / "v00001").is_dir():
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    line = err.decode().strip()
    kept = sorted(p.name for p in (tmp_path / "ds").iterdir())
    assert kept[:2] == ["v00000", "v00001"] and "manifest.csv" not in kept
    assert line.startswith("error: stopped by SIGTERM; kept the variants finished"), line
    assert "of 40, in ds" in line and "no output was written" not in line, line
    assert len(line.splitlines()) == 1
