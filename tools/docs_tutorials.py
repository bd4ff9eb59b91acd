"""The docs' tutorials: Python scripts (``docs/tutorials/*.py``) that the docs build runs
and turns into pages, so every command and call a tutorial shows was run, and every
picture it shows was made, by the build that published it (``tools/mkdocs_hooks.py``).

A tutorial is a plain script a reader can download and run. Its docstring is the page's
title (first line) and introduction; ``# %%`` lines cut the rest into cells. A cell's
leading comment lines are Markdown prose, the lines after them its code, shown as a
``python`` block with what the code printed below it. A cell whose code is only
``sh("...")`` calls is shown as a ``bash`` block of those commands (``sh`` runs a shell
command as the page shows it and stops the script when it fails: ``expect=1`` for a
command meant to exit 1). A ``# %% [setup]`` cell runs but is not shown (the helpers
the page does not need to explain). The script writes its pictures into its working
folder, and the prose shows them by name (``![a torus with fur](fur.png)``): the build
puts them beside the page, and a picture the prose names that the script did not make
fails the build, as does a cell that raises.

``run(script, workdir)`` runs a script cell by cell in a child process
(``python tools/docs_tutorials.py SCRIPT [OUT.json]``, in ``workdir``: how a reader
runs a tutorial too, in an empty folder), ``run_shown`` also reads the pictures its
page shows, and ``page(script, ran, folder)`` writes its Markdown. The conventions
shared with the gallery (commands, pool, skip, errors) are :mod:`docs_runs`'s.
"""

from __future__ import annotations

import ast
import contextlib
import io
import json
import re
import subprocess
import sys
import traceback
from dataclasses import asdict, dataclass
from pathlib import Path

from docs_runs import PICTURE, RunError, argv, not_made, run_child

__all__ = ["Cell", "TutorialError", "cells", "page", "pictures_named", "run", "run_shown"]

_CUT = re.compile(r"^# %%(?:\s*\[(\w+)\])?\s*$")
_SH = re.compile(r"""^sh\((?P<q>["'])(?P<cmd>.*?)(?P=q)(?:,\s*expect=(?P<rc>\d+))?\)\s*$""")


# the once-per-machine notice of a cold numba cache: the page shows what a reader sees
# every time, not what depended on the build machine's cache
_COMPILING = "compiling follicle's kernels for this machine, once"


class TutorialError(RunError):
    """A tutorial that failed: the script, the cell and the traceback or the reason."""


@dataclass(frozen=True)
class Cell:
    """One cell of a tutorial: its prose (Markdown), code, and kind (``"python"``,
    ``"bash"`` when its code is only ``sh`` calls, ``"setup"`` when hidden); ``line``
    is the script line its code starts on."""

    prose: str
    code: str
    kind: str
    line: int


def cells(source: str) -> tuple[str, list[Cell]]:
    """The script's docstring and its cells, in order."""
    tree = ast.parse(source)
    doc = ast.get_docstring(tree) or ""
    if not doc:
        raise TutorialError("a tutorial starts with a docstring: its title, then its introduction")
    lines = source.splitlines()
    first = tree.body[0].end_lineno or 1  # the docstring's last line
    out: list[Cell] = []
    block: list[str] = []
    tag, start = None, first + 1

    def close() -> None:
        prose: list[str] = []
        body = list(block)
        while body and (body[0].startswith("#") or not body[0].strip()):
            text = body.pop(0)
            prose.append(text[2:] if text.startswith("# ") else text.lstrip("#"))
        while body and not body[-1].strip():
            body.pop()
        code = "\n".join(body)
        if not code and not "".join(prose).strip():
            return
        calls = [ln for ln in body if ln.strip()]
        kind = "setup" if tag == "setup" else "python"
        if kind == "python" and calls and all(_SH.match(ln) for ln in calls):
            kind = "bash"
        out.append(Cell("\n".join(prose).strip("\n"), code, kind, start + len(prose)))

    for number, text in enumerate(lines[first:], start=first + 1):
        cut = _CUT.match(text)
        if cut:
            close()
            block, tag, start = [], cut.group(1), number + 1
        else:
            block.append(text)
    close()
    return doc, out


def sh(command: str, expect: int = 0) -> None:
    """Run ``command`` (split as a shell would, no shell features; ``follicle`` is the
    one beside this Python: :func:`docs_runs.argv`) and print what it printed; raise
    when it exits other than ``expect``."""
    done = subprocess.run(argv(command), capture_output=True, text=True, timeout=600)
    printed = (done.stdout + done.stderr).splitlines()
    print("\n".join(ln for ln in printed if _COMPILING not in ln))
    if done.returncode != expect:
        raise TutorialError(f"`{command}` exited {done.returncode}, not {expect}")


def _execute(script: Path) -> list[dict[str, str | int]]:
    """Run the cells of ``script`` in one namespace, here, and what each printed."""
    _, parts = cells(script.read_text(encoding="utf-8"))
    space: dict[str, object] = {"__name__": "__main__", "__file__": str(script), "sh": sh}
    done: list[dict[str, str | int]] = []
    for cell in parts:
        printed = io.StringIO()
        try:
            with contextlib.redirect_stdout(printed):
                code = compile("\n" * (cell.line - 1) + cell.code, str(script), "exec")
                exec(code, space)  # noqa: S102 - running the tutorial is the point
        except BaseException:  # noqa: BLE001 - reported whole to the build
            raise TutorialError(
                f"{script.name}, the cell at line {cell.line}:\n{printed.getvalue()}"
                f"{traceback.format_exc()}"
            ) from None
        done.append({**asdict(cell), "output": printed.getvalue().rstrip()})
    return done


def run(script: Path, workdir: Path, timeout: float = 600) -> list[dict[str, str | int]]:
    """Run ``script`` in a child process in ``workdir``; its cells with their output.
    Raises TutorialError with the failing cell's traceback."""
    out = workdir / ".cells.json"
    script_args = [str(Path(__file__).resolve()), str(script.resolve()), str(out)]
    done = run_child([sys.executable, *script_args], workdir, timeout)
    if done.returncode != 0:
        raise TutorialError(
            f"tutorial {script.name} failed:\n{done.stdout[-4000:]}{done.stderr[-6000:]}"
        )
    return json.loads(out.read_text(encoding="utf-8"))


def run_shown(script: Path, workdir: Path) -> tuple[list[dict[str, str | int]], dict[str, bytes]]:
    """:func:`run`, and the pictures the page shows, read from ``workdir`` (name ->
    PNG bytes). Raises TutorialError when one the prose names was not made."""
    ran = run(script, workdir)
    shown = pictures_named("\n".join(str(c["prose"]) for c in ran))
    missing = [p for p in shown if not (workdir / p).is_file()]
    if missing:
        raise TutorialError(f"tutorial {script.name} shows {missing} but did not make them")
    return ran, {p: (workdir / p).read_bytes() for p in shown}


def pictures_named(markdown: str) -> list[str]:
    """The relative picture paths a page's Markdown shows."""
    return [p for p in PICTURE.findall(markdown) if "://" not in p and not p.startswith("../")]


def page(script: Path, ran: list[dict[str, str | int]] | None, folder: str) -> str:
    """The Markdown page of ``script``: its docstring, then each shown cell's prose,
    code and output; ``ran`` None (not run) leaves outputs and pictures out. Pictures
    are named as in ``folder``/ (the page's pictures, beside it)."""
    doc, parts = cells(script.read_text(encoding="utf-8"))
    title, _, intro = doc.partition("\n")
    outputs = [str(c["output"]) for c in ran] if ran is not None else [""] * len(parts)
    text = [f"# {title.strip()}", "", intro.strip(), ""]
    text.append(
        f"*This page is [`{script.name}`]({script.name}), run by the docs build: every "
        "command and its output below, and every picture, come from that run (its timings "
        "are those of the machine that built the page). To run it yourself, in an empty "
        f"folder: `python FOLLICLE/tools/docs_tutorials.py {script.name}`, FOLLICLE being "
        "follicle's repository (the runner gives the "
        "script its `sh`).*\n"
    )
    for cell, output in zip(parts, outputs, strict=True):
        if cell.kind == "setup":
            continue
        prose = cell.prose
        if ran is None:
            prose = PICTURE.sub(lambda m: _beside(m, None), prose)
        else:
            prose = PICTURE.sub(lambda m: _beside(m, folder), prose)
        if prose:
            text += [prose, ""]
        if cell.code:
            if cell.kind == "bash":
                lines = []
                for ln in cell.code.splitlines():
                    call = _SH.match(ln)
                    if call:
                        rc = call.group("rc")
                        lines.append(call.group("cmd") + (f"   # exits {rc}" if rc else ""))
                text += ["```bash", *lines, "```", ""]
            else:
                text += ["```python", cell.code, "```", ""]
        if output:
            text += ["```text", output, "```", ""]
    return "\n".join(text)


def _beside(match: re.Match[str], folder: str | None) -> str:
    """A picture of the prose as the page shows it: one the script made, in ``folder``
    (None: not made, a note says so); one of the docs (``../``), as it is."""
    name = match.group(1)
    if name.startswith("../") or "://" in name:
        return match.group(0)
    if folder is None:
        return not_made(name, "the tutorials")
    return match.group(0).replace(f"({name})", f"({folder}/{name})")


if __name__ == "__main__":  # the child process of run()
    result = _execute(Path(sys.argv[1]))
    if len(sys.argv) > 2:
        Path(sys.argv[2]).write_text(json.dumps(result), encoding="utf-8")
