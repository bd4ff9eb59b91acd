"""How near the raster shading models come to the path-traced reference: NVIDIA FLIP
(Andersson et al. 2020) of each model's CPU-engine render against Mitsuba 3's
(Chiang et al. 2016 hair BSDF) on the gallery scenes, same camera and lights.

Prints a table (scene × model: mean FLIP, lower is nearer; CPU frame time at that size,
benchmarks/shading.py measures the ratio better) and writes ``docs/shading_flip.png``:
Mitsuba | kajiya-kay | physical for a few scenes. The Mitsuba pictures are cached under
``out/flip/`` (keyed by scene, size and samples), so a rerun only renders the raster
models. Needs the pbr extra and ``pip install flip-evaluator``.

``--floor`` adds a column: FLIP between the reference and Mitsuba's picture with sampler
seed 1, the path tracer's own noise at those samples (a raster engine without noise
would come to about 1/√2 of it).

``--errors`` writes ``docs/shading_flip_errors.png`` (Mitsuba | physical | FLIP's error
map, white = 1) for the sheet's scenes and prints where the error lies: its share in
the pixels hair covers wholly, partly and not at all (the CPU engine's hair drawn over
black and over white: covered where the two agree).

Run: ``.venv/bin/python docs/make_flip_report.py [--size 320] [--spp 256]
[--models kajiya-kay,marschner,physical] [--scenes wavy,curly] [--sheet] [--floor]
[--errors]``
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from PIL import Image

from follicle.pipeline import grow, render_scene
from follicle.render.mitsuba import render_mitsuba
from follicle.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
CACHE = ROOT / "out" / "flip"
SCENES = ("long_straight", "wavy", "curly", "parting", "short_fur", "blond_multistrand")
MODELS = ("kajiya-kay", "marschner", "physical")
SHEET_SCENES = ("wavy", "short_fur", "blond_multistrand")
SHEET_MODELS = ("kajiya-kay", "physical")
GAP = 4  # pixels between the pictures of the sheet


def mitsuba_reference(
    name: str, scene, mesh, curves, size: int, spp: int, seed: int = 0
) -> np.ndarray:
    """Mitsuba's picture of ``scene`` with sampler ``seed``, from the cache or rendered
    (and cached)."""
    path = CACHE / f"{name}_{size}_{spp}spp{f'_seed{seed}' if seed else ''}.png"
    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        params = scene.render.replace(size=(size, size))
        start = time.perf_counter()
        render_mitsuba(curves, mesh, settings=params, spp=spp, seed=seed, out=str(path))
        print(f"  {name}: Mitsuba {spp} spp {time.perf_counter() - start:.0f} s", flush=True)
    return np.asarray(Image.open(path).convert("RGB"))


def cpu_render(scene, mesh, curves, size: int, model: str) -> tuple[np.ndarray, float]:
    """The CPU engine's picture with shading ``model`` and its frame time (the best of
    two renders after a warm-up: the kernels compiled, the groom grown)."""
    params = scene.render.replace(size=(size, size), engine="cpu", shading=model, shading_params={})
    image = render_scene(curves, mesh, params)
    times = []
    for _ in range(2):
        start = time.perf_counter()
        render_scene(curves, mesh, params)
        times.append(time.perf_counter() - start)
    return image[..., :3], min(times)


def flip(reference: np.ndarray, test: np.ndarray) -> float:
    return float(flip_map(reference, test).mean())


def flip_map(reference: np.ndarray, test: np.ndarray) -> np.ndarray:
    """FLIP's per-pixel error (H, W) of ``test`` against ``reference`` (sRGB uint8)."""
    import flip_evaluator

    error, _, _ = flip_evaluator.evaluate(
        reference.astype(np.float32) / 255.0,
        test.astype(np.float32) / 255.0,
        "LDR",
        applyMagma=False,
    )
    error = np.asarray(error, dtype=np.float64)
    return error.reshape(error.shape[:2])


def hair_cover(scene, mesh, curves, size: int) -> np.ndarray:
    """How wholly hair covers each pixel (0..1): one less the largest channel difference
    of the CPU engine's hair over black and over white (background and skin)."""
    params = scene.render.replace(size=(size, size), engine="cpu", scalp_tint=0.0)
    over = []
    for v in (0.0, 1.0):
        grey = [v, v, v]
        p = params.replace(background_top=grey, background_bottom=grey, skin_color=grey)
        over.append(render_scene(curves, mesh, p)[..., :3].astype(np.int16))
    return 1.0 - np.abs(over[1] - over[0]).max(axis=-1) / 255.0


def error_sheet(errors: dict, size: int) -> None:
    """docs/shading_flip_errors.png: Mitsuba | physical | error map, a row a scene, and
    where each scene's error lies."""
    rows = []
    for name, (ref, image, error, cover) in errors.items():
        whole, none = cover > 0.9, cover <= 0.1
        total = error.sum()
        print(
            f"{name}: FLIP {error.mean():.3f}; of the error {error[whole].sum() / total:.0%}"
            f" where hair covers a pixel wholly ({int(whole.sum())} px, mean"
            f" {error[whole].mean():.3f}), {error[~whole & ~none].sum() / total:.0%} partly,"
            f" {error[none].sum() / total:.0%} where there is none"
        )
        grey = (np.clip(error, 0.0, 1.0) * 255).astype(np.uint8)
        gap = np.full((size, GAP, 3), 255, np.uint8)
        rows.append(np.concatenate([ref, gap, image, gap, np.stack([grey] * 3, -1)], axis=1))
    between = np.full((GAP, rows[0].shape[1], 3), 255, np.uint8)
    sheet = np.concatenate([x for row in rows for x in (row, between)][:-1], axis=0)
    small = Image.fromarray(sheet).quantize(256, dither=Image.Dither.FLOYDSTEINBERG)
    small.save(ROOT / "docs" / "shading_flip_errors.png", optimize=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--size", type=int, default=320, help="image width and height")
    parser.add_argument("--spp", type=int, default=256, help="Mitsuba samples per pixel")
    parser.add_argument("--models", default=",".join(MODELS))
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--sheet", action="store_true", help="write docs/shading_flip.png")
    parser.add_argument(
        "--floor",
        action="store_true",
        help="also FLIP between the reference and Mitsuba's picture with another seed:"
        " the path tracer's own noise at these samples",
    )
    parser.add_argument("--errors", action="store_true", help="write docs/shading_flip_errors.png")
    args = parser.parse_args()
    models = args.models.split(",")
    header = "| scene | " + " | ".join(f"{m} FLIP | {m} ms" for m in models) + " |"
    if args.floor:
        header = header.replace("| scene |", "| scene | Mitsuba seed 1 FLIP |")
    rows, totals, pictures, errors = [], {m: [] for m in models}, {}, {}
    for name in args.scenes.split(","):
        scene = load_scene(ROOT / "examples" / f"{name}.toml")
        mesh, curves = grow(scene)
        ref = mitsuba_reference(name, scene, mesh, curves, args.size, args.spp)
        cells = []
        pictures[name] = {"mitsuba": ref}
        if args.floor:
            again = mitsuba_reference(name, scene, mesh, curves, args.size, args.spp, seed=1)
            totals.setdefault("floor", []).append((flip(ref, again), 0.0))
            cells.append(f"{totals['floor'][-1][0]:.3f}")
        for model in models:
            image, seconds = cpu_render(scene, mesh, curves, args.size, model)
            error = flip(ref, image)
            totals[model].append((error, seconds))
            pictures[name][model] = image
            if args.errors and model == "physical" and name in SHEET_SCENES:
                cover = hair_cover(scene, mesh, curves, args.size)
                errors[name] = (ref, image, flip_map(ref, image), cover)
            cells.append(f"{error:.3f} | {seconds * 1e3:.0f}")
        rows.append(f"| {name} | " + " | ".join(cells) + " |")
        print(rows[-1], flush=True)
    mean = {m: np.mean(np.array(v), axis=0) for m, v in totals.items()}
    rows.append(
        "| **mean** | "
        + (f"**{mean['floor'][0]:.3f}** | " if args.floor else "")
        + " | ".join(f"**{mean[m][0]:.3f}** | {mean[m][1] * 1e3:.0f}" for m in models)
        + " |"
    )
    print(f"\n{args.size}×{args.size}, Mitsuba {args.spp} spp, CPU engine\n")
    print(header)
    print("|---|" + "---:|" * (2 * len(models) + args.floor))
    print("\n".join(rows))
    if "kajiya-kay" in mean:
        kk_flip, kk_time = mean["kajiya-kay"]
        for m in models:
            print(
                f"{m}: FLIP {mean[m][0] / kk_flip:.2f}× and time {mean[m][1] / kk_time:.2f}× KK's"
            )
    if args.sheet:
        write_sheet(pictures, args.size)
    if errors:
        error_sheet(errors, args.size)


def write_sheet(pictures: dict, size: int) -> None:
    """docs/shading_flip.png: a row per scene of SHEET_SCENES, Mitsuba then the models."""
    columns = ("mitsuba", *SHEET_MODELS)
    rows = []
    for name in SHEET_SCENES:
        if name not in pictures:
            continue
        gap = np.full((size, GAP, 3), 255, np.uint8)
        row = [x for c in columns for x in (pictures[name][c], gap)][:-1]
        rows.append(np.concatenate(row, axis=1))
    between = np.full((GAP, rows[0].shape[1], 3), 255, np.uint8)
    sheet = np.concatenate([x for row in rows for x in (row, between)][:-1], axis=0)
    # a 256-colour PNG, dithered: a third of the bytes
    small = Image.fromarray(sheet).quantize(256, dither=Image.Dither.FLOYDSTEINBERG)
    small.save(ROOT / "docs" / "shading_flip.png", optimize=True)


if __name__ == "__main__":
    main()
