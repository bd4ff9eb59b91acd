"""MkDocs hooks (``hooks:`` in mkdocs.yml): add the generated reference pages
(``reference/scene.md``, ``reference/cli.md``, from :mod:`docs_reference`), the
tutorials' pages and pictures (each ``tutorials/NAME.py`` run, :mod:`docs_tutorials`) and
the gallery's examples (each ``examples/NAME.toml`` rendered into ``gallery.md``, its
picture at ``examples/NAME.png``, :mod:`docs_gallery`) to the site before the navigation
is built, so the nav and the strict link check see them; the tutorials and the examples
run side by side in one pool (:mod:`docs_runs`: ``FOLLICLE_DOCS_JOBS``,
``FOLLICLE_DOCS_TUTORIALS=0`` / ``FOLLICLE_DOCS_GALLERY=0`` to build without running
them), and one that fails fails the build. And show the docstrings' Sphinx roles
(``:meth:`replace```) as the code they name, since mkdocstrings renders a docstring's
Markdown and leaves the role's prefix as text. The site's ``site_url`` and ``repo_url``
come from pyproject's ``[project.urls]`` (:func:`on_config`)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files
from mkdocs.structure.pages import Page

sys.path.insert(0, str(Path(__file__).resolve().parent))
import docs_gallery  # noqa: E402  (tools/ is not a package)
import docs_reference  # noqa: E402
import docs_tutorials  # noqa: E402
from docs_runs import RunError, in_fresh_folder, in_pool, once, skipped  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "build_support"))
import readme_links  # noqa: E402  (build_support/ is not a package)

GENERATED = {
    "reference/scene.md": docs_reference.scene_reference,
    "reference/cli.md": docs_reference.cli_reference,
}
GALLERY = "gallery.md"


def on_config(config: MkDocsConfig) -> MkDocsConfig:
    """The site's address and its repository from pyproject's ``[project.urls]``, the one
    place that names them (``Documentation``, ``Source``; see
    ``build_support/readme_links.py``), set as mkdocs.yml's ``site_url`` / ``repo_url``
    would set them: the repository's name and edit link (GitHub's) with them."""
    urls = readme_links.project_urls(ROOT)
    config["site_url"] = urls["Documentation"].rstrip("/") + "/"
    config["repo_url"] = urls["Source"]
    config["repo_name"] = "GitHub"
    config["edit_uri"] = f"edit/{readme_links.BRANCH}/docs/"
    return config


def on_files(files: Files, config: MkDocsConfig) -> Files:
    """The generated pages and pictures, written fresh on every build; a tutorial or
    an example that fails fails the build."""
    for path, make in GENERATED.items():
        files.append(File.generated(config, path, content=make()))
    try:
        _add_runs(files, config)
    except RunError as error:
        raise PluginError(str(error)) from None
    return files


def _add_runs(files: Files, config: MkDocsConfig) -> None:
    """Run the tutorials and the examples (side by side, in one pool) and add their
    pages and pictures to ``files``: each tutorial's page with its pictures beside it,
    the gallery page in place of the hand-written one, the examples' pictures."""
    root = Path(config.config_file_path).parent
    scripts = sorted(Path(config.docs_dir, "tutorials").glob("*.py"))
    found = docs_gallery.examples(root)
    tasks = [] if skipped("tutorials") else [_tutorial_run(s) for s in scripts]
    tasks += [] if skipped("gallery") else [_example_run(root, e) for e in found]
    runs = iter(in_pool(tasks))
    for script in scripts:
        ran = None if skipped("tutorials") else next(runs)
        text = docs_tutorials.page(script, None if ran is None else ran[0], script.stem)
        files.append(File.generated(config, f"tutorials/{script.stem}.md", content=text))
        for name, data in (ran or (None, {}))[1].items():
            files.append(File.generated(config, f"tutorials/{script.stem}/{name}", content=data))
    pictures = None if skipped("gallery") else {e.name: next(runs) for e in found}
    written = files.get_file_from_path(GALLERY)
    if written is None:
        raise docs_gallery.ExampleError(f"docs/{GALLERY} is missing: the gallery's page")
    files.remove(written)
    text = docs_gallery.page(written.content_string, root, found, pictures)
    files.append(File.generated(config, GALLERY, content=text))
    for name, data in (pictures or {}).items():
        files.append(File.generated(config, f"examples/{name}.png", content=data))


def _tutorial_run(script: Path):
    """A task running tutorial ``script`` in a fresh folder: its cells' outputs and the
    pictures its page shows (rerun by ``mkdocs serve`` only when the script changed)."""
    return lambda: once(
        [b"tutorial", script.read_bytes()],
        lambda: in_fresh_folder(
            f"tutorial-{script.stem}-", lambda work: docs_tutorials.run_shown(script, work)
        ),
    )


def _example_run(root: Path, example: docs_gallery.Example):
    """A task running ``example`` in a fresh folder: its picture's PNG bytes (rerun by
    ``mkdocs serve`` only when a file of ``examples/`` changed)."""
    return lambda: once(
        [b"example", example.name.encode(), *docs_gallery.depends(root)],
        lambda: in_fresh_folder(
            f"example-{example.name}-", lambda work: docs_gallery.run(example, root, work)
        ),
    )


def on_page_markdown(markdown: str, page: Page, config: MkDocsConfig, files: Files) -> str:
    """A page's Markdown with the gallery's pictures replaced by a note when the build
    does not run the examples (``FOLLICLE_DOCS_GALLERY=0``): they are not there."""
    return docs_gallery.unrendered(markdown, page.file.src_uri) if skipped("gallery") else markdown


# ":meth:" before the <code> span its backticks became
_ROLE = re.compile(r":(?:py:)?(?:meth|class|func|data|mod|attr|exc|obj|const):(?=<code>)")


def on_page_content(html: str, page: Page, config: MkDocsConfig, files: Files) -> str:
    """The reference pages' HTML without the roles' prefixes."""
    return _ROLE.sub("", html) if page.file.src_uri.startswith("reference/") else html
