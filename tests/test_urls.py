"""Inputs read from URLs (issue: beyond one machine): a scene served over HTTP — its
mesh, guides and textures beside it — grows the same bytes as the scene on disk, in
one process and on a LocalCluster whose workers fetch the files themselves; a fetched
file is kept and fetched again only when it changes; a missing file, an unknown
protocol or a server that does not answer is one clean refusal."""

from __future__ import annotations

import functools
import http.server
import threading

import numpy as np
import pytest
from PIL import Image

from follicle.errors import ConfigError, FormatError
from follicle.inputs import input_file, is_url
from follicle.io.dispatch import load_curves, save
from follicle.io.mesh_load import load_mesh
from follicle.io.mesh_save import save_mesh
from follicle.scene import load_scene
from hostile import assert_cli_refused, run_cli, warm

SCENE = """[mesh]
path = "head.obj"

[guides]
path = "guides.hair"

[groom]
count = 2000
density = "density.png"
root_color = "color.png"
"""


class _Quiet(http.server.SimpleHTTPRequestHandler):
    """A file server that counts the files it sends instead of logging them."""

    sent: list[str]

    def do_GET(self):  # noqa: N802 - the name http.server calls
        self.sent.append(self.path)
        super().do_GET()

    def log_message(self, *args):
        pass


@pytest.fixture
def served(tmp_path, monkeypatch):
    """A scene folder served on a local port: (folder, base URL, paths sent)."""
    from follicle.groom.builtin_guides import builtin_guides

    folder = tmp_path / "site"
    folder.mkdir()
    (folder / "s.toml").write_text(SCENE)
    save_mesh(load_mesh("builtin:head"), folder / "head.obj")
    save(builtin_guides("short"), folder / "guides.hair")
    ramp = np.linspace(0, 255, 64 * 64).reshape(64, 64).astype(np.uint8)
    Image.fromarray(ramp).save(folder / "density.png")
    Image.fromarray(np.dstack([ramp, ramp[::-1], ramp.T])).save(folder / "color.png")
    sent: list[str] = []
    handler = type("Handler", (_Quiet,), {"sent": sent})
    server = http.server.ThreadingHTTPServer(
        ("127.0.0.1", 0), functools.partial(handler, directory=str(folder))
    )
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    monkeypatch.setenv("FOLLICLE_CACHE", str(tmp_path / "cache"))
    yield folder, f"http://127.0.0.1:{server.server_address[1]}", sent
    server.shutdown()
    server.server_close()


def test_a_url_is_fetched_once_and_again_when_it_changes(served, tmp_path):
    folder, url, sent = served
    copy = input_file(f"{url}/density.png")
    assert copy.read_bytes() == (folder / "density.png").read_bytes()
    assert copy.name == "density.png" and copy.is_relative_to(tmp_path / "cache")
    assert input_file(f"{url}/density.png") == copy
    assert sent.count("/density.png") == 1  # the second asked the size, not the bytes
    Image.fromarray(np.zeros((8, 8), np.uint8)).save(folder / "density.png")
    again = input_file(f"{url}/density.png")
    assert again != copy and again.read_bytes() == (folder / "density.png").read_bytes()
    assert sent.count("/density.png") == 2


def test_bad_urls_are_refused_naming_them(served):
    _, url, _ = served
    for bad, says in (
        (f"{url}/nothing.png", "no such file"),
        ("nosuchprotocol://host/a.png", "nosuchprotocol"),
        ("http://127.0.0.1:9/a.png", "cannot be read"),  # the discard port: refused
    ):
        with pytest.raises(FormatError) as err:
            input_file(bad, "image")
        assert bad.split("://")[0] in str(err.value) and says in str(err.value)


def test_a_file_url_is_read_in_place(served):
    folder, _, _ = served
    assert input_file(f"file://{folder}/s.toml") == folder / "s.toml"
    assert is_url("s3://bucket/a.abc") and not is_url("builtin:head") and not is_url("a/b.png")


def test_a_served_scene_grows_the_bytes_of_the_scene_on_disk(served, tmp_path):
    """`follicle grow URL` (relative paths inside become URLs beside it) in one process
    and on two workers, each fetching the files into its own cache: the file written
    from disk, byte for byte."""
    folder, url, sent = served
    scene = load_scene(f"{url}/s.toml")
    assert scene.resolve(scene.mesh.path) == f"{url}/head.obj"
    warm()
    local = run_cli("grow", folder / "s.toml", "-o", tmp_path / "disk.usdc", cwd=tmp_path)
    assert local.rc == 0, local.stderr
    env = {"FOLLICLE_CACHE": str(tmp_path / "cache-one")}
    one = run_cli("grow", f"{url}/s.toml", "-o", tmp_path / "one.usdc", cwd=tmp_path, env=env)
    assert one.rc == 0, one.stderr
    env = {"FOLLICLE_CACHE": str(tmp_path / "cache-many")}
    many = run_cli(
        "grow",
        f"{url}/s.toml",
        "-o",
        tmp_path / "many.usdc",
        "--scheduler",
        "local:2",
        "--chunk",
        "700",
        cwd=tmp_path,
        env=env,
        timeout=120,
        memory=8 << 30,
    )  # fmt: skip  (a client and its cluster map more than the default 2 GiB)
    assert many.rc == 0, many.stderr
    want = (tmp_path / "disk.usdc").read_bytes()
    assert (tmp_path / "one.usdc").read_bytes() == want
    assert (tmp_path / "many.usdc").read_bytes() == want
    assert load_curves(tmp_path / "one.usdc").curve_count == 2000
    for name in ("head.obj", "guides.hair", "density.png", "color.png"):
        assert any((tmp_path / "cache-many").rglob(name)), name
    assert {"/head.obj", "/guides.hair", "/density.png", "/color.png"} <= set(sent)


def test_a_missing_served_file_is_one_line(served, tmp_path):
    folder, url, _ = served
    (folder / "color.png").unlink()
    out = run_cli("grow", f"{url}/s.toml", "-o", tmp_path / "h.usdc", cwd=tmp_path)
    line = assert_cli_refused(out, f"{url}/color.png")
    assert "no such file" in line
    assert not any(tmp_path.glob("*h.usdc*"))


def test_a_served_groom_exports_the_bytes_of_the_file_on_disk(served, tmp_path):
    """`follicle export URL -o …` and a folder of URLs (`export_files`): the bytes the
    files on disk give."""
    from follicle.distributed_export import convert, export_files

    folder, url, _ = served
    convert(folder / "guides.hair", tmp_path / "disk.abc")
    convert(f"{url}/guides.hair", tmp_path / "one.abc")
    guides = load_curves(folder / "guides.hair")
    done = export_files([f"{url}/guides.hair"], [tmp_path / "out" / "guides.abc"])
    assert done == [(guides.curve_count, guides.point_count)]
    want = (tmp_path / "disk.abc").read_bytes()
    assert (tmp_path / "one.abc").read_bytes() == want
    assert (tmp_path / "out" / "guides.abc").read_bytes() == want


@pytest.mark.parametrize(
    ("line", "key"),
    [
        ('[mesh]\npath = "{local}/head.obj"\n', "[mesh].path"),
        ('[mesh]\npath = "file://{local}/head.obj"\n', "[mesh].path"),
        ('[mesh]\npath = "head.obj"\n[guides]\npath = "{local}/guides.hair"\n', "[guides].path"),
        ('[mesh]\npath = "head.obj"\n[groom]\ndensity = "{local}/density.png"\n', "density"),
        ('[mesh]\npath = "head.obj"\n[groom]\nroot_color = "file://{local}/c.png"\n', "color"),
        ('[mesh]\npath = "http://127.0.0.1:9/head.obj"\n', "[mesh].path"),
    ],
)
def test_a_served_scene_reads_nothing_but_files_beside_it(served, tmp_path, line, key):
    """A scene fetched from a server may not name this machine's files (an absolute path,
    a file:// URL) nor another server's: one line naming the key, and the local file,
    a whole mesh that would grow, is never read."""
    folder, url, _ = served
    local = tmp_path / "local"
    local.mkdir()
    for name in ("head.obj", "guides.hair", "density.png"):
        (local / name).write_bytes((folder / name).read_bytes())
    (local / "c.png").write_bytes((folder / "color.png").read_bytes())
    (folder / "evil.toml").write_text(line.format(local=local))
    warm()
    out = run_cli("grow", f"{url}/evil.toml", "-o", tmp_path / "h.npz", cwd=tmp_path)
    got = assert_cli_refused(out, f"{url}/evil.toml", key)
    assert "own server" in got
    assert not (tmp_path / "h.npz").exists()
    with pytest.raises(ConfigError, match="own server"):
        load_scene(f"{url}/evil.toml")


def test_a_served_scene_writes_its_default_outputs_in_the_current_folder(served, tmp_path):
    """`follicle grow URL` and `follicle render URL` without -o write the scene's
    [output] file names in the current folder (a local scene's are beside it), never a
    folder named after the URL, nor where the remote scene's [output] points."""
    folder, url, _ = served
    (folder / "out.toml").write_text(
        SCENE.replace("count = 2000", "count = 100")
        + f'[output]\ncurves = "{tmp_path}/elsewhere/h.npz"\nimage = "../pic.png"\n'
        + "[render]\nsize = [32, 32]\n"
    )
    work = tmp_path / "work"
    work.mkdir()
    warm()
    for tty in (False, True):
        grown = run_cli("grow", f"{url}/s.toml", "--count", 100, cwd=work, tty=tty)
        assert grown.rc == 0, grown.stdout + grown.stderr
        assert sorted(p.name for p in work.iterdir()) == ["hair.npz"]
        assert load_curves(work / "hair.npz").curve_count == 100
        (work / "hair.npz").unlink()
    assert run_cli("grow", f"{url}/out.toml", cwd=work).rc == 0
    assert run_cli("render", f"{url}/out.toml", cwd=work).rc == 0
    assert sorted(p.name for p in work.iterdir()) == ["h.npz", "pic.png"]
    assert not (tmp_path / "elsewhere").exists() and not (tmp_path / "pic.png").exists()
    rendered = run_cli("render", f"{url}/guides.hair", cwd=work)
    assert rendered.rc == 0, rendered.stderr
    assert sorted(p.name for p in work.iterdir()) == ["guides.png", "h.npz", "pic.png"]


def test_a_skin_animation_url_is_fetched_like_every_url_input(served, tmp_path):
    """`follicle simulate --skin-animation URL`: fetched, not read as a local path."""
    from test_skin_animation import _frames, _usd

    folder, url, sent = served
    head = load_mesh(folder / "head.obj")
    _usd(folder / "anim.usdc", _frames(head.rest_vertices, 4), head.faces)
    (tmp_path / "s.toml").write_text('[groom]\ncount = 50\n[guides]\npath = "builtin:short"\n')
    warm()
    for tty in (False, True):
        out = run_cli(
            "simulate", "s.toml", "--skin-animation", f"{url}/anim.usdc", "--frames", 3,
            "-o", "sim.npz", cwd=tmp_path, tty=tty, timeout=120,
        )  # fmt: skip
        assert out.rc == 0, out.stdout + out.stderr
        assert "skin animation" in out.stdout
    assert "/anim.usdc" in sent
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache", "s.toml", "sim.npz", "site"]
