"""``python -m follicle``: the ``follicle`` command, for where its script is not on PATH."""

from .cli import main

main(prog_name="follicle")
