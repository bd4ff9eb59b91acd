"""Rendering a simulation cache's frames on a Dask cluster: `follicle render CACHE
--scheduler local:N` against the single-process `follicle render CACHE`, the same
cache, frames and machine.

Both are run as a user runs them, as `follicle render` commands in a fresh process
each (start-up and, for the cluster, its workers' start-up included), alternating so
that a neighbour's load falls on both; the frames (or the video) are checked to be the
same bytes. The cache is the default scene (20,000 hairs on the built-in head's 300
guides) turning its head, simulated once. Run:
``.venv/bin/python benchmarks/render_frames.py [--frames 48] [--size 320 240] [--video]``.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

from common import follicle, runs, same_output


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=48, help="cache frames (default 48)")
    parser.add_argument("--size", type=int, nargs=2, default=(320, 240), help="W H (320 240)")
    parser.add_argument("--workers", type=int, default=2, help="local workers (default 2)")
    parser.add_argument("--engine", default="cpu", help="render engine (default cpu)")
    parser.add_argument("--video", action="store_true", help="render to .mp4, not PNGs")
    parser.add_argument("--repeat", type=int, default=2, help="runs of each (default 2)")
    args = parser.parse_args()
    size = [str(v) for v in args.size]
    render = ["--size", *size, "--engine", args.engine]
    out = "{}.mp4" if args.video else "{}"
    with tempfile.TemporaryDirectory(prefix="follicle-bench-") as tmp:
        folder = Path(tmp)
        (folder / "s.toml").write_text('[sim]\nmotion = "turn"\n')
        follicle(folder, "simulate", "s.toml", "--frames", str(args.frames), "-o", "sim.npz")
        follicle(folder, "render", "sim.npz", "-o", "warm", "--frames", "0:2", *render)
        one, many = [], []
        for _ in range(args.repeat):
            one.append(follicle(folder, "render", "sim.npz", "-o", out.format("one"), *render))
            many.append(
                follicle(
                    folder,
                    "render",
                    "sim.npz",
                    "-o",
                    out.format("many"),
                    *render,
                    "--scheduler",
                    f"local:{args.workers}",
                )
            )
            a, b = folder / out.format("one"), folder / out.format("many")
            assert same_output(a, b), "the cluster's frames differ from the single process's"
            shutil.rmtree(b) if b.is_dir() else b.unlink()
    n, (w, h) = args.frames, args.size
    what = "an .mp4" if args.video else "PNGs"
    print(
        f"{n} frames of 20,000 hairs at {w}×{h} ({args.engine}) to {what}, best of {args.repeat}:"
    )
    print(f"  one process          {min(one):6.2f} s  {n / min(one):5.1f} frames/s  ({runs(one)})")
    print(
        f"  --scheduler local:{args.workers} {min(many):6.2f} s  {n / min(many):5.1f} frames/s"
        f"  ({runs(many)})"
    )
    print(f"  speed-up             {min(one) / min(many):6.2f}×  (cluster start-up included)")


if __name__ == "__main__":
    main()
