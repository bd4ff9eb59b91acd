"""Format benchmark: write and read every registered curves format, one run.

Workload: the default scene's groom (built-in head, ``builtin:long`` guides) grown with
``[groom] vertices = 16``, so every hair has exactly 16 vertices, each with width,
colour, opacity and normal (the groom's own attributes), 1,000,000 hairs by default.
For every extension in ``follicle.io.dispatch.WRITERS`` (the USD and RIB writers
included when registered) it times a write and, where a reader exists, a read, and
prints the file size and the rate in MB/s of hair data: points, width, colour and
opacity as float32, 32 bytes a vertex, the same numerator for every format. The
same-run baseline is ``np.save`` / ``np.load`` of those four arrays (memory and disk
bandwidth; best of 3, it is quick), and every format's time is printed as a ratio to
it. Formats are timed ``--repeat`` times (default once), best kept. Files go to a
temporary folder. Run: ``.venv/bin/python benchmarks/formats.py [--count N]``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from common import best_of
from follicle.curves import HairCurves
from follicle.io.dispatch import READERS, WRITERS, load_curves, save
from follicle.pipeline import groom_scene
from follicle.scene import parse_scene

DATA = ("width", "color", "opacity")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--count", type=int, default=1_000_000, help="hairs (default 1 M)")
    parser.add_argument("--repeat", type=int, default=1, help="timings per format, best kept")
    args = parser.parse_args()

    groom = groom_scene(parse_scene({"groom": {"vertices": 16}}, "benchmark"))
    curves = groom.generate(count=args.count)
    arrays = [curves.points, *(curves.point_data[k] for k in DATA)]
    data_mb = sum(a.nbytes for a in arrays) / 1e6
    counts = np.unique(curves.counts).tolist()
    print(
        f"{curves.curve_count:,} hairs × {counts} vertices, {curves.point_count:,} points;"
        f" hair data (points, width, colour, opacity) {data_mb:.0f} MB"
    )

    with tempfile.TemporaryDirectory(prefix="follicle-formats-") as tmp:
        folder = Path(tmp)
        warm = curves[:10]
        for ext in WRITERS:  # compile the numba kernels (cached) before timing
            save(warm, folder / f"warm{ext}")
            if ext in READERS:
                load_curves(folder / f"warm{ext}")

        paths = [folder / f"base{i}.npy" for i in range(len(arrays))]
        base_w = best_of(lambda: [np.save(p, a) for p, a in zip(paths, arrays, strict=True)])
        base_r = best_of(lambda: [np.load(p) for p in paths])
        base_mb = sum(p.stat().st_size for p in paths) / 1e6

        print(
            f"\n{'format':<8} {'file MB':>9} {'write s':>8} {'MB/s':>7} {'× np.save':>9}"
            f" {'read s':>8} {'MB/s':>7} {'× np.load':>9}"
        )
        print(
            f"{'np.save':<8} {base_mb:9.0f} {base_w:8.2f} {data_mb / base_w:7.0f} {1:9.1f}"
            f" {base_r:8.2f} {data_mb / base_r:7.0f} {1:9.1f}"
        )
        for ext in sorted(WRITERS):
            print(
                _row(ext, curves, folder / f"hair{ext}", data_mb, base_w, base_r, args.repeat),
                flush=True,
            )


def _row(
    ext: str,
    curves: HairCurves,
    path: Path,
    data_mb: float,
    base_w: float,
    base_r: float,
    repeat: int,
) -> str:
    """One table row: write (and read) ``curves`` as ``ext``; errors are printed, not raised."""
    try:
        write = best_of(lambda: save(curves, path), repeat)
        size = path.stat().st_size / 1e6
        row = f"{ext:<8} {size:9.0f} {write:8.2f} {data_mb / write:7.0f} {write / base_w:9.1f}"
        if ext in READERS:
            read = best_of(lambda: load_curves(path), repeat)
            row += f" {read:8.2f} {data_mb / read:7.0f} {read / base_r:9.1f}"
        else:
            row += f" {'(write only)':>26}"
        path.unlink()
        return row
    except Exception as exc:  # a format that fails should not hide the others
        return f"{ext:<8} failed: {type(exc).__name__}: {exc}"


if __name__ == "__main__":
    main()
