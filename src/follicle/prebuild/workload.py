"""What compiles every kernel: follicle's own commands run on small inputs, each feature
of a scene at least once, so that every kernel is compiled for the argument types the
commands give it.

A wheel's build runs it for a CPU level (:mod:`follicle.prebuild.build`) and ships what
it compiles; ``follicle warm`` runs it for this machine. Its tasks are independent
enough to run side by side in separate processes (numba compiles one kernel at a time
per process): ``grow`` and ``render`` share no kernel, and the tasks that need grown hair
wait for ``grow``, whose kernels they then load instead of compiling them again.
:data:`TASKS` lists them in the order a process takes them up.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Task", "TASKS", "run_task"]


@dataclass(frozen=True)
class Task:
    """A named piece of the workload, run in a folder of its own after the tasks
    ``after`` have finished (their kernels are then in the cache)."""

    name: str
    run: Callable[[Path], None]
    after: tuple[str, ...] = ()


def _follicle(folder: Path, *args: str) -> None:
    """``follicle ARGS…`` in this process, in ``folder``; an error is raised."""
    from ..cli import main

    here = os.getcwd()
    os.chdir(folder)
    try:
        main.main(args=list(args), prog_name="follicle", standalone_mode=False)
    finally:
        os.chdir(here)


def _toml(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml(v)}" for k, v in value.items()) + "}"
    return repr(value)


def _scene(folder: Path, name: str, **sections: dict) -> str:
    """A scene file ``name`` in ``folder`` of ``sections`` ({"groom": {...}, ...}; a
    list of dicts is an array of tables)."""
    lines = []
    for section, keys in sections.items():
        tables = {
            k: v for k, v in keys.items() if isinstance(v, list) and v and isinstance(v[0], dict)
        }
        lines.append(f"[{section}]")
        lines += [f"{k} = {_toml(v)}" for k, v in keys.items() if k not in tables]
        for key, rows in tables.items():
            for row in rows:
                lines.append(f"[[{section}.{key}]]")
                lines += [f"{k} = {_toml(v)}" for k, v in row.items()]
    (folder / name).write_text("\n".join(lines) + "\n")
    return name


def _textures(folder: Path) -> None:
    """A density map, a colour map, a group map and a displacement map, 64² PNGs."""
    import numpy as np
    from PIL import Image

    u, v = np.meshgrid(np.linspace(0, 1, 64), np.linspace(0, 1, 64))
    grey = (255 * (0.2 + 0.8 * u * v)).astype(np.uint8)
    Image.fromarray(grey, "L").save(folder / "density.png")
    Image.fromarray((255 * (0.5 + 0.5 * np.sin(8 * u))).astype(np.uint8), "L").save(
        folder / "bump.png"
    )
    rgb = np.stack([grey, grey[::-1], np.full_like(grey, 128)], axis=-1)
    Image.fromarray(rgb, "RGB").save(folder / "colour.png")
    groups = np.zeros((64, 64, 3), np.uint8)
    groups[:, :32, 0] = 255
    groups[:, 32:, 2] = 255
    Image.fromarray(groups, "RGB").save(folder / "groups.png")


def _attributed_guides(folder: Path) -> None:
    """The built-in short guides with attributes to inherit: a colour and a width per
    vertex, an integer per vertex, a float and an integer per guide."""
    import numpy as np

    from ..curves import HairCurves
    from ..groom.builtin_guides import builtin_guides
    from ..io.dispatch import save
    from ..mesh.head import builtin_head

    curves = builtin_guides("short", builtin_head())
    t = np.concatenate([np.linspace(0.0, 1.0, c) for c in curves.counts])
    point_data = {
        "color": np.stack([1.0 - t, 0.2 * t, t], axis=1),
        "width": (2e-4 - 1e-4 * t).astype(np.float32),
        "knot": np.concatenate([np.arange(c) for c in curves.counts]),
    }
    n = curves.curve_count
    curve_data = {"stiffness": np.linspace(0.0, 1.0, n), "tag": np.arange(n, dtype=np.int32)}
    save(
        HairCurves(curves.points, curves.offsets, point_data, curve_data), folder / "attributed.npz"
    )


# ---------------------------------------------------------------------------- tasks
def grow(folder: Path) -> None:
    """Every groom feature, IDW and barycentric, textures as property maps, written to
    every curves format."""
    _textures(folder)
    small = {"count": 600, "seed": 1}
    _scene(
        folder,
        "features.toml",
        mesh={"path": "builtin:head", "displacement": "bump.png", "displacement_scale": 0.002},
        guides={"path": "builtin:long"},
        groom={
            **small,
            "density": "density.png",
            "density_refine": 1,
            "groups": "groups.png",
            "group_vertices": {"#ff0000": 12},
            "vertices": 16,
            "cut": {"value": 0.9, "texture": "density.png"},
            "random_scale": 0.1,
            "frizz_tip": 0.01,
            "frizz_speed": 0.5,
            "frizz_blend": 0.5,
            "kink_tip": 0.003,
            "clump_count": 40,
            "clump_root": 0.2,
            "root_color": {"value": [0.3, 0.2, 0.1], "texture": "colour.png"},
            "hue_variation": 5.0,
            "saturation_variation": 0.05,
            "value_variation": 0.1,
            "mutant_fraction": 0.05,
            "root_opacity": 0.9,
            "skip_threshold": 0.9995,
        },
    )
    _scene(
        folder,
        "barycentric.toml",
        guides={"path": "builtin:curly"},
        groom={
            **small,
            "interpolation": "barycentric",
            "groups": "builtin:parting",
            "offset_mode": "translate",
            "curl_radius": 0.005,
            "curl_frequency_tip": 50.0,
            "strand_count": 3,
            "strand_twist": 100.0,
            "strand_randomize": 0.1,
        },
    )
    _scene(folder, "short.toml", guides={"path": "builtin:short"}, groom=small)
    _attributed_guides(folder)
    _scene(
        folder,
        "inherit.toml",
        mesh={"path": "builtin:head"},  # the guides' own skin (_attributed_guides)
        guides={"path": "attributed.npz"},
        groom={
            **small,
            "inherit": ["color", "width", "knot", "stiffness", "tag"],
            "cut": 0.8,
            "hue_variation": 5.0,
        },
    )
    _scene(folder, "offset.toml", groom={**small, "interpolation": "offset"})
    _scene(
        folder,
        "translate.toml",
        groom={**small, "interpolation": "offset", "offset_mode": "translate"},
    )
    for scene in (
        "features.toml",
        "barycentric.toml",
        "short.toml",
        "inherit.toml",
        "offset.toml",
        "translate.toml",
    ):
        _follicle(folder, "grow", scene, "-o", scene.replace(".toml", ".npz"))
    for suffix in (".hair", ".tfx", ".obj", ".pbrt", ".txt", ".usda", ".abc", ".rib"):
        _follicle(folder, "grow", "features.toml", "-o", f"features{suffix}")
        _follicle(folder, "export", f"features{suffix}", "-o", f"again{suffix}.npz")
    _follicle(folder, "grow", "short.toml", "-o", "short.usdc", "--target", "unreal")
    _follicle(folder, "check", "short.usdc", "--target", "unreal")
    _follicle(
        folder, "cards", "short.toml", "-o", "cards.glb", "--counts", "20,6", "--atlas", "256"
    )
    _follicle(folder, "export-rib", "short.toml", "-o", "short.rib", "--voxels", "2")
    _follicle(folder, "export", "builtin:head", "-o", "head.obj")
    _scene(folder, "mesh.toml", mesh={"path": "head.obj", "units": "cm"}, groom=small)
    _follicle(folder, "grow", "mesh.toml", "-o", "mesh.npz")


def render(folder: Path) -> None:
    """The CPU engine on strands made without the groom's kernels: each shading model,
    with and without shadows, transparency, MSAA, level of detail and the skin."""
    import numpy as np

    from ..curves import HairCurves
    from ..io.dispatch import save

    rng = np.random.default_rng(0)
    roots = rng.normal(size=(300, 3))
    roots = 0.1 * roots / np.linalg.norm(roots, axis=1, keepdims=True)
    steps = np.linspace(0.0, 0.12, 12)[None, :, None]
    points = (roots[:, None, :] * (1.0 + steps / 0.1)).astype(np.float32)
    curves = HairCurves(
        points.reshape(-1, 3),
        np.arange(0, points.shape[0] * 12 + 1, 12, dtype=np.int64),
        point_data={"width": np.full(points.shape[0] * 12, 1e-4, np.float32)},
    )
    save(curves, folder / "strands.npz")
    for shading in ("kajiya-kay", "scheuermann", "marschner"):
        _scene(
            folder,
            f"{shading}.toml",
            render={"engine": "cpu", "shading": shading, "size": [96, 64], "lod": 0.5},
        )
        _follicle(
            folder,
            "render",
            "strands.npz",
            "-o",
            f"{shading}.png",
            "--engine",
            "cpu",
            "--shading",
            shading,
            "--size",
            "96",
            "64",
            "--mesh",
            "builtin:head",
        )
    plain = {
        "engine": "cpu",
        "shadows": False,
        "oit": False,
        "msaa": 0,
        "lights": [{"type": "ambient"}, {"direction": [1.0, 1.0, 0.0], "space": "world"}],
        "size": [80, 80],
    }
    from ..pipeline import render_scene
    from ..scene import parse_scene

    scene = parse_scene({"render": plain}, "workload")
    render_scene(curves, None, scene.render, out=str(folder / "plain.png"))


def simulate(folder: Path) -> None:
    """Both solvers, wind, drag, colliders of every kind, the skin's SDF, hair volume, a
    nod, a skin animation from a file; the caches rendered and exported."""
    small = {"count": 400, "seed": 2}
    sim = {
        "wind": [1.0, 0.0, 0.0],
        "wind_gust": 0.5,
        "drag": 0.1,
        "volume_friction": 0.1,
        "volume_repulsion": 0.1,
        "volume_resolution": 16,
        "shape_local": 0.1,
        "cone_angle": 60.0,
        "motion": "nod",
        "colliders": [
            {"kind": "sphere", "centre": [0.0, -0.3, 0.1], "radius": 0.1},
            {"kind": "capsule", "a": [-0.1, -0.3, 0.0], "b": [0.1, -0.3, 0.0], "radius": 0.05},
            {"kind": "plane", "centre": [0.0, -0.4, 0.0], "normal": [0.0, 1.0, 0.0]},
        ],
    }
    _scene(folder, "pbd.toml", groom=small, sim=sim)
    _scene(folder, "dftl.toml", groom=small, sim={**sim, "solver": "dftl", "integrator": "euler"})
    for name in ("pbd", "dftl"):
        _follicle(folder, "simulate", f"{name}.toml", "--frames", "3", "-o", f"{name}.npz")
    _follicle(folder, "render", "pbd.npz", "-o", "frames", "--engine", "cpu", "--size", "64", "64")
    _follicle(folder, "export", "pbd.npz", "-o", "pbd.usdc")
    _follicle(folder, "export", "pbd.npz", "-o", "pbd.abc")
    _scene(folder, "animated.toml", groom=small, sim={"skin_animation": "pbd.usdc"})
    _follicle(folder, "simulate", "animated.toml", "--frames", "2", "-o", "animated.npz")
    _scene(
        folder,
        "bare.toml",
        groom=small,
        sim={"skin_collision": False, "colliders": sim["colliders"]},
    )
    _follicle(folder, "simulate", "bare.toml", "--frames", "2", "-o", "bare.npz")


def groom(folder: Path) -> None:
    """Every brush of the guide editor, replayed from a stroke log."""
    camera = {"eye": [0.9, 0.1, 0.1], "target": [0.0, 0.03, 0.0], "up": [0.0, 1.0, 0.0]}
    path = [[400.0, 190.0], [480.0, 160.0], [560.0, 190.0]]
    strokes = [
        {
            "brush": brush,
            "path": path,
            "radius": 30.0,
            "strength": 0.5,
            "size": [960, 540],
            "camera": camera,
        }
        for brush in ("comb", "puff", "smooth", "length", "add", "part", "cut", "delete")
    ]
    doc = {
        "follicle_strokes": 1,
        "mesh": "builtin:head",
        "guides": "builtin:short",
        "strokes": strokes,
    }
    (folder / "strokes.json").write_text(json.dumps(doc))
    _follicle(folder, "groom", "strokes.json", "-o", "groomed.npz", "--groups", "groups.png")


def view(folder: Path) -> None:
    """The viewer's loop, headless: simulation, regrowth and the CPU engine together."""
    _scene(folder, "view.toml", groom={"count": 500}, render={"engine": "cpu"})
    _follicle(folder, "view", "view.toml", "--offscreen", "--frames", "2", "--size", "96", "64")
    _follicle(
        folder,
        "view",
        "view.toml",
        "--offscreen",
        "--frames",
        "2",
        "--size",
        "96",
        "64",
        "--quality",
        "fast",
        "--hold-fps",
        "15",
    )


def api(folder: Path) -> None:
    """The Python functions over arrays that no command calls on its own: splines,
    frames, colours, noise, low-discrepancy points, the skin's SDF, hair volume, the
    density sampler's maps and the finite check of a large array."""
    import numpy as np

    from .. import color, frames, noise, rng, spline
    from ..groom.appearance import hair_appearance
    from ..io.mesh_load import load_mesh
    from ..mesh.sampling import DensitySampler
    from ..mesh.sdf import SDF
    from ..mesh.texture import Texture
    from ..sim.volume import apply_volume

    rand = np.random.default_rng(0)
    points = rand.random((40, 3))
    offsets = np.arange(0, 41, 8, dtype=np.int64)
    spline.evaluate(points[:8], np.linspace(0.0, 1.0, 5))
    spline.derivative(points[:8], np.linspace(0.0, 1.0, 5))
    spline.vertex_tangents(points, offsets)
    spline.resample(points, offsets, 6)
    spline.cut(points[:8], 0.5)
    spline.cut_curves(points, offsets, np.full(5, 0.5))
    spline.curve_bounds(points, offsets)
    frames.rotation_minimizing_frames(points, offsets, np.tile([0.0, 0.0, 1.0], (5, 1)))
    rng.halton(np.arange(10), 3)
    hsv = color.rgb_to_hsv(rand.random((10, 3)))
    color.hsv_to_rgb(hsv)
    color.hue_distance(hsv[:, 0], hsv[::-1, 0])
    color.lerp_hsv(hsv, hsv[::-1], np.linspace(0.0, 1.0, 10))
    noise.perlin_array(points)
    noise.noise3_array(points)
    hair_appearance(
        np.arange(4),
        0,
        6,
        root_color=(0.1, 0.05, 0.02),
        tip_color=(0.2, 0.1, 0.05),
        hue_var=5.0,
        sat_var=0.1,
        val_var=0.1,
        mutant_fraction=0.1,
        mutant_color=(0.8, 0.8, 0.8),
        root_width=1e-4,
        tip_width=5e-5,
        root_opacity=1.0,
        tip_opacity=0.5,
    )
    mesh = load_mesh("builtin:head")
    field = SDF.from_mesh(mesh.vertices, mesh.faces)
    field.distance_and_normal(points)
    texture = Texture(rand.random((16, 16)).astype(np.float32))
    sampler = DensitySampler(mesh, texture)
    sampler.sub_triangle_areas()
    x = rand.random((6, 8, 3))
    v = np.zeros_like(x)
    grid = apply_volume(x, v, 0.01, 0.1, 0.1, resolution=8)
    grid.sample_density(points)
    grid.sample_velocity(points)
    grid.density_gradient(points)
    from ..arrays import SCAN_IN_PARALLEL, all_finite

    for dtype in (np.float32, np.float64):  # a large array is scanned on every core
        all_finite(np.zeros(SCAN_IN_PARALLEL, dtype))


def commands(folder: Path) -> None:
    """The commands a new user runs first, as they run them."""
    _follicle(folder, "demo", "--out", "demo", "--count", "2000", "--size", "128", "128")
    _scene(folder, "scene.toml", groom={"count": 2000})
    _follicle(folder, "simulate", "scene.toml", "--frames", "2", "-o", "sim.npz")
    _follicle(folder, "render", "scene.toml", "-o", "scene.png", "--size", "128", "128")


TASKS: tuple[Task, ...] = (
    Task("grow", grow),
    Task("render", render),
    Task("simulate", simulate, after=("grow",)),
    Task("groom", groom, after=("grow",)),
    Task("api", api, after=("grow", "render")),
    Task("view", view, after=("grow", "render", "simulate")),
    Task("commands", commands, after=("grow", "render", "simulate")),
)


def run_task(name: str, folder: Path) -> None:
    """Run the task ``name`` in ``folder`` (made if need be)."""
    task = next((t for t in TASKS if t.name == name), None)
    if task is None:
        raise KeyError(f"no workload task {name!r}: one of {[t.name for t in TASKS]}")
    folder.mkdir(parents=True, exist_ok=True)
    task.run(folder)
