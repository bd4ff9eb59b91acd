"""The first minute of a new user: each first command timed cold (an empty numba cache)
and warm, on a non-editable install of a wheel built from this repository, in a fresh
virtual environment, each run a new process.

For each command: the cold run's seconds, the warm run's (the same cache, second run),
the share of the cold run spent compiling numba kernels and the kernels it compiled
(``compile_probe.py`` listens to numba's compile events; the seconds are the
process's wall time, Python's start-up included), and the target of the issue
"The first minute": cold ≤ 1.5 × warm + 5 s. ``--baseline`` runs each command cold once
more with ``NUMBA_CPU_NAME=generic``, for which the wheel ships no kernels: what a first
run costs where everything compiles on first use (a source install, another numba) —
the same-run baseline of the prebuilt kernels. ``--first-command`` times the README's
first line on a fresh venv: the install (from the wheel, and editable from a clean clone
of HEAD) and ``follicle demo`` after it.

Run: ``.venv/bin/python benchmarks/cold_start.py [--wheel W.whl] [--baseline]
[--first-command] [--keep DIR]``. The wheel is built with ``pip wheel --no-deps
--no-build-isolation`` (reusing ``src/follicle/_kernels`` when it is fresh) unless given.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROBE = Path(__file__).resolve().parent / "compile_probe.py"
SCENE = "[groom]\ncount = 2000\n"
COMMANDS: list[tuple[str, list[str]]] = [
    ("import follicle", ["--import"]),
    ("follicle --help", ["--help"]),
    ("follicle demo", ["demo", "--out", "demo"]),
    ("follicle simulate (12 frames, 2,000 hairs)", ["simulate", "s.toml", "--frames", "12"]),
    ("follicle render --engine cpu (20,000 hairs, 960²)", ["render", "r.toml", "--engine", "cpu"]),
    (
        "follicle view --offscreen --frames 10 --screenshot",
        ["view", "s.toml", "--offscreen", "--frames", "10", "--screenshot", "v.png"],
    ),
    ("follicle groom (the hand-groomed example's strokes)", ["groom", "strokes.json"]),
    ("follicle grow -o x.abc (20,000 hairs)", ["grow", "r.toml", "-o", "x.abc"]),
]
OUTPUTS = {"simulate": "sim.npz", "render": "r.png", "groom": "g.npz"}


def build_wheel(folder: Path) -> Path:
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation"]
        + ["-q", "-w", str(folder)],
        check=True,
    )
    return next(folder.glob("follicle-*.whl"))


def fresh_venv(folder: Path, *install: str) -> tuple[Path, float]:
    """A new virtual environment with ``pip install INSTALL…``: its bin folder and the
    seconds the environment and the install took."""
    start = time.perf_counter()
    venv.EnvBuilder(with_pip=True, clear=True).create(folder)
    subprocess.run([folder / "bin" / "pip", "install", "-q", *install], check=True)
    return folder / "bin", time.perf_counter() - start


def probe(bin_: Path, work: Path, cache: Path, args: list[str], **env: str) -> dict:
    """One run of ``args`` by the probe in a new process: its report."""
    out = ["-o", OUTPUTS[args[0]]] if args[0] in OUTPUTS else []
    report = work / "probe.json"
    environ = {**os.environ, "NUMBA_CACHE_DIR": str(cache), **env}
    environ.pop("PYTHONPATH", None)
    start = time.perf_counter()
    done = subprocess.run(
        [bin_ / "python", PROBE, report, *args, *out],
        cwd=work,
        env=environ,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    if done.returncode != 0:
        raise RuntimeError(f"{args}: exit {done.returncode}\n{done.stderr[-2000:]}")
    # the wall time of the whole process, interpreter start-up included, as a user sees it
    return {**json.loads(report.read_text()), "seconds": time.perf_counter() - start}


def workspace(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "s.toml").write_text(SCENE)
    (folder / "r.toml").write_text("")
    shutil.copy(ROOT / "examples" / "hand_groomed.strokes.json", folder / "strokes.json")
    return folder


def measure(bin_: Path, tmp: Path, baseline: bool) -> list[dict]:
    rows = []
    for k, (label, args) in enumerate(COMMANDS):
        work = workspace(tmp / f"case{k}")
        cache = tmp / f"cache{k}"
        cache.mkdir()
        cold = probe(bin_, work, cache, args)
        warm = probe(bin_, work, cache, args)
        row = {"command": label, "cold": cold, "warm": warm}
        if baseline:
            generic = tmp / f"generic{k}"
            generic.mkdir()
            row["baseline"] = probe(bin_, work, generic, args, NUMBA_CPU_NAME="generic")
        rows.append(row)
        print(f"  {label}: cold {cold['seconds']:.2f} s, warm {warm['seconds']:.2f} s", flush=True)
    return rows


def table(rows: list[dict], baseline: bool) -> str:
    head = "| command | cold s | warm s | target (1.5 × warm + 5 s) | compile share | kernels |"
    lines = [head, "|---|---|---|---|---|---|"]
    if baseline:
        lines[0] += " without prebuilt kernels: cold s | compile share | kernels |"
        lines[1] += "---|---|---|"
    for row in rows:
        cold, warm = row["cold"], row["warm"]
        limit = 1.5 * warm["seconds"] + 5.0
        verdict = "met" if cold["seconds"] <= limit else "missed"
        share = cold["compile_seconds"] / cold["seconds"]
        line = (
            f"| `{row['command']}` | {cold['seconds']:.2f} | {warm['seconds']:.2f} |"
            f" ≤ {limit:.1f}: {verdict} | {share:.0%} | {len(cold['kernels'])} |"
        )
        if baseline:
            base = row["baseline"]
            outer = [r for r in base["kernels"] if r["outermost"]]
            line += (
                f" {base['seconds']:.1f} | {base['compile_seconds'] / base['seconds']:.0%} |"
                f" {len(outer)} ({len(base['kernels'])} with callees) |"
            )
        lines.append(line)
    return "\n".join(lines)


def kernel_lists(rows: list[dict]) -> str:
    out = []
    for row in rows:
        base = row.get("baseline")
        if base is None:
            continue
        outer = sorted((r for r in base["kernels"] if r["outermost"]), key=lambda r: -r["seconds"])
        names = ", ".join(
            f"{r['kernel'].removeprefix('follicle.')} {r['seconds']:.1f}" for r in outer
        )
        out.append(f"- `{row['command']}` compiles without prebuilt kernels (s): {names}")
    return "\n".join(out)


def first_command(wheel: Path, tmp: Path) -> str:
    """The README's first line, on a fresh venv: install, then ``follicle demo``."""
    lines = ["| install | venv + pip install s | follicle demo s | total s |", "|---|---|---|---|"]
    # a clean clone of HEAD, as a new user has it: no kernels built or cached in the tree
    clone = tmp / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    for label, install in (
        ("wheel (prebuilt kernels)", [str(wheel)]),
        ("`pip install -e .` of a clean clone (kernels compiled on first use)", ["-e", str(clone)]),
    ):
        bin_, seconds = fresh_venv(tmp / f"first-{len(lines)}", *install)
        work = workspace(tmp / f"first-work-{len(lines)}")
        start = time.perf_counter()
        subprocess.run(
            [bin_ / "follicle", "demo", "--out", "demo"],
            cwd=work,
            check=True,
            capture_output=True,
            env={**os.environ, "NUMBA_CACHE_DIR": str(tmp / f"first-cache-{len(lines)}")},
        )
        demo = time.perf_counter() - start
        lines.append(f"| {label} | {seconds:.1f} | {demo:.1f} | {seconds + demo:.1f} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--wheel", type=Path, default=None)
    parser.add_argument("--baseline", action="store_true")
    parser.add_argument("--first-command", action="store_true")
    parser.add_argument("--keep", type=Path, default=None, help="work here, and keep it")
    args = parser.parse_args()
    tmp = args.keep or Path(tempfile.mkdtemp(prefix="follicle-cold-"))
    try:
        wheel = args.wheel or build_wheel(tmp / "dist")
        print(f"wheel: {wheel.name}", flush=True)
        bin_, seconds = fresh_venv(tmp / "venv", str(wheel))
        print(f"fresh venv + pip install of the wheel: {seconds:.1f} s", flush=True)
        rows = measure(bin_, tmp, args.baseline)
        print()
        print(table(rows, args.baseline))
        if args.baseline:
            print()
            print(kernel_lists(rows))
        if args.first_command:
            print()
            print(first_command(wheel, tmp))
    finally:
        if args.keep is None:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
