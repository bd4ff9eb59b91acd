"""The docs site builds strictly (a warning, a broken link or anchor, a page left out of
the navigation fails, as `mkdocs.yml` sets), its pages find every picture they show,
and the README's and CHANGELOG's links point at files that exist."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote, urlsplit

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


def _build(config_dir: Path, out: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=config_dir,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.mark.slow
def test_a_broken_link_fails_the_build(tmp_path: Path):
    """The strictness is real: the same site with one link to a page that is not there
    does not build."""
    shutil.copytree(ROOT / "docs", tmp_path / "docs")
    shutil.copytree(ROOT / "tools", tmp_path / "tools")
    shutil.copy(ROOT / "mkdocs.yml", tmp_path)
    (tmp_path / "src").symlink_to(ROOT / "src")
    page = tmp_path / "docs" / "how-to" / "grooming.md"
    page.write_text(page.read_text(encoding="utf-8") + "\n[gone](no-such-page.md)\n")
    done = _build(tmp_path, tmp_path / "site")
    assert done.returncode != 0
    assert "no-such-page.md" in done.stderr + done.stdout


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
