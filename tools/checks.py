"""The checks that run before the tests (the README's test command, and CI): the
formatter, the linter and the type check, each as pyproject.toml configures it, quickest
first, stopping at the first that fails.

Run from anywhere: ``python tools/checks.py``. Exit status 0 when all pass.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PATHS = ["src", "tests", "benchmarks", "examples", "tools"]
CHECKS = [
    ("ruff format", [sys.executable, "-m", "ruff", "format", "--check", "-q", *PATHS]),
    ("ruff check", [sys.executable, "-m", "ruff", "check", "-q", *PATHS]),
    ("type check", [sys.executable, str(ROOT / "tools" / "typecheck.py")]),
]


def main() -> int:
    for name, command in CHECKS:
        done = subprocess.run(command, cwd=ROOT)
        if done.returncode:
            print(f"checks: {name} failed (exit {done.returncode}); see above", file=sys.stderr)
            return done.returncode
        print(f"checks: {name} passed", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
