"""What a fresh interpreter has imported after running some code: the tests that keep
``import follicle``, ``--help`` and light file formats free of heavy libraries."""

from __future__ import annotations

import json
import os
import subprocess
import sys

HEAVY = ("numba", "llvmlite", "pxr", "alembic", "dask", "distributed", "mitsuba", "moderngl")


def modules_after(code: str, names: tuple[str, ...] = HEAVY) -> list[str]:
    """The top-level packages of ``names`` that a new ``python -c code`` holds at its end."""
    out = subprocess.run(
        [sys.executable, "-c", f"{code}\nimport sys, json\nprint(json.dumps(sorted(sys.modules)))"],
        capture_output=True,
        text=True,
        env={**os.environ, "COLUMNS": "100"},
    )
    assert out.returncode == 0, out.stderr
    loaded = json.loads(out.stdout.strip().splitlines()[-1])
    return sorted({name.split(".")[0] for name in loaded} & set(names))
