"""The help reads well beside the docs: every command's --help ends with examples that are
real commands (click's own parser takes them and the repository files they name exist),
nothing overflows an 80-column terminal, and `follicle docs` says where the docs are."""

from __future__ import annotations

import sys
from email.message import Message
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from cli_lines import follicle_args, parse_problem
from follicle import docs_location
from follicle.apps import procedural
from follicle.cli import main

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = main.list_commands(click.Context(main))


def _help(*command: str) -> str:
    """``follicle COMMAND --help`` as an 80-column terminal shows it: click wraps its prose
    to the terminal's width less 2, 78 columns (``COLUMNS=80 follicle --help``)."""
    done = CliRunner().invoke(main, [*command, "--help"], terminal_width=78)
    assert done.exit_code == 0, done.output
    return done.output


def _examples(text: str) -> list[str]:
    """The lines of a help's ``Example:`` / ``Examples:`` block."""
    lines = text.splitlines()
    starts = [i for i, line in enumerate(lines) if line.strip() in ("Example:", "Examples:")]
    if not starts:
        return []
    block = []
    for line in lines[starts[-1] + 1 :]:
        if not line.startswith("    "):
            break
        block.append(line.strip())
    return block


def test_every_command_has_examples_that_parse_and_name_files_that_exist():
    assert len(COMMANDS) >= 14 and "docs" in COMMANDS and "export-rib" in COMMANDS
    wrong = []
    for name in COMMANDS:
        examples = _examples(_help(name))
        if not examples:
            wrong.append((name, "no example"))
        for line in examples:
            args = follicle_args(line)
            if args is None or args[:1] != [name]:
                wrong.append((name, f"not a `follicle {name}` line: {line}"))
                continue
            problem = parse_problem(args)
            if problem:
                wrong.append((name, f"{line}: {problem}"))
            missing = [w for w in args if w.startswith("examples/") and not (ROOT / w).exists()]
            if missing:
                wrong.append((name, f"{line}: no such file {missing}"))
    assert wrong == []


def test_the_root_help_has_an_example_and_points_at_follicle_docs():
    text = _help()
    assert "`follicle docs` says where the documentation is" in " ".join(text.split())
    assert _examples(text) == [
        "follicle demo                     # long hair on a bust: follicle-demo/"
    ]
    assert parse_problem(follicle_args(_examples(text)[0]) or ["?"]) is None


def test_the_checks_catch_a_wrong_example():
    """What the test above relies on: a help without examples, a misspelt option, a bad
    value and a missing argument are each found."""
    assert _examples("Usage: follicle x\n\n  Does x.\n") == []
    assert _examples("  Examples:\n    follicle a\n    follicle b\n\n  after\n") == [
        "follicle a",
        "follicle b",
    ]
    assert follicle_args("follicle render a.toml   # a comment") == ["render", "a.toml"]
    assert follicle_args("ls -l") is None
    assert parse_problem(["render", "examples/wavy.toml", "-o", "w.png"]) is None
    assert "--sise" in (parse_problem(["render", "s.toml", "--sise", "6", "6"]) or "")
    assert "requires 2 arguments" in (parse_problem(["render", "s.toml", "--size", "6"]) or "")
    assert "'fast'" in (parse_problem(["render", "s.toml", "--engine", "fast"]) or "")
    assert "not a valid integer" in (parse_problem(["grow", "s.toml", "--count", "many"]) or "")
    assert "Missing argument" in (parse_problem(["grow"]) or "")
    assert parse_problem(["grwo", "s.toml"]) == "no such command: grwo"


def test_every_help_fits_an_80_column_terminal():
    """Click wraps the prose to 78 columns; the example lines, kept as written (``\\b``),
    must fit too."""
    long = []
    for command in ([], *([name] for name in COMMANDS)):
        for line in _help(*command).splitlines():
            if len(line) > 78:
                long.append((command, line))
    assert long == []


def test_docs_says_where_the_docs_are_one_fact_a_line():
    done = CliRunner().invoke(main, ["docs"])
    assert done.exit_code == 0, done.output
    lines = done.output.splitlines()
    facts = [line.split(":")[0] for line in lines]
    assert facts[:3] == ["site", "source", "serve"] and facts[-2:] == ["reference", "here"]
    # the Documentation URL pyproject.toml names (the oracle: the file itself), as the
    # install's metadata has it
    urls = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["urls"]
    assert lines[0] == f"site: {urls['Documentation']}"
    # this checkout: its docs/ folder, served from its root by mkdocs
    assert lines[1] == f"source: {ROOT / 'docs'} (Markdown; start at index.md)"
    assert (ROOT / "docs" / "index.md").is_file() and (ROOT / "mkdocs.yml").is_file()
    assert lines[2].startswith(f"serve: cd {ROOT} && {sys.executable} -m mkdocs serve, ")


def test_docs_without_a_checkout_and_with_a_url():
    """An installed wheel (no docs/ beside the package) whose metadata names a site."""
    lines = docs_location.where_lines("https://follicle.example/docs", None)
    assert lines[0] == "site: https://follicle.example/docs"
    assert lines[1].startswith("source: not in this install (a wheel ships no docs)")
    assert not any(line.startswith("serve:") for line in lines)


def test_the_site_url_comes_from_the_package_metadata(monkeypatch: pytest.MonkeyPatch):
    meta = Message()
    meta["Project-URL"] = "Source, https://example.org/follicle"
    meta["Project-URL"] = "Documentation, https://example.org/follicle/docs"
    monkeypatch.setattr(docs_location.metadata, "metadata", lambda name: meta)
    assert docs_location.site_url() == "https://example.org/follicle/docs"
    del meta["Project-URL"]
    meta["Project-URL"] = "Source, https://example.org/follicle"
    assert docs_location.site_url() is None


def test_follicle_procedural_has_a_help_and_refuses_arguments(capsys: pytest.CaptureFixture):
    procedural.main(["--help"])
    shown = capsys.readouterr().out
    assert shown.startswith("usage: follicle-procedural\n")
    assert "follicle export-rib" in shown and "| follicle-procedural > voxel84.rib" in shown
    with pytest.raises(SystemExit) as stop:
        procedural.main(["--voxels"])
    assert stop.value.code == 2
    assert "takes no arguments" in capsys.readouterr().err


@pytest.mark.slow
def test_help_and_docs_under_a_terminal(tmp_path: Path):
    """In a pseudo-terminal (no CliRunner): the help's examples come out as written, and
    `follicle docs` says the same lines."""
    from hostile import run_cli

    shown = run_cli("render", "--help", cwd=tmp_path, tty=True, timeout=120)
    assert shown.rc == 0, shown.stdout
    text = shown.stdout.replace("\r\n", "\n")
    assert _examples(text) == _examples(_help("render"))
    docs = run_cli("docs", cwd=tmp_path, tty=True, timeout=120)
    assert docs.rc == 0, docs.stdout
    assert (
        docs.stdout.replace("\r\n", "\n").splitlines()
        == CliRunner().invoke(main, ["docs"]).output.splitlines()
    )
