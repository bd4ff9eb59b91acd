"""Where follicle's documentation is, for ``follicle docs``: the site that the package's
metadata names (the ``Documentation`` URL of pyproject's ``[project.urls]``; an install
made before it was there names none) and, in a source checkout, the Markdown in
``docs/`` that ``mkdocs serve`` shows as that site. A wheel ships no docs: it says so,
and where they are instead."""

from __future__ import annotations

import importlib.util
import shlex
import sys
from importlib import metadata
from pathlib import Path

__all__ = ["site_url", "checkout", "where_lines"]


def site_url() -> str | None:
    """The ``Documentation`` (or ``Docs``) URL among the installed package's
    ``Project-URL``\\ s, or None where it names none."""
    try:
        urls = metadata.metadata("follicle").get_all("Project-URL") or []
    except metadata.PackageNotFoundError:
        return None
    for entry in urls:
        label, _, url = entry.partition(",")
        if label.strip().lower() in ("documentation", "docs") and url.strip():
            return url.strip()
    return None


def checkout() -> Path | None:
    """The source checkout this follicle runs from (an editable install): the folder above
    the package holding ``mkdocs.yml`` and ``docs/index.md``; None for an installed wheel."""
    root = Path(__file__).resolve().parents[2]
    if (root / "mkdocs.yml").is_file() and (root / "docs" / "index.md").is_file():
        return root
    return None


def where_lines(url: str | None, root: Path | None) -> list[str]:
    """What ``follicle docs`` prints, one fact a line: the site (``url``), the docs'
    source in the checkout ``root`` and the command that serves it, and the help that
    needs neither."""
    lines = [f"site: {url}" if url else "site: none published (the package names no URL)"]
    if root is None:
        lines.append(
            "source: not in this install (a wheel ships no docs); docs/ of follicle's source"
            " repository, a site built with mkdocs (mkdocs.yml beside it)"
        )
    else:
        python = shlex.quote(sys.executable)
        lines += [
            f"source: {root / 'docs'} (Markdown; start at index.md)",
            f"serve: cd {shlex.quote(str(root))} && {python} -m mkdocs serve, then open the"
            " address it prints (http://127.0.0.1:8000 by default)",
        ]
        if importlib.util.find_spec("mkdocs") is None:
            lines.append("needs: pip install 'follicle[docs]' (mkdocs is not installed here)")
    lines += [
        "reference: every command and scene key with its type, default, range and unit"
        " (Reference › Command line, Scene keys; generated from the code)",
        "here: follicle COMMAND --help (options and examples); follicle info SCENE (every"
        " scene key: value, [unit], meaning)",
    ]
    return lines
