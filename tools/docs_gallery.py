"""The docs' gallery: every scene of ``examples/`` run by the docs build, so each of its
pictures is what that scene file makes today, with the commands that made it
(``tools/mkdocs_hooks.py``; as sphinx-gallery does for plotting scripts).

A scene is ``examples/NAME.toml``. Its leading comment describes it (the first line says
what it shows) and lists, indented, the commands that make it — ``#   follicle render
examples/NAME.toml ...``, a ``\\`` continuing a command on the next line, ``# ...`` after a
command a remark. The gallery runs the commands that prepare the scene (a script that
writes a stroke log, ``follicle groom`` replaying it, ``make_assets.py``) as written,
then, in place of the comment's ``follicle render``, its own :func:`render_command`:
small (360²) and with the CPU engine, so the build stays quick and needs no GPU. It
runs them in a fresh folder holding a copy of ``examples/``, so the commands read, and
run, as from a checkout's root (``docs_runs`` says how ``follicle`` and ``python`` are
found); a command that fails, or a picture not made, fails the build.

``examples(root)`` reads the scenes, ``run(example, root, workdir)`` makes one's picture,
``page(text, examples, pictures)`` writes the gallery page: the hand-written
``docs/gallery.md`` with the examples' section where its ``MARK`` line is.
"""

from __future__ import annotations

import posixpath
import re
import shutil
from dataclasses import dataclass
from pathlib import Path

from docs_runs import PICTURE, RunError, argv, not_made, run_child

__all__ = [
    "MARK",
    "SIZE",
    "Example",
    "ExampleError",
    "depends",
    "example",
    "examples",
    "page",
    "render_command",
    "run",
    "section",
    "unrendered",
]

SIZE = 360  # the pictures' width and height, pixels
MARK = "<!-- the examples, run by the docs build: tools/docs_gallery.py -->"

_COMMAND = re.compile(r"^#\s{3,}((?:follicle|python3?|\.venv/bin/python)\s.*)$")
_REMARK = re.compile(r"\s+#\s.*$")  # "   # remark" after a command
_RENDERED = re.compile(r"examples/([\w-]+)\.png")  # a gallery picture's path in the site


class ExampleError(RunError):
    """An example that failed: its scene, the command and what it printed."""


@dataclass(frozen=True)
class Example:
    """One scene of ``examples/``: its ``name`` (the file's stem), ``title`` (the
    comment's first line), ``description`` (the rest of the comment, Markdown, the
    commands left out), the ``commands`` that make its picture (the last renders it),
    and the ``scripts`` of ``examples/`` they run (shown beside the scene file)."""

    name: str
    title: str
    description: str
    commands: tuple[str, ...]
    scripts: tuple[str, ...]


def render_command(name: str) -> str:
    """The command that renders scene ``name``'s gallery picture, ``NAME.png``."""
    return f"follicle render examples/{name}.toml -o {name}.png --size {SIZE} {SIZE} --engine cpu"


def example(scene: Path) -> Example:
    """The example of ``scene`` (``examples/NAME.toml``), read from its leading comment."""
    prose: list[str] = []
    commands: list[str] = []
    continued = False
    for line in scene.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        command = _COMMAND.match(line)
        if continued or command:
            text = _REMARK.sub("", line[1:]).strip()
            if continued:
                commands[-1] = commands[-1][:-1].rstrip() + " " + text
            else:
                commands.append(text)
            continued = text.endswith("\\")
        else:
            prose.append(line[2:] if line.startswith("# ") else line[1:])
    paragraphs = "\n".join(prose).strip().split("\n\n", 1)
    if not paragraphs[0]:
        raise ExampleError(f"{scene}: a scene starts with a comment: what it shows, first")
    name = scene.stem
    prepare = [c for c in commands if not c.startswith("follicle render")]
    scripts = [
        words[1]
        for words in (c.split() for c in prepare)
        if words[0] != "follicle" and words[1].startswith("examples/")
    ]
    return Example(
        name=name,
        title=" ".join(paragraphs[0].split()),
        description=paragraphs[1].strip() if len(paragraphs) > 1 else "",
        commands=(*prepare, render_command(name)),
        scripts=tuple(scripts),
    )


def examples(root: Path) -> list[Example]:
    """The examples of the checkout at ``root``, by name."""
    return [example(scene) for scene in sorted((root / "examples").glob("*.toml"))]


def depends(root: Path) -> list[bytes]:
    """What an example's run reads: every file of ``examples/``, named."""
    folder = root / "examples"
    return [
        str(path.relative_to(folder)).encode() + b"\0" + path.read_bytes()
        for path in sorted(folder.rglob("*"))
        if path.is_file() and "__pycache__" not in path.parts
    ]


def run(example: Example, root: Path, workdir: Path, timeout: float = 600) -> bytes:
    """Run ``example``'s commands in ``workdir`` (empty) beside a copy of ``root``'s
    ``examples/``; its picture's PNG bytes. Raises ExampleError naming the scene, the
    command and its output."""
    shutil.copytree(
        root / "examples", workdir / "examples", ignore=shutil.ignore_patterns("__pycache__")
    )
    for command in example.commands:
        done = run_child(argv(command), workdir, timeout)
        if done.returncode != 0:
            raise ExampleError(
                f"example examples/{example.name}.toml: `{command}` exited {done.returncode}:\n"
                f"{done.stdout[-3000:]}{done.stderr[-5000:]}"
            )
    picture = workdir / f"{example.name}.png"
    if not picture.is_file():
        raise ExampleError(f"example examples/{example.name}.toml made no {picture.name}")
    return picture.read_bytes()


def section(root: Path, found: list[Example], pictures: dict[str, bytes] | None) -> str:
    """The examples' Markdown on a page at the site's root: each with its picture
    (``examples/NAME.png``; ``pictures`` None: not run, a note instead), description,
    commands, and the scene file and scripts in collapsed blocks."""
    text: list[str] = []
    for ex in found:
        shown = f"![{ex.name}: {ex.title}](examples/{ex.name}.png)"
        if pictures is None:
            shown = not_made(f"examples/{ex.name}.png", "the gallery's examples")
        text += [f"### {ex.name}", "", shown, "", f"**{ex.title}**", ""]
        if ex.description:
            text += [ex.description, ""]
        text += ["```bash", *ex.commands, "```", ""]
        for path, language in ((f"examples/{ex.name}.toml", "toml"),) + tuple(
            (s, "python") for s in ex.scripts
        ):
            body = (root / path).read_text(encoding="utf-8").rstrip("\n")
            text += [f'??? example "{path}"', "", f"    ```{language}"]
            text += [f"    {line}" if line else "" for line in body.splitlines()]
            text += ["    ```", ""]
    return "\n".join(text)


def page(text: str, root: Path, found: list[Example], pictures: dict[str, bytes] | None) -> str:
    """The gallery page: ``text`` (``docs/gallery.md``) with the examples' section in
    place of its ``MARK`` line."""
    if MARK not in text:
        raise ExampleError(f"docs/gallery.md has no line {MARK!r} to put the examples at")
    return text.replace(MARK, section(root, found, pictures))


def unrendered(markdown: str, src_uri: str) -> str:
    """A page's Markdown with the gallery's pictures it shows (``examples/NAME.png``,
    relative to the page ``src_uri``) replaced by a note: for a build that does not run
    the examples (``FOLLICLE_DOCS_GALLERY=0``)."""

    def note(match: re.Match[str]) -> str:
        path = posixpath.normpath(posixpath.join(posixpath.dirname(src_uri), match.group(1)))
        if not _RENDERED.fullmatch(path):
            return match.group(0)
        return not_made(path, "the gallery's examples")

    return PICTURE.sub(note, markdown)
