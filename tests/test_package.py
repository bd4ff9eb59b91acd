"""The package as an index shows it: the sdist and a wheel built from this repository
pass ``twine check --strict``; their description (README.md) has absolute links only,
each where the repository's relative one leads; the wheel carries the licence (PEP 639)
and the project's addresses, which ``follicle docs`` reads."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tarfile
import zipfile
from email.parser import Parser
from pathlib import Path

import pytest

from follicle import docs_location

pytestmark = pytest.mark.slow  # builds an sdist and a wheel in subprocesses

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "build_support"))
import readme_links  # noqa: E402  (build_support/ is not a package)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
URLS = PROJECT["urls"]
# a Markdown link or image target, and an HTML src/href
LINK = re.compile(r"\]\(([^)\s]+)\)|(?:src|href)=\"([^\"]+)\"")


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The sdist and a wheel without kernels (``FOLLICLE_KERNELS=0``: quick), built by
    the project's own backend as a frontend calls it; the wheel from the sdist, as pip
    builds one from an index."""
    out = tmp_path_factory.mktemp("dist")

    def build(kind: str, project: Path) -> str:
        """The file name of the ``kind`` (sdist, wheel) the backend of ``project`` builds."""
        backend = f"import sys, follicle_build as b; print(b.build_{kind}(sys.argv[1]))"
        return subprocess.run(
            [sys.executable, "-c", backend, str(out)],
            cwd=project,
            env={
                **os.environ,
                "FOLLICLE_KERNELS": "0",
                "PYTHONPATH": str(project / "build_support"),
            },
            capture_output=True,
            text=True,
            check=True,
        ).stdout.split()[-1]

    sdist = build("sdist", ROOT)
    with tarfile.open(out / sdist) as archive:
        archive.extractall(out / "src", filter="data")
    (unpacked,) = (out / "src").iterdir()
    wheel = build("wheel", unpacked)
    return {"sdist": out / sdist, "wheel": out / wheel}


def _metadata(built: dict[str, Path]) -> dict[str, str]:
    """Each archive's metadata file, as text."""
    with zipfile.ZipFile(built["wheel"]) as whl:
        wheel = whl.read("follicle-0.1.0.dist-info/METADATA").decode()
    with tarfile.open(built["sdist"]) as tar:
        member = tar.extractfile("follicle-0.1.0/PKG-INFO")
        assert member is not None
        sdist = member.read().decode()
    return {"wheel": wheel, "sdist": sdist}


def test_twine_check_passes_the_sdist_and_the_wheel(built):
    done = subprocess.run(
        [sys.executable, "-m", "twine", "check", "--strict", *map(str, built.values())],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.count("PASSED") == 2, done.stdout


def test_the_description_links_absolutely_where_the_readme_links(built):
    """Every link of the description is absolute; each one README.md has relatively
    leads to that file: a picture to its raw file in the repository, a docs page to the
    address MkDocs gives that page (its own File.url, directory URLs as mkdocs.yml
    builds them), a tutorial script to the page the site makes of it, any other file to
    the repository's copy."""
    from mkdocs.structure.files import File

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    relative = [a or b for a, b in LINK.findall(readme) if not re.match(r"\w+:", a or b)]
    assert len(relative) > 20  # the README links relatively: right on the repository
    site, repo = URLS["Documentation"], URLS["Source"]
    raw = repo.replace("https://github.com/", "https://raw.githubusercontent.com/")
    for text in _metadata(built).values():
        description = Parser().parsestr(text).get_payload()
        links = [a or b for a, b in LINK.findall(description)]
        assert [x for x in links if not x.startswith(("https://", "http://"))] == []
        assert len(links) == len(LINK.findall(readme))  # one for one
        for target, absolute in zip([a or b for a, b in LINK.findall(readme)], links, strict=True):
            if re.match(r"\w+:", target):
                assert absolute == target
                continue
            assert (ROOT / target.split("#")[0]).is_file(), target  # a file of the repository
            if target.endswith(".png"):
                assert absolute == f"{raw}/main/{target}"
            elif target.startswith("docs/") and target.endswith((".md", ".py")):
                page = target.removeprefix("docs/").removesuffix(".py").removesuffix(".md")
                url = File(page + ".md", str(ROOT / "docs"), "/site", True).url
                url = url.removeprefix("./")  # the site's own index
                assert absolute == site + url, (target, absolute)
            else:
                assert absolute == f"{repo}/blob/main/{target}"


def test_the_wheel_carries_the_licence_and_the_project_metadata(built):
    with zipfile.ZipFile(built["wheel"]) as whl:
        licence = whl.read("follicle-0.1.0.dist-info/licenses/LICENSE").decode()
    assert licence == (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert licence.startswith("MIT License\n\nCopyright (c) 2026 the follicle authors\n")
    with tarfile.open(built["sdist"]) as tar:
        names = tar.getnames()
    assert "follicle-0.1.0/LICENSE" in names and "follicle-0.1.0/README.md" in names
    assert [n for n in names if "__pycache__" in n or n.endswith(".pyc")] == []
    for text in _metadata(built).values():
        meta = Parser().parsestr(text)
        assert meta["License-Expression"] == "MIT" and meta["License-File"] == "LICENSE"
        assert meta["Author"] == "the follicle authors"
        assert not [c for c in meta.get_all("Classifier") if c.startswith("License ::")]
        assert "Development Status :: 3 - Alpha" in meta.get_all("Classifier")
        assert sorted(meta.get_all("Project-URL")) == sorted(f"{k}, {v}" for k, v in URLS.items())


def test_follicle_docs_finds_the_site_the_wheel_names(built, monkeypatch):
    with zipfile.ZipFile(built["wheel"]) as whl:
        meta = Parser().parsestr(whl.read("follicle-0.1.0.dist-info/METADATA").decode())
    monkeypatch.setattr(docs_location.metadata, "metadata", lambda name: meta)
    assert docs_location.site_url() == "https://follicle-hair.github.io/follicle/"
    assert docs_location.where_lines(docs_location.site_url(), None)[0] == (
        "site: https://follicle-hair.github.io/follicle/"
    )


def test_the_addresses_are_named_in_one_place():
    """pyproject's [project.urls] names the repository and the site; mkdocs.yml does
    not repeat them (its hook reads pyproject), nor does the build."""
    mkdocs = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    assert not re.search(r"^(site_url|repo_url):", mkdocs, re.MULTILINE)
    for path in [ROOT / "setup.py", *(ROOT / "build_support").glob("*.py")]:
        assert "follicle-hair" not in path.read_text(encoding="utf-8"), path
    assert readme_links.project_urls(ROOT) == URLS
