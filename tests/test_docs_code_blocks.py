"""Every code block of the README and the docs is checked like code: each ```python
block runs, page by page, and each `follicle …` command of a ```bash block names a
command and options that exist.

Python blocks of a page run in order in one namespace (a page's blocks continue each
other), in an empty folder, after a prelude that gives them what the prose says they
start from: ``follicle``, ``np``, a ``mesh`` (the built-in head), its ``hair`` (300
hairs), a ``sequence`` of them, a ``scene`` (``follicle.Scene()``), ``some_4x4`` (a head
transform), ``mask`` (a region of the mesh) and the files they name (``scene.toml``,
``a.toml``, ``b.toml``, ``density.tif``). A block whose first line is
``# not run by the docs' tests: REASON`` is skipped, visibly on the page; only a few
may be (a window, millions of hairs). The tutorials (``docs/tutorials/*.py``) are not
here: the docs build runs them (tests/test_docs_build.py).
"""

from __future__ import annotations

import re
from pathlib import Path

import click
import pytest

from cli_lines import follicle_args

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
SKIP = "# not run by the docs' tests:"
MAX_SKIPPED = 3

_PRELUDE = """
import numpy as np
import follicle
from PIL import Image

mesh = follicle.load_mesh("builtin:head")
hair = follicle.Groom(mesh, follicle.load_guides("builtin:long", mesh)).generate(300)
sequence = [hair, hair]
scene = follicle.Scene()
some_4x4 = np.eye(4)
some_4x4[:3, 3] = (0.0, 0.01, 0.0)
mask = np.zeros(mesh.face_count, bool)
mask[: mesh.face_count // 2] = True
Image.fromarray(np.full((64, 64), 200, np.uint8)).save("density.tif")
for name in ("scene.toml", "a.toml", "b.toml"):
    open(name, "w").write(
        '[mesh]\\npath = "builtin:head"\\n[guides]\\npath = "builtin:short"\\n'
        '[groom]\\ncount = 300\\n[render]\\nsize = [96, 96]\\n'
    )
"""


def _blocks(page: Path, lang: str) -> list[str]:
    text = page.read_text(encoding="utf-8")
    return re.findall(rf"^```{lang}\n(.*?)^```", text, re.S | re.M)


def _python_pages() -> list[Path]:
    """The pages with a python block to run."""
    return [p for p in PAGES if any(not b.startswith(SKIP) for b in _blocks(p, "python"))]


def test_few_blocks_are_skipped_and_each_says_why():
    skipped = [
        (page.name, block.splitlines()[0])
        for page in PAGES
        for block in _blocks(page, "python")
        if block.startswith(SKIP)
    ]
    assert len(skipped) <= MAX_SKIPPED, skipped
    assert all(len(first) > len(SKIP) + 5 for _, first in skipped), skipped  # a reason


@pytest.mark.slow
@pytest.mark.parametrize("page", _python_pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_each_python_block_runs(page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.chdir(tmp_path)
    space: dict[str, object] = {"__name__": "__docs__"}
    exec(compile(_PRELUDE, "prelude", "exec"), space)  # noqa: S102
    ran = 0
    for number, block in enumerate(_blocks(page, "python"), start=1):
        if block.startswith(SKIP):
            continue
        code = compile(block, f"{page.relative_to(ROOT)} block {number}", "exec")
        exec(code, space)  # noqa: S102 - the block is the test
        ran += 1
    assert ran, page


def _commands() -> list[tuple[str, str]]:
    """Each `follicle …` command line of the bash blocks: (page, the command's words)."""
    found = []
    for page in PAGES:
        for block in _blocks(page, "bash") + _blocks(page, "sh"):
            for line in block.replace("\\\n", " ").splitlines():
                # [--count N]: optional words, checked as words
                args = follicle_args(line.replace("[", " ").replace("]", " "))
                if args is not None:
                    found.append((str(page.relative_to(ROOT)), " ".join(args)))
    return found


def _unknown(line: str) -> list[str]:
    """The words of ``follicle LINE`` that are not its command or that command's options
    (empty when the command line parses)."""
    from follicle.cli import main

    words = line.split()
    command = main
    if words and not words[0].startswith("-"):
        command = main.commands.get(words[0])
        if not isinstance(command, click.Command):
            return [words[0]]
        words = words[1:]
    options = {o for p in command.get_params(click.Context(command)) for o in p.opts}
    options |= {o for p in command.params for o in p.secondary_opts}
    return [w for w in words if re.match(r"^--?[A-Za-z]", w) and w.split("=")[0] not in options]


def test_each_follicle_command_in_the_docs_names_a_command_and_its_options():
    """`follicle CMD --opt …` in a bash block: CMD is a command (its `--help` exists) and
    each --opt / -o is one of its options; a misspelt or removed option fails."""
    commands = _commands()
    assert len(commands) >= 30, len(commands)
    wrong = [(page, line, _unknown(line)) for page, line in commands if _unknown(line)]
    assert wrong == []


def test_the_command_check_catches_a_wrong_command_or_option():
    assert _unknown("grow scene.toml -o hair.usdc --target unreal --count 5") == []
    assert _unknown("grow scene.toml --motion nod") == ["--motion"]
    assert _unknown("simulate scene.toml --motion nod --frame 4") == ["--frame"]
    assert _unknown("grwo scene.toml") == ["grwo"]
    assert _unknown("--version") == []
