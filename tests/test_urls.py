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

from follicle.errors import FormatError
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
