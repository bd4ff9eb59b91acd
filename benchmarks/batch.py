"""Throughput of a batch of grooms: `follicle batch --scheduler local:2` against the serial
`follicle batch` (one process, its kernels threaded), the same 100 variants and machine.

The sweep is the issue's: five curl radii × 20 seeds of the default scene, each
variant grown (``--count`` hairs), written to USD and rendered to a PNG. Both are run as
a user runs them, in a fresh process each (start-up, the cluster's included),
alternating so that a neighbour's load falls on both, and the two batch folders are
checked to be the same bytes, manifest included (the target: ≥ 1.7× the serial
throughput). Run:
``.venv/bin/python benchmarks/batch.py [--count 10000] [--seeds 20] [--size 320 240]``.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

from common import follicle, runs, same_output


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=10_000, help="hairs a variant (10,000)")
    parser.add_argument("--seeds", type=int, default=20, help="seeds a curl radius (20)")
    parser.add_argument("--size", type=int, nargs=2, default=(320, 240), help="W H (320 240)")
    parser.add_argument("--curves", default=".usdc", help="hair file (default .usdc)")
    parser.add_argument("--workers", type=int, default=2, help="local workers (default 2)")
    parser.add_argument("--repeat", type=int, default=2, help="runs of each (default 2)")
    args = parser.parse_args()
    w, h = args.size
    sweep = ["--vary", "groom.curl_radius=0.002:0.01:5", "--seeds", f"0:{args.seeds}"]
    what = ["--count", str(args.count), "--size", str(w), str(h), "--curves", args.curves]
    n = 5 * args.seeds
    with tempfile.TemporaryDirectory(prefix="follicle-bench-") as tmp:
        folder = Path(tmp)
        follicle(folder, "batch", "-o", "warm", "--seeds", "0:2", *what)  # numba's cache
        one, many = [], []
        for _ in range(args.repeat):
            for name in ("one", "many"):
                shutil.rmtree(folder / name, ignore_errors=True)
            one.append(follicle(folder, "batch", "-o", "one", *sweep, *what))
            scheduler = ["--scheduler", f"local:{args.workers}"]
            many.append(follicle(folder, "batch", "-o", "many", *sweep, *what, *scheduler))
            assert same_output(folder / "one", folder / "many"), "the batches differ"
    print(
        f"{n} variants of {args.count:,} hairs ({args.curves} and a {w}×{h} PNG each),"
        f" best of {args.repeat}:"
    )
    print(
        f"  serial               {min(one):7.2f} s  {n / min(one):5.2f} variants/s  ({runs(one)})"
    )
    print(
        f"  --scheduler local:{args.workers}  {min(many):7.2f} s  {n / min(many):5.2f} variants/s"
        f"  ({runs(many)})"
    )
    print(f"  throughput           {min(one) / min(many):7.2f}×  (target ≥ 1.7×)")


if __name__ == "__main__":
    main()
