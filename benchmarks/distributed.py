"""The overhead of growing on a Dask cluster: `follicle grow --scheduler local:2` against
the threaded single-process `follicle grow`, the same scene, file and machine, in both
USD layouts.

Each run is a `follicle grow` command in a fresh process, as a user runs it (start-up,
the cluster's included), the four kinds alternating so that a neighbour's load falls on
all of them; each cluster's output is checked to be the same bytes as the
single-process one of its layout. The issue's target is the cluster's grow within 1.3×
of the threaded one-process grow of one file (4 M hairs to USD):

- ``--layout file``: the client writes the one file, the workers only grow; its single
  crate writer is the critical path and shares the 2 cores with the workers.
- ``--layout payloads``: each worker also writes the part files it grows and the client
  only the root layer, so the writing is split between the workers as the growing is.

Run: ``.venv/bin/python benchmarks/distributed.py [--count 4000000] [--ext .usdc]``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from common import follicle, runs, same_output


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=4_000_000, help="hairs (default 4 M)")
    parser.add_argument("--ext", default=".usdc", help="output format (default .usdc)")
    parser.add_argument("--workers", type=int, default=2, help="local workers (default 2)")
    parser.add_argument("--repeat", type=int, default=2, help="runs of each (default 2)")
    args = parser.parse_args()
    cluster = ("--scheduler", f"local:{args.workers}")
    kinds = {
        "one process, one file": ("file", ()),
        f"local:{args.workers}, one file": ("file", cluster),
        "one process, payloads": ("payloads", ()),
        f"local:{args.workers}, payloads": ("payloads", cluster),
    }
    times: dict[str, list[float]] = {kind: [] for kind in kinds}
    with tempfile.TemporaryDirectory(prefix="follicle-bench-") as tmp:
        folder = Path(tmp)
        (folder / "s.toml").write_text(f"[groom]\ncount = {args.count}\n")
        follicle(folder, "grow", "s.toml", "-o", f"warm{args.ext}", "--count", "1000")
        for _ in range(args.repeat):
            for i, (kind, (layout, extra)) in enumerate(kinds.items()):
                out = folder / str(i)
                out.mkdir(exist_ok=True)
                times[kind].append(
                    follicle(
                        folder,
                        "grow",
                        "s.toml",
                        "-o",
                        f"{i}/h{args.ext}",
                        "--layout",
                        layout,
                        *extra,
                    )
                )
            for one, many in ((0, 1), (2, 3)):
                same = same_output(folder / str(one), folder / str(many))
                assert same, f"run {many}'s output differs from the single-process one"
        size = sum(p.stat().st_size for p in (folder / "0").rglob("*") if p.is_file())
    base = min(times["one process, one file"])
    print(f"{args.count:,} hairs → {args.ext} ({size / 1e6:,.0f} MB), best of {args.repeat}:")
    for kind, seconds in times.items():
        ratio = min(seconds) / base
        print(f"  {kind:<26} {min(seconds):7.2f} s  {ratio:5.2f}×  (runs: {runs(seconds)})")
    print("  ratios against one process writing one file (target for a cluster: ≤ 1.3×)")


if __name__ == "__main__":
    main()
