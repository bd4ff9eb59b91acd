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
import filecmp
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _follicle(folder: Path, *args: str) -> float:
    """Seconds of one `follicle ARGS…` in a fresh process."""
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "follicle.cli", *args],
        cwd=folder,
        check=True,
        stdout=subprocess.DEVNULL,
    )
    return time.perf_counter() - start


def _same(a: Path, b: Path) -> bool:
    """Whether two outputs (files, or folders of frames) hold the same bytes."""
    if a.is_file():
        return filecmp.cmp(a, b, shallow=False)
    names = sorted(p.name for p in a.iterdir())
    if names != sorted(p.name for p in b.iterdir()):
        return False
    return all(filecmp.cmp(a / n, b / n, shallow=False) for n in names)


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
        _follicle(folder, "simulate", "s.toml", "--frames", str(args.frames), "-o", "sim.npz")
        _follicle(folder, "render", "sim.npz", "-o", "warm", "--frames", "0:2", *render)
        one, many = [], []
        for _ in range(args.repeat):
            one.append(_follicle(folder, "render", "sim.npz", "-o", out.format("one"), *render))
            many.append(
                _follicle(
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
            assert _same(a, b), "the cluster's frames differ from the single process's"
            shutil.rmtree(b) if b.is_dir() else b.unlink()
    n, (w, h) = args.frames, args.size
    what = "an .mp4" if args.video else "PNGs"
    print(
        f"{n} frames of 20,000 hairs at {w}×{h} ({args.engine}) to {what}, best of {args.repeat}:"
    )
    print(f"  one process          {min(one):6.2f} s  {n / min(one):5.1f} frames/s  ({_runs(one)})")
    print(
        f"  --scheduler local:{args.workers} {min(many):6.2f} s  {n / min(many):5.1f} frames/s"
        f"  ({_runs(many)})"
    )
    print(f"  speed-up             {min(one) / min(many):6.2f}×  (cluster start-up included)")


def _runs(times: list[float]) -> str:
    return ", ".join(f"{t:.2f}" for t in times)


if __name__ == "__main__":
    main()
