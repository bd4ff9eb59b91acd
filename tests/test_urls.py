"""Inputs read from URLs (issue: beyond one machine): a scene served over HTTP — its
mesh, guides and textures beside it — grows the same bytes as the scene on disk, in
one process and on a LocalCluster whose workers fetch the files themselves; a fetched
file is kept and fetched again only when it changes; a missing file, an unknown
protocol or a server that does not answer is one clean refusal."""

from __future__ import annotations

import functools
import http.server
import socketserver
import threading
import time

import numpy as np
import pytest
from PIL import Image

from follicle.errors import ConfigError, FileAccessError, FormatError
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


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
def test_a_file_url_is_read_in_place(served):
    folder, _, _ = served
    assert input_file(f"file://{folder}/s.toml") == folder / "s.toml"
    assert is_url("s3://bucket/a.abc") and not is_url("builtin:head") and not is_url("a/b.png")


@pytest.mark.slow
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


@pytest.mark.slow
def test_a_missing_served_file_is_one_line(served, tmp_path):
    folder, url, _ = served
    (folder / "color.png").unlink()
    out = run_cli("grow", f"{url}/s.toml", "-o", tmp_path / "h.usdc", cwd=tmp_path)
    line = assert_cli_refused(out, f"{url}/color.png")
    assert "no such file" in line
    assert not any(tmp_path.glob("*h.usdc*"))


@pytest.mark.slow
def test_a_served_groom_exports_the_bytes_of_the_file_on_disk(served, tmp_path):
    """`follicle export URL -o …` and a folder of URLs (`export_files`): the bytes the
    files on disk give."""
    from follicle.distributed.export import convert, export_files

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
@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
def test_a_skin_animation_url_is_fetched_like_every_url_input(served, tmp_path):
    """`follicle simulate --skin-animation URL`: fetched, not read as a local path."""
    from test_skin_animation import _frames, _usd

    folder, url, sent = served
    head = load_mesh(folder / "head.obj")
    _usd(folder / "anim.usdc", _frames(head.rest_vertices, 4), head.faces)
    skin = f'[mesh]\npath = "{folder / "head.obj"}"\n'  # the skin the animation moves
    (tmp_path / "s.toml").write_text(
        f'{skin}[groom]\ncount = 50\n[guides]\npath = "builtin:short"\n'
    )
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


class _Hostile(socketserver.BaseRequestHandler):
    """A server that misbehaves by the path asked for: /trickle.* sends a 1 MiB body a
    byte every 50 ms, /headers.* sends headers without end, /silent.* never answers,
    /endless.* streams zeros without a length, /liar.* declares a terabyte."""

    gets: list[str]

    def handle(self) -> None:
        request = b""
        while b"\r\n\r\n" not in request:
            more = self.request.recv(4096)
            if not more:
                return
            request += more
        method, path = request.split(b" ", 2)[:2]
        kind = path.decode().strip("/").split(".")[0]
        if method == b"GET":
            self.gets.append(kind)
        send = self.request.sendall
        try:
            if kind == "silent":
                time.sleep(30)
            elif kind == "headers":
                send(b"HTTP/1.1 200 OK\r\n")
                for i in range(600):
                    send(b"X-More-%d: yes\r\n" % i)
                    time.sleep(0.05)
            elif kind == "liar":
                send(b"HTTP/1.1 200 OK\r\nContent-Length: 1000000000000\r\n\r\n")
                if method == b"GET":
                    send(bytes(1 << 16))
            elif kind == "endless":
                send(b"HTTP/1.1 200 OK\r\nConnection: close\r\n\r\n")
                if method == b"GET":
                    for _ in range(1 << 16):  # 4 GiB at most, should no one stop reading
                        send(bytes(1 << 16))
            else:  # trickle
                send(b"HTTP/1.1 200 OK\r\nContent-Length: 1048576\r\n\r\n")
                if method == b"GET":
                    for _ in range(600):
                        send(b"#")
                        time.sleep(0.05)
        except OSError:  # the client left: what a watched fetch does
            pass


@pytest.fixture
def hostile_server(tmp_path, monkeypatch):
    """(base URL, kinds fetched with GET) of a :class:`_Hostile` server; fetches wait
    1 s for 16 KiB and are kept in tmp_path/cache."""
    gets: list[str] = []
    server = socketserver.ThreadingTCPServer(
        ("127.0.0.1", 0), type("Handler", (_Hostile,), {"gets": gets})
    )
    server.daemon_threads = True
    threading.Thread(target=server.serve_forever, daemon=True).start()
    monkeypatch.setenv("FOLLICLE_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("FOLLICLE_URL_TIMEOUT", "1")
    yield f"http://127.0.0.1:{server.server_address[1]}", gets
    server.shutdown()
    server.server_close()


def _cached(tmp_path) -> list[str]:
    return sorted(p.name for p in (tmp_path / "cache").rglob("*") if p.is_file())


@pytest.mark.parametrize(
    ("kind", "says"),
    [("trickle", "sent 2"), ("headers", "sent nothing"), ("silent", "sent nothing")],
)
@pytest.mark.slow
def test_a_server_too_slow_or_silent_is_left_within_the_timeout(
    hostile_server, tmp_path, kind, says
):
    """A body that trickles (20 bytes a second), headers that never end and a server
    that accepts but never speaks are each one FileAccessError within about the timeout
    (1 s here), and nothing stays in the cache."""
    url, _ = hostile_server
    start = time.monotonic()
    with pytest.raises(FileAccessError, match="FOLLICLE_URL_TIMEOUT") as err:
        input_file(f"{url}/{kind}.png", "image")
    assert time.monotonic() - start < 6
    assert str(err.value).startswith(f"{url}/{kind}.png: the server {says}")
    time.sleep(0.3)  # the fetching thread, told to stop, removes what it began
    assert _cached(tmp_path) == []


def test_a_download_stops_at_the_readers_size_limit(hostile_server, tmp_path, monkeypatch):
    """An endless body stops at the reader's limit (a scene's 1 MiB, a stroke log's
    64 MiB) or at $FOLLICLE_MAX_DOWNLOAD, not at the disk's end; a declared size past
    the limit is refused before the body is asked for."""
    from follicle.editing.strokes import MAX_BYTES, load_strokes
    from follicle.scene import MAX_SCENE_BYTES

    url, gets = hostile_server
    with pytest.raises(FormatError, match=f"more than the {MAX_SCENE_BYTES:,} bytes a scene"):
        load_scene(f"{url}/endless.toml")
    with pytest.raises(FormatError, match=f"more than the {MAX_BYTES:,} bytes a stroke log"):
        load_strokes(f"{url}/endless.json")
    monkeypatch.setenv("FOLLICLE_MAX_DOWNLOAD", "3e6")
    with pytest.raises(FormatError, match=r"more than the 3,000,000 bytes .*FOLLICLE_MAX_DOWN"):
        load_mesh(f"{url}/endless.obj")
    with pytest.raises(
        FormatError, match="liar.obj: 1,000,000,000,000 bytes, more than the 3,000,000"
    ):
        load_mesh(f"{url}/liar.obj")
    assert "endless" in gets and "liar" not in gets  # the liar's body never asked for
    assert _cached(tmp_path) == []
    monkeypatch.setenv("FOLLICLE_MAX_DOWNLOAD", "lots")
    with pytest.raises(ConfigError, match=r"\$FOLLICLE_MAX_DOWNLOAD='lots': give bytes"):
        load_mesh(f"{url}/endless.obj")
    monkeypatch.delenv("FOLLICLE_MAX_DOWNLOAD")
    monkeypatch.setenv("FOLLICLE_URL_TIMEOUT", "-1")
    with pytest.raises(ConfigError, match=r"\$FOLLICLE_URL_TIMEOUT='-1': give a number"):
        load_mesh(f"{url}/endless.obj")


@pytest.mark.parametrize("tty", [False, True])
@pytest.mark.slow
def test_the_cli_leaves_a_slow_server_in_one_line(hostile_server, tmp_path, tty):
    """`follicle grow URL` from a server whose body trickles, under a pseudo-terminal
    too: one line naming the URL and the setting, exit 2, nothing written."""
    url, _ = hostile_server
    env = {"FOLLICLE_URL_TIMEOUT": "1", "FOLLICLE_CACHE": str(tmp_path / "cache")}
    out = run_cli("grow", f"{url}/trickle.toml", "-o", "h.npz", cwd=tmp_path, tty=tty, env=env)
    assert_cli_refused(out, f"{url}/trickle.toml", "FOLLICLE_URL_TIMEOUT")
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "cache") == []


@pytest.mark.slow
def test_a_served_stroke_log_names_files_beside_it_only(served, tmp_path):
    """A stroke log fetched from a server names guides and a mesh on its own server
    (relative paths become URLs beside it), never a file of this machine."""
    from follicle.editing.editor import replay_file
    from follicle.errors import InputError

    folder, url, sent = served
    local = tmp_path / "mine.hair"
    local.write_bytes((folder / "guides.hair").read_bytes())
    log = '{{"follicle_strokes": 1, "guides": "{g}", "mesh": "head.obj", "strokes": []}}'
    (folder / "near.json").write_text(log.format(g="guides.hair"))
    (folder / "far.json").write_text(log.format(g=local))
    editor = replay_file(f"{url}/near.json")
    assert editor.guides.curves.curve_count > 0
    assert "/guides.hair" in sent and "/head.obj" in sent
    with pytest.raises(InputError, match=f"far.json: guides: {local} is a path of this machine"):
        replay_file(f"{url}/far.json")


def test_a_download_leaves_the_cache_disk_a_gibibyte_free(hostile_server, tmp_path, monkeypatch):
    """An endless body under the size limit stops where the cache's disk would keep
    less than 1 GiB free (here: made to leave 2 MB of room), and says where and how to
    make room; nothing stays in the cache."""
    import shutil

    import follicle.inputs as inputs

    url, _ = hostile_server
    (tmp_path / "cache").mkdir()
    free = shutil.disk_usage(tmp_path / "cache").free
    monkeypatch.setattr(inputs, "_KEEP_FREE", free - (2 << 20))
    with pytest.raises(FileAccessError) as err:
        load_mesh(f"{url}/endless.obj")
    line = str(err.value)
    assert line.startswith(f"{url}/endless.obj: past ") and "would keep less than 1 GiB" in line
    assert "$FOLLICLE_CACHE" in line and "\n" not in line
    assert _cached(tmp_path) == []


@pytest.mark.slow
def test_a_batch_of_a_served_scene_names_its_url_in_each_variant(served, tmp_path):
    import csv

    from follicle.distributed.batch import plan_batch

    _, url, _ = served
    job = plan_batch([f"{url}/s.toml"], tmp_path / "b", seeds="0:2", count=50, image=False)
    manifest = job.run()
    first = (tmp_path / "b" / "v00000" / "scene.toml").read_text().splitlines()[0]
    assert first.endswith(f"relative paths start in {url}")  # the server's folder, as given
    rows = list(csv.DictReader(manifest.open()))
    assert [row["seed"] for row in rows] == ["0", "1"] and rows[0]["hairs"] == "50"
