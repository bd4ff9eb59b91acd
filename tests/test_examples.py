"""The example scenes in examples/: they parse, grow, and show what they claim to show.

Each scene is grown with a small hair count through the Python API (each is rendered,
with the commands its comment names, by the docs build's gallery: tests/test_docs_build.py
checks the gallery shows a real render of every one).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy.spatial import cKDTree

from follicle.curves import HairCurves
from follicle.groom.generator import load_texture
from follicle.mesh.texture import Texture
from follicle.pipeline import groom_scene
from follicle.scene import Scene, load_scene

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SCENES = sorted(EXAMPLES.glob("*.toml"))
NAMES = [p.stem for p in SCENES]
EXPECTED = {
    "long_straight",
    "wavy",
    "curly",
    "short_fur",
    "parting",
    "blond_multistrand",
    "hand_groomed",
}
COUNT = 1000

_cache: dict[str, tuple[Scene, object, HairCurves]] = {}


def grown(name: str, count: int = COUNT) -> tuple[Scene, object, HairCurves]:
    """(scene, groom, hairs with ids [0, count)) of an example, grown once per session."""
    key = f"{name}:{count}"
    if key not in _cache:
        scene = load_scene(EXAMPLES / f"{name}.toml")
        groom = groom_scene(scene)
        _cache[key] = (scene, groom, groom.generate(count))
    return _cache[key]


def curve_ids(hair: HairCurves) -> np.ndarray:
    return np.repeat(np.arange(hair.curve_count), np.diff(hair.offsets))


def arc_over_chord(hair: HairCurves) -> np.ndarray:
    """Length along each curve over its root-to-tip distance (1: straight)."""
    p = hair.points.astype(np.float64)
    cid = curve_ids(hair)
    inside = cid[:-1] == cid[1:]
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    arc = np.bincount(cid[:-1][inside], seg[inside], minlength=hair.curve_count)
    chord = np.linalg.norm(p[hair.offsets[1:] - 1] - p[hair.offsets[:-1]], axis=1)
    return arc / np.maximum(chord, 1e-12)


def turning_angle(hair: HairCurves) -> np.ndarray:
    """Angle (degrees) between successive segments of every curve."""
    p = hair.points.astype(np.float64)
    cid = curve_ids(hair)
    d = np.diff(p, axis=0)
    t = d / np.maximum(np.linalg.norm(d, axis=1), 1e-12)[:, None]
    inside = cid[:-1] == cid[1:]
    pairs = inside[:-1] & inside[1:]
    cos = np.clip(np.sum(t[:-1] * t[1:], axis=1), -1.0, 1.0)
    return np.degrees(np.arccos(cos))[pairs]


# ------------------------------------------------------------------ every scene
def test_the_seven_examples_are_there():
    assert EXPECTED <= set(NAMES), f"missing: {EXPECTED - set(NAMES)}"


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.slow
def test_scene_grows_finite_hair(name):
    scene, groom, hair = grown(name)
    assert hair.curve_count > 0
    assert np.all(np.isfinite(hair.points))
    assert hair.offsets[0] == 0 and hair.offsets[-1] == len(hair.points)
    assert np.all(np.diff(hair.offsets) >= 2)
    ids = hair.curve_data["hair_id"]
    assert ids.min() >= 0 and ids.max() < COUNT
    for key in ("width", "color", "opacity"):
        assert np.all(np.isfinite(hair.point_data[key])), key
    assert np.all(hair.point_data["width"] > 0)
    # the hair stays near its mesh: nothing flies off (NaN-like spikes)
    lo, hi = groom.mesh.bounds("rest")
    reach = float(np.linalg.norm(hi - lo))
    centre = 0.5 * (lo + hi)
    assert np.linalg.norm(hair.points - centre, axis=1).max() < reach
    # a modest count for `follicle render` on a small machine
    assert scene.groom.count * scene.groom.strand_count <= 100_000


# ------------------------------------------------------------------ what each one shows
@pytest.mark.slow
def test_long_straight_is_straight():
    scene, _, hair = grown("long_straight")
    assert scene.guides.path == "builtin:long"
    assert np.median(arc_over_chord(hair)) < 1.02


@pytest.mark.slow
def test_wavy_waves_but_does_not_curl():
    scene, _, hair = grown("wavy")
    _, _, straight = grown("long_straight")
    g = scene.groom
    assert scene.guides.path == "builtin:long"
    assert g.kink_tip > 0 or g.frizz_tip > 0 or g.curl_radius > 0
    bends = np.median(turning_angle(hair))
    assert bends > 3.0 and bends > 10 * np.median(turning_angle(straight))
    assert 1.01 < np.median(arc_over_chord(hair)) < 1.2


@pytest.mark.slow
def test_curly_forms_clumped_ringlets():
    scene, groom, hair = grown("curly")
    g = scene.groom
    assert g.curl_radius > 0 or scene.guides.path == "builtin:curly"
    assert g.clump_count > 0 and g.clump_tip >= 0.8
    assert np.median(arc_over_chord(hair)) > 1.4
    # clumping gathers the curled tips onto their clump centre's curl: ringlets
    tips = hair.points[hair.offsets[1:] - 1]
    clumped = np.median(cKDTree(tips).query(tips, k=2)[0][:, 1])
    groom.params = g.model_copy(update={"clump_count": 0})
    loose = groom.generate(COUNT)
    groom.params = g
    loose_tips = loose.points[loose.offsets[1:] - 1]
    apart = np.median(cKDTree(loose_tips).query(loose_tips, k=2)[0][:, 1])
    assert clumped < 0.5 * apart


@pytest.mark.slow
def test_short_fur_grows_only_where_the_density_map_is_not_zero():
    scene, groom, hair = grown("short_fur", 2000)
    assert not scene.mesh.path.startswith("builtin:")
    assert scene.guides.path == "builtin:short"
    density = Texture.load(scene.resolve(scene.groom.density))
    assert density.data.min() == 0.0 and density.data.max() > 0.0  # a map with bald parts
    uv = hair.curve_data["root_uv"]
    assert np.all(density.sample(uv) > 0.0)
    # the bald band along the inner equator (v = 0 / 1) holds no roots
    assert np.min(np.minimum(uv[:, 1], 1.0 - uv[:, 1])) > 0.04
    # short: a few centimetres at most
    roots = hair.points[hair.offsets[:-1]]
    tips = hair.points[hair.offsets[1:] - 1]
    assert np.median(np.linalg.norm(tips - roots, axis=1)) < 0.04
    # the coat colour comes from the texture
    spec = scene.groom.root_color
    assert isinstance(spec, dict)
    coat = Texture.load(scene.resolve(spec["texture"])).sample(uv)
    root_rgb = hair.point_data["color"][hair.offsets[:-1]]
    for k in range(3):
        assert np.corrcoef(root_rgb[:, k], coat[:, k])[0, 1] > 0.7


def load_example_module(name: str):
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_example_assets_are_small_and_reproducible(tmp_path):
    assets = EXAMPLES / "assets"
    files = sorted(p for p in assets.iterdir() if p.is_file())
    assert sum(p.stat().st_size for p in files) < 300_000
    load_example_module("make_assets").main(tmp_path)
    for name in ("torus.obj", "hand_groomed.npz"):  # the guides replayed from the log
        assert (tmp_path / name).read_bytes() == (assets / name).read_bytes(), name
    for name in ("fur_density.png", "fur_color.png", "hand_groomed_groups.png"):
        with Image.open(tmp_path / name) as made, Image.open(assets / name) as kept:
            assert np.array_equal(np.asarray(made), np.asarray(kept)), name


@pytest.mark.slow
def test_parting_keeps_the_two_groups_apart():
    scene, groom, hair = grown("parting", 2000)
    assert scene.groom.groups == "builtin:parting"
    # the skin's own map, in its UV layout (the bust's differs from the head's)
    rgb = load_texture("builtin:parting", mesh=groom.mesh).sample(hair.curve_data["root_uv"])
    red = rgb[:, 0] > 0.5  # the head's right half (x < 0); blue is its left
    assert 0.3 < red.mean() < 0.7  # both groups grow hair
    roots = hair.points[hair.offsets[:-1]]
    side = np.where(red, -1.0, 1.0)
    assert np.all(np.sign(roots[:, 0]) == side)
    # no hair crosses the parting by more than 5 mm
    cid = curve_ids(hair)
    assert np.all(hair.points[:, 0] * side[cid] > -0.005)
    # each group has its own vertex count (no cut, no vertex removal in this scene)
    counts = np.diff(hair.offsets)
    by_colour = {k.lower(): v for k, v in scene.groom.group_vertices.items()}
    assert set(by_colour) == {"#ff0000", "#0000ff"}
    assert set(np.unique(counts[red]).tolist()) == {by_colour["#ff0000"]}
    assert set(np.unique(counts[~red]).tolist()) == {by_colour["#0000ff"]}


@pytest.mark.slow
def test_blond_multistrand_has_fibres_and_light_colour():
    scene, _, hair = grown("blond_multistrand", 500)
    n = scene.groom.strand_count
    assert 3 <= n <= 6
    assert hair.curve_data["strand_id"].min() == 0
    assert hair.curve_data["strand_id"].max() == n - 1
    per_hair = np.bincount(hair.curve_data["hair_id"])
    assert per_hair.max() == n and np.mean(per_hair[per_hair > 0] == n) > 0.9
    tips = hair.point_data["color"][hair.offsets[1:] - 1]
    luminance = tips @ np.array([0.2126, 0.7152, 0.0722])
    assert np.median(luminance) > 0.3  # blond, in linear RGB
    assert np.std(luminance) > 0.01  # per-hair variation


@pytest.mark.slow
def test_hand_groomed_log_is_what_its_script_writes(tmp_path):
    log = load_example_module("hand_groomed").main(tmp_path / "strokes.json")
    assert log.read_bytes() == (EXAMPLES / "hand_groomed.strokes.json").read_bytes()


@pytest.mark.slow
def test_hand_groomed_is_combed_back_parted_and_has_a_fringe():
    """What the strokes were for, in the grown hair: the sides combed back, a parting
    over the left eye the hairs do not cross, a fringe ending on a line at the brow —
    each against the built-in short guides the log started from."""
    scene, groom, hair = grown("hand_groomed", 2000)
    start = scene.replace(
        guides=scene.guides.replace(path="builtin:short"), groom=scene.groom.replace(groups=None)
    )
    before = groom_scene(start).generate(2000)

    def ends(h: HairCurves) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p = h.points.astype(np.float64)
        return p, p[h.offsets[:-1]], p[h.offsets[1:] - 1]

    points, roots, tips = ends(hair)
    points0, roots0, tips0 = ends(before)
    # combed back: the hairs rooted on the sides end 2 cm behind their roots (on the
    # bust, the built-in short guides already end 1 cm behind for 96 %: 67 % at 2 cm)
    side, side0 = np.abs(roots[:, 0]) > 0.06, np.abs(roots0[:, 0]) > 0.06
    back = np.mean(tips[side, 2] < roots[side, 2] - 0.02)
    assert back > 0.93 and back > np.mean(tips0[side0, 2] < roots0[side0, 2] - 0.02) + 0.05

    # the fringe: the hairs rooted at the front hairline right of the parting hang over
    # the forehead, and end on the cut at the brow (y = 3.5 cm), none past it
    def front(r: np.ndarray) -> np.ndarray:
        return (r[:, 2] > 0.03) & (r[:, 0] > -0.05) & (r[:, 0] < 0.02) & (r[:, 1] < 0.11)

    fringe = front(roots)
    assert fringe.sum() > 50
    forward = tips[fringe, 2] - roots[fringe, 2]  # over the forehead
    assert np.all(forward > 0.0) and np.mean(forward > 0.02) > 0.9
    assert tips[fringe, 1].min() > 0.028
    assert np.mean((tips[fringe, 1] > 0.03) & (tips[fringe, 1] < 0.045)) > 0.5
    assert np.median(tips0[front(roots0), 1]) > 0.06  # they ended up the head before

    # the parting at x = 3.5 cm from the hairline to the crown: a line of scalp, with
    # under half the hair over it that lies over its mirror image on the other side
    def over(p: np.ndarray, x: float) -> float:
        top = (p[:, 2] > -0.02) & (p[:, 2] < 0.04) & (p[:, 1] > 0.09)
        return float(np.mean(top & (np.abs(p[:, 0] - x) < 0.003)))

    assert over(points, 0.035) < 0.5 * over(points, -0.035)
    assert over(points, 0.035) < 0.5 * over(points0, 0.035)
    assert groom.guides.groups.count == 4  # the head's halves and the parting's two sides
