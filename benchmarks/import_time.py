"""``import follicle`` and a first ``follicle.save`` to .npz, warm, each in a fresh
interpreter, beside ``import numpy`` in the same run (the floor: follicle needs numpy).

The issue "The house for the next builders" asks both to stay under 1 s warm. Each figure
is the median of ``--repeat`` runs of a new ``python -c`` (start-up included), and the
ratio to numpy's import is printed beside it.

Run: ``.venv/bin/python benchmarks/import_time.py [--repeat 7]``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CASES = {
    "python -c pass (start-up)": "pass",
    "import numpy (baseline)": "import numpy",
    "import follicle": "import follicle",
    "import follicle; follicle.save(…, 'x.npz')": (
        "import numpy as np, follicle\n"
        "c = follicle.HairCurves(np.zeros((6, 3), np.float32), np.array([0, 3, 6]))\n"
        "follicle.save(c, {path!r})"
    ),
}


def _seconds(code: str) -> float:
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / "x.npz")
        codes = {name: code.format(path=path) for name, code in CASES.items()}
        for code in codes.values():
            _seconds(code)  # warm: bytecode and the OS's file cache
        times = {
            name: statistics.median(_seconds(c) for _ in range(args.repeat))
            for name, c in codes.items()
        }
    base = times["import numpy (baseline)"]
    print(f"{'':46s} {'seconds':>8s} {'× numpy':>8s}")
    for name, seconds in times.items():
        print(f"{name:46s} {seconds:8.3f} {seconds / base:8.2f}")


if __name__ == "__main__":
    main()
