"""The package's long description: README.md with its relative links made absolute.

README.md links relatively (``docs/demo.png``, ``docs/how-to/dynamics.md``), which is
right on the repository's page and broken on a package index, which shows the
description alone. A build (``setup.py``, for pyproject's ``dynamic = ["readme"]``)
rewrites each relative Markdown link or image: a picture to its raw file in the
repository, a page of the docs to the docs site (``how-to/dynamics.md`` →
``…/how-to/dynamics/``, ``index.md`` → its folder; a tutorial script ``tutorials/X.py``
→ the page the site makes of it), anything else to the file in the repository.

The repository and the site are pyproject's ``[project.urls]`` ``Source`` and
``Documentation``: the one place that names them (the docs' ``site_url`` and
``repo_url`` are read from there too, by ``tools/mkdocs_hooks.py``).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["project_urls", "absolute_links", "long_description"]

BRANCH = "main"  # the repository's branch the description's links point into
_IMAGES = (".png", ".jpg", ".jpeg", ".gif", ".svg", ".webp")
# a Markdown link or image: [text](target) or ![alt](target), target without spaces
_LINK = re.compile(r"(!?\[[^\]]*\]\()([^)\s]+)(\))")
_ABSOLUTE = re.compile(r"^([a-z][a-z0-9+.-]*:|#|/)", re.IGNORECASE)


def project_urls(root: Path) -> dict[str, str]:
    """pyproject's ``[project.urls]`` of the project at ``root``."""
    project = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    return dict(project["urls"])


def _site_page(path: str) -> str:
    """The docs site's address (below its root) of ``path`` below ``docs/``: MkDocs'
    directory URLs, as mkdocs.yml builds them."""
    if path.endswith(".py") and path.startswith("tutorials/"):  # a page made of the script
        path = path[: -len(".py")] + ".md"
    page, _, anchor = path.partition("#")
    page = page.removesuffix(".md")
    page = page[: -len("index")] if page == "index" or page.endswith("/index") else page + "/"
    return page + (f"#{anchor}" if anchor else "")


def _absolute(target: str, urls: dict[str, str]) -> str:
    """``target`` of a link in README.md as an absolute address (see the module)."""
    if _ABSOLUTE.match(target):
        return target
    repo = urls["Source"].rstrip("/")
    site = urls["Documentation"].rstrip("/") + "/"
    path = target.removeprefix("./")
    if path.lower().split("#")[0].endswith(_IMAGES):
        host = repo.replace("https://github.com/", "https://raw.githubusercontent.com/", 1)
        return f"{host}/{BRANCH}/{path}"
    file = path.split("#")[0]
    page = file.endswith(".md") or file.startswith("docs/tutorials/") and file.endswith(".py")
    if file.startswith("docs/") and page:
        return site + _site_page(path.removeprefix("docs/"))
    return f"{repo}/blob/{BRANCH}/{path}"


def absolute_links(markdown: str, urls: dict[str, str]) -> str:
    """``markdown`` with every relative link and image target made absolute."""
    return _LINK.sub(lambda m: m[1] + _absolute(m[2], urls) + m[3], markdown)


def long_description(root: Path) -> str:
    """README.md of the project at ``root``, its links absolute: the package's
    description."""
    text = (root / "README.md").read_text(encoding="utf-8")
    return absolute_links(text, project_urls(root))
