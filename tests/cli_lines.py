"""`follicle …` command lines as the docs' bash blocks and the commands' help examples
write them: the arguments of a line, and whether click's own parser takes them."""

from __future__ import annotations

import os
import re
import shlex

import click


def follicle_args(line: str) -> list[str] | None:
    """The arguments of the ``follicle`` command on a shell ``line``, or None when the
    line runs something else. A trailing ``# comment``, what comes before ``&&``, and
    ``VAR=value`` and ``…/python`` words before the command are dropped."""
    line = line.split(" #")[0].split("&&")[-1].strip()
    words = shlex.split(line)
    while words and (re.match(r"^\w+=", words[0]) or words[0].endswith("/python")):
        words.pop(0)  # VAR=value, .venv/bin/python -m …
    if words and os.path.basename(words[0]) == "follicle":
        return words[1:]
    return None


def parse_problem(args: list[str]) -> str | None:
    """Why ``follicle ARGS`` would not parse (an unknown command or option, a value of
    the wrong type or choice, a missing or extra argument), or None when it does: the
    command's own ``make_context``, the parser click runs before a command, and nothing
    run but an eager option's callback (``--help`` prints the help). Options before the
    command must be the group's (``-v``, ``--version``)."""
    from follicle.cli import main

    ctx = click.Context(main, info_name="follicle", **main.context_settings)
    words = list(args)
    group_options = {o for p in main.get_params(ctx) for o in p.opts}
    while words and words[0].startswith("-"):
        if words.pop(0) not in group_options:
            return f"no such option of follicle: {args[len(args) - len(words) - 1]}"
    if not words:
        return None
    command = main.get_command(ctx, words[0])
    if command is None:
        return f"no such command: {words[0]}"
    try:
        with command.make_context(words[0], words[1:], parent=ctx):
            return None
    except click.exceptions.Exit as exc:  # --help, its work done while parsing
        return None if exc.exit_code == 0 else f"exit {exc.exit_code}"
    except click.ClickException as exc:
        return exc.format_message()
