"""MkDocs hooks (``hooks:`` in mkdocs.yml): add the generated reference pages
(``reference/scene.md``, ``reference/cli.md``, from :mod:`docs_reference`) to the site
before the navigation is built, so the nav and the strict link check see them; and show
the docstrings' Sphinx roles (``:meth:`replace```) as the code they name, since
mkdocstrings renders a docstring's Markdown and leaves the role's prefix as text."""

from __future__ import annotations

import re
import sys
from pathlib import Path

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.structure.files import File, Files
from mkdocs.structure.pages import Page

sys.path.insert(0, str(Path(__file__).resolve().parent))
import docs_reference  # noqa: E402  (tools/ is not a package)

GENERATED = {
    "reference/scene.md": docs_reference.scene_reference,
    "reference/cli.md": docs_reference.cli_reference,
}


def on_files(files: Files, config: MkDocsConfig) -> Files:
    """The generated pages, written fresh on every build."""
    for path, make in GENERATED.items():
        files.append(File.generated(config, path, content=make()))
    return files


# ":meth:" before the <code> span its backticks became
_ROLE = re.compile(r":(?:py:)?(?:meth|class|func|data|mod|attr|exc|obj|const):(?=<code>)")


def on_page_content(html: str, page: Page, config: MkDocsConfig, files: Files) -> str:
    """The reference pages' HTML without the roles' prefixes."""
    return _ROLE.sub("", html) if page.file.src_uri.startswith("reference/") else html
