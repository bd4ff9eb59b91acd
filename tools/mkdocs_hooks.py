"""MkDocs hooks (``hooks:`` in mkdocs.yml): add the generated reference pages
(``reference/scene.md``, ``reference/cli.md``, from :mod:`docs_reference`) and the
tutorials' pages and pictures (each ``tutorials/NAME.py`` run, :mod:`docs_tutorials`) to
the site before the navigation is built, so the nav and the strict link check see them;
and show
the docstrings' Sphinx roles (``:meth:`replace```) as the code they name, since
mkdocstrings renders a docstring's Markdown and leaves the role's prefix as text."""

from __future__ import annotations

import hashlib
import os
import re
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files
from mkdocs.structure.pages import Page

sys.path.insert(0, str(Path(__file__).resolve().parent))
import docs_reference  # noqa: E402  (tools/ is not a package)
import docs_tutorials  # noqa: E402

GENERATED = {
    "reference/scene.md": docs_reference.scene_reference,
    "reference/cli.md": docs_reference.cli_reference,
}


def on_files(files: Files, config: MkDocsConfig) -> Files:
    """The generated pages, written fresh on every build."""
    for path, make in GENERATED.items():
        files.append(File.generated(config, path, content=make()))
    scripts = sorted(Path(config.docs_dir, "tutorials").glob("*.py"))
    skip = os.environ.get("FOLLICLE_DOCS_TUTORIALS") == "0"
    with ThreadPoolExecutor(int(os.environ.get("FOLLICLE_DOCS_JOBS", "2"))) as pool:
        runs = list(pool.map(lambda s: None if skip else _ran(s), scripts))
    for script, ran in zip(scripts, runs, strict=True):
        files.append(_tutorial(config, script, ran))
        for name, data in (ran or (None, {}))[1].items():
            files.append(File.generated(config, f"tutorials/{script.stem}/{name}", content=data))
    return files


# script text's SHA-256 -> (cells, pictures): `mkdocs serve` reruns only a changed script
_RUNS: dict[str, tuple[list, dict[str, bytes]]] = {}


def _ran(script: Path) -> tuple[list, dict[str, bytes]]:
    """Run a tutorial in a fresh folder: its cells' outputs and the pictures its page
    shows (a PluginError, failing the build, when it fails or a picture is missing)."""
    key = hashlib.sha256(script.read_bytes()).hexdigest()
    if key not in _RUNS:
        with tempfile.TemporaryDirectory(prefix=f"tutorial-{script.stem}-") as work:
            try:
                ran = docs_tutorials.run(script, Path(work))
            except docs_tutorials.TutorialError as error:
                raise PluginError(str(error)) from None
            shown = docs_tutorials.pictures_named("\n".join(str(c["prose"]) for c in ran))
            missing = [p for p in shown if not (Path(work) / p).is_file()]
            if missing:
                raise PluginError(f"tutorial {script.name} shows {missing} but did not make them")
            _RUNS[key] = (ran, {p: (Path(work) / p).read_bytes() for p in shown})
    return _RUNS[key]


def _tutorial(config: MkDocsConfig, script: Path, ran: tuple | None) -> File:
    """The page of a tutorial, ``tutorials/NAME.md`` beside its script."""
    text = docs_tutorials.page(script, None if ran is None else ran[0], script.stem)
    return File.generated(config, f"tutorials/{script.stem}.md", content=text)


# ":meth:" before the <code> span its backticks became
_ROLE = re.compile(r":(?:py:)?(?:meth|class|func|data|mod|attr|exc|obj|const):(?=<code>)")


def on_page_content(html: str, page: Page, config: MkDocsConfig, files: Files) -> str:
    """The reference pages' HTML without the roles' prefixes."""
    return _ROLE.sub("", html) if page.file.src_uri.startswith("reference/") else html
