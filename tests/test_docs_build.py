"""The docs site builds strictly (a warning, a broken link or anchor, a page left out of
the navigation, a failing tutorial or example fails, as `mkdocs.yml` and
tools/mkdocs_hooks.py set), its pages find every picture they show — on disk, over HTTP
from the served site, and in a real browser (headless Chromium) —, the gallery shows a
picture the build rendered for every example, and the README's and CHANGELOG's links
point at files that exist."""

from __future__ import annotations

import functools
import html
import http.server
import os
import re
import shutil
import subprocess
import sys
import threading
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import unquote, urljoin, urlsplit

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    done = _build(ROOT, out)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-5000:]
    return out


@pytest.mark.slow
def test_the_docs_build_strictly_with_the_generated_reference(site: Path):
    scene = (site / "reference" / "scene" / "index.html").read_text(encoding="utf-8")
    assert "frizz_tip" in scene and "m/s²" in scene
    cli = (site / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    assert "follicle export-rib" in cli
    api = (site / "reference" / "api" / "index.html").read_text(encoding="utf-8")
    assert "HairCurves" in api and "from_polylines" in api  # a method's docstring
    assert "generate</code>" in api and not re.search(r":(meth|class|func|data):<code>", api)
    errors = (site / "reference" / "errors" / "index.html").read_text(encoding="utf-8")
    assert "ResourceError" in errors and "more memory or time" in errors


@pytest.mark.slow
def test_every_picture_on_every_page_is_there(site: Path):
    pages = list(site.rglob("*.html"))
    assert len(pages) > 30
    shown = set()
    for page in pages:
        for src in re.findall(r'<img[^>]*\ssrc="([^"]+)"', page.read_text(encoding="utf-8")):
            if urlsplit(src).scheme:
                continue
            target = (page.parent / unquote(urlsplit(src).path)).resolve()
            assert target.is_file(), f"{page.relative_to(site)}: {src}"
            shown.add(target.relative_to(site.resolve()))
    pictures = {p.relative_to(ROOT / "docs") for p in (ROOT / "docs").rglob("*.png")}
    assert pictures - shown == set(), "pictures in docs/ that no page shows"


def _build(
    config_dir: Path, out: Path, tutorials: bool = True, gallery: bool = True
) -> subprocess.CompletedProcess:
    """``mkdocs build --strict``; ``tutorials`` (``gallery``) False builds the tutorials'
    (the gallery's) pages without running them (FOLLICLE_DOCS_TUTORIALS=0,
    FOLLICLE_DOCS_GALLERY=0, tools/docs_runs.py) where a test needs no more."""
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    env["FOLLICLE_DOCS_TUTORIALS"] = "1" if tutorials else "0"
    env["FOLLICLE_DOCS_GALLERY"] = "1" if gallery else "0"
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=config_dir,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


def _with_project(root: Path) -> None:
    """What the docs' hook reads beside mkdocs.yml: pyproject's [project.urls] (the
    site's address and repository) through build_support/readme_links.py."""
    shutil.copy(ROOT / "pyproject.toml", root)
    shutil.copytree(ROOT / "build_support", root / "build_support")


@pytest.mark.slow
def test_a_broken_link_fails_the_build(tmp_path: Path):
    """The strictness is real: the same site with one link to a page that is not there
    does not build."""
    shutil.copytree(ROOT / "docs", tmp_path / "docs")
    shutil.copytree(ROOT / "tools", tmp_path / "tools")
    _with_project(tmp_path)
    shutil.copy(ROOT / "mkdocs.yml", tmp_path)
    (tmp_path / "src").symlink_to(ROOT / "src")
    page = tmp_path / "docs" / "how-to" / "grooming.md"
    page.write_text(page.read_text(encoding="utf-8") + "\n[gone](no-such-page.md)\n")
    done = _build(tmp_path, tmp_path / "site", tutorials=False, gallery=False)
    assert done.returncode != 0
    assert "no-such-page.md" in done.stderr + done.stdout


@pytest.mark.slow
def test_a_failing_tutorial_fails_the_build(tmp_path: Path):
    """A tutorial is run by the build: one whose command fails stops the build, naming
    the tutorial and the command."""
    shutil.copytree(ROOT / "docs", tmp_path / "docs")
    shutil.copytree(ROOT / "tools", tmp_path / "tools")
    _with_project(tmp_path)
    shutil.copy(ROOT / "mkdocs.yml", tmp_path)
    (tmp_path / "src").symlink_to(ROOT / "src")
    for script in (tmp_path / "docs" / "tutorials").glob("*.py"):
        if script.name != "game_engines.py":
            script.write_text('"""Stand-in\n\nNot run here."""\n', encoding="utf-8")
    script = tmp_path / "docs" / "tutorials" / "game_engines.py"
    text = script.read_text(encoding="utf-8")
    script.write_text(
        text.replace('groom_unity.abc --target unity")', 'groom_unity.abc --count -5")')
    )
    done = _build(tmp_path, tmp_path / "site", gallery=False)
    assert done.returncode != 0
    assert "game_engines.py" in done.stderr and "groom_unity.abc --count -5" in done.stderr


@pytest.mark.slow
@pytest.mark.parametrize(
    ("scene", "file", "old", "new", "command"),
    [
        # the scene itself: its render fails (a negative hair count)
        ("curly", "curly.toml", "count = 13000", "count = -5",
         "follicle render examples/curly.toml -o curly.png --size 360 360 --engine cpu"),
        # a script the scene's comment says to run first: the build runs it too
        ("hand_groomed", "hand_groomed.py", "    groom(editor)\n", "    groom(editor)\n    1 / 0\n",
         ".venv/bin/python examples/hand_groomed.py"),
    ],
)  # fmt: skip
def test_a_failing_example_fails_the_build(tmp_path: Path, scene, file, old, new, command):
    """The gallery's examples are run by the build: one whose command fails stops the
    build, naming the scene and the command (the other scenes are left out here)."""
    shutil.copytree(ROOT / "docs", tmp_path / "docs")
    shutil.copytree(ROOT / "tools", tmp_path / "tools")
    _with_project(tmp_path)
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    shutil.copy(ROOT / "mkdocs.yml", tmp_path)
    (tmp_path / "src").symlink_to(ROOT / "src")
    for other in (tmp_path / "examples").glob("*.toml"):
        if other.stem != scene:
            other.unlink()
    broken = tmp_path / "examples" / file
    text = broken.read_text(encoding="utf-8")
    assert old in text
    broken.write_text(text.replace(old, new), encoding="utf-8")
    done = _build(tmp_path, tmp_path / "site", tutorials=False)
    assert done.returncode != 0
    assert f"examples/{scene}.toml" in done.stderr and f"`{command}` exited" in done.stderr


# the gallery's pictures: its page shows each example's, from examples/NAME.png in the site
_GALLERY_PICTURE = re.compile(r'<img[^>]*\ssrc="\.\./examples/([\w-]+)\.png"')


@pytest.mark.slow
def test_the_gallery_shows_every_example_rendered_by_the_build(site: Path):
    """The gallery page shows one picture per scene of examples/, each made by this build
    (no examples/ pictures are in docs/), 360² and a real render: something covers much
    of it (pixels far from the background's colour in the corner) and the middle has the
    fine detail of strands (a blank, flat or gradient picture has none), with the
    command that made it and the scene file's text."""
    from PIL import Image

    scenes = sorted(p.stem for p in (ROOT / "examples").glob("*.toml"))
    assert len(scenes) >= 7
    assert not list((ROOT / "docs").rglob("examples/*.png")), "gallery pictures are built"
    page = (site / "gallery" / "index.html").read_text(encoding="utf-8")
    shown = _GALLERY_PICTURE.findall(page)
    assert sorted(shown) == scenes  # each once
    text = html.unescape(re.sub(r"<[^>]+>", "", page))
    for name in scenes:
        command = f"follicle render examples/{name}.toml -o {name}.png --size 360 360 --engine cpu"
        assert command in text, name
        seed = re.search(r"^seed = \d+$", (ROOT / "examples" / f"{name}.toml").read_text(), re.M)
        assert seed and seed.group(0) in text, name  # the scene file's text, shown
        with Image.open(site / "examples" / f"{name}.png") as img:
            assert img.size == (360, 360), name
            rgb = np.asarray(img.convert("RGB"), dtype=np.int16)
        covered = (np.abs(rgb - rgb[0, 0]).max(axis=2) > 40).mean()
        assert covered > 0.3, (name, covered)
        grey = rgb.mean(axis=2)
        detail = np.abs(np.diff(grey[90:270, 90:270], axis=1)).mean()
        assert detail > 2.0, (name, detail)
    assert ".venv/bin/python examples/hand_groomed.py" in text  # a scene's script, run


def test_the_readme_and_changelog_link_to_files_that_exist():
    for name in ("README.md", "CHANGELOG.md"):
        text = (ROOT / name).read_text(encoding="utf-8")
        links = re.findall(r"\]\(([^)\s]+)\)", text)
        assert links, name
        for link in links:
            if urlsplit(link).scheme:
                continue
            assert (ROOT / link.split("#")[0]).exists(), f"{name}: {link}"


def test_the_readme_is_short_and_starts_with_the_two_commands():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 150
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert lines[2] == "```bash" and lines[4] in ci  # .ci/run runs the second verbatim
    assert lines[3].endswith("follicle demo")
    text = "\n".join(lines)
    assert not re.search(r"\bissue \d+|\blanded\b|\btarget \d", text, re.IGNORECASE), "dev log"


def _toml_blocks() -> list[tuple[Path, str]]:
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    return [
        (page, block)
        for page in pages
        for block in re.findall(r"```toml\n(.*?)```", page.read_text(encoding="utf-8"), re.S)
    ]


def test_the_scenes_the_docs_show_are_valid_and_name_real_keys():
    """Each TOML block of the docs is a scene the loader takes, and each key it names in
    a comment (`# frizz_tip = 0.01`: what a reader may set) is a key of its table."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10, as follicle.scene reads TOML there
        import tomli as tomllib

    from tools.docs_reference import scene_tables

    from follicle.scene import parse_scene

    tables = {name.strip("[]"): model for name, model in scene_tables()}
    blocks = _toml_blocks()
    assert len(blocks) >= 2
    named = 0
    for page, block in blocks:
        parse_scene(tomllib.loads(block), source=str(page))  # ConfigError names the key
        table = None
        for line in block.splitlines():
            header = re.match(r"^(?:# )?\[\[?([a-z.]+)\]\]?", line)
            if header:
                table = header.group(1)
            commented = re.match(r"^# ([a-z_]+) = ", line)
            if commented:
                assert table in tables, (page.name, line)
                assert commented.group(1) in tables[table].model_fields, (page.name, table, line)
                named += 1
    assert named >= 30


class _Quiet(http.server.SimpleHTTPRequestHandler):
    """The site's files under the path it is published at (``prefix``), nothing else."""

    prefix = "/"

    def translate_path(self, path: str) -> str:
        if not path.startswith(self.prefix):
            return os.path.join(str(self.directory), "__outside_the_site__")  # a 404
        return super().translate_path("/" + path[len(self.prefix) :])

    def log_message(self, format: str, *args: object) -> None:  # noqa: A002 - the base's name
        pass


def _published_path(site: Path) -> str:
    """The path the site is published under (its ``site_url``'s, as the build wrote it
    into the sitemap: pages such as 404.html link their assets from there), or "/"."""
    sitemap = site / "sitemap.xml"
    found = re.search(r"<loc>([^<]+)</loc>", sitemap.read_text()) if sitemap.is_file() else None
    return urlsplit(found.group(1)).path if found else "/"


@pytest.fixture(scope="module")
def served(site: Path) -> Iterator[str]:
    """The built site served over HTTP on a free local port, under the path it is
    published at, as a browser would get it."""
    prefix = _published_path(site)
    handler = functools.partial(type("_Site", (_Quiet,), {"prefix": prefix}), directory=str(site))
    with http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler) as server:
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        yield f"http://127.0.0.1:{server.server_address[1]}{prefix}"
        server.shutdown()


def _status(url: str) -> int:
    try:
        with urllib.request.urlopen(url, timeout=30) as answer:
            return answer.status
    except urllib.error.HTTPError as error:
        return error.code


_LOADED = re.compile(
    r'<img[^>]*\ssrc="([^"]+)"|<script[^>]*\ssrc="([^"]+)"'
    r'|<link(?=[^>]*\srel="stylesheet")[^>]*\shref="([^"]+)"'
)


@pytest.mark.slow
def test_every_page_loads_its_pictures_scripts_and_stylesheets_over_http(site: Path, served: str):
    """What a browser fetches for each page — every <img>, <script src> and stylesheet —
    answers 200 from the served site (the tutorials' pictures, made by the build,
    included); a page that names a missing file fails."""
    fetched: dict[str, int] = {}
    pages = sorted(site.rglob("*.html"))
    for page in pages:
        url = urljoin(served, page.relative_to(site).as_posix())
        assert _status(url) == 200, url
        for groups in _LOADED.findall(page.read_text(encoding="utf-8")):
            ref = next(g for g in groups if g)
            target = urljoin(url, ref)
            if urlsplit(target).netloc != urlsplit(served).netloc:
                continue  # another site (none today): not ours to check offline
            if target not in fetched:
                fetched[target] = _status(target)
            assert fetched[target] == 200, f"{page.relative_to(site)}: {ref}"
    assert any(t.endswith(".js") for t in fetched) and any(t.endswith(".css") for t in fetched)
    tutorial_pictures = [t for t in fetched if "/tutorials/" in t and t.endswith(".png")]
    assert len(tutorial_pictures) >= 6, tutorial_pictures
    assert _status(served + "no-such-page/") == 404  # the check can fail


def _chromium() -> str | None:
    found = shutil.which("chromium") or shutil.which("chromium-browser")
    if found is None:
        if os.environ.get("CI"):
            pytest.fail("chromium is not on PATH under CI (.ci/run installs it)")
        pytest.skip("chromium is not on PATH (Debian: apt-get install chromium)")
    return found


@pytest.mark.slow
def test_a_real_browser_draws_the_home_page_a_tutorial_and_the_gallery(served: str, tmp_path: Path):
    """Headless Chromium renders the home page, a tutorial and the gallery to screenshots
    that are not blank: the page's text, pictures and theme drew (a missing stylesheet or a
    blank page gives one flat colour)."""
    from PIL import Image

    chromium = _chromium()
    for name, path in (("home", ""), ("tutorial", "tutorials/own_mesh/"), ("gallery", "gallery/")):
        shot = tmp_path / f"{name}.png"
        subprocess.run(
            [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
             f"--screenshot={shot}", "--window-size=1280,900", served + path],
            capture_output=True, timeout=120, check=False,
        )  # fmt: skip
        assert shot.is_file(), name
        pixels = np.asarray(Image.open(shot).convert("L"), dtype=np.float64)
        assert pixels.shape == (900, 1280)
        assert pixels.std() > 20, (name, pixels.std())  # text and pictures, not a flat page
        assert (pixels < 80).mean() > 0.005, name  # dark text or a picture drew
