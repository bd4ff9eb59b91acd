"""Grooming by hand (follicle.GuideEditor): each brush's defining property, undo and
redo to the byte, the skin never entered, determinism, save, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

import follicle
from follicle.errors import InputError
from follicle.groom.brushes import dab, segment_lengths
from follicle.groom.builtin_guides import builtin_guides
from follicle.groom.settings import GroomParams
from follicle.render.cpu.engine import skin_depth

SIZE = (640, 480)


@pytest.fixture(scope="module")
def head():
    return follicle.load_mesh("builtin:head")


@pytest.fixture(scope="module")
def guides(head):
    return follicle.Guides(builtin_guides("long", head, count=300), head)


@pytest.fixture(scope="module")
def camera(head):
    lo, hi = head.bounds("rest")
    centre = (lo + hi) / 2
    return follicle.Camera(eye=centre + np.array([0.0, 0.1, 0.8]), target=centre)


def editor(guides) -> follicle.GuideEditor:
    return follicle.GuideEditor(guides)


def screen(camera, points):
    xy, _ = camera.project(points.reshape(-1, 3), SIZE)
    return xy.reshape(*points.shape[:-1], 2)


def seen(mesh, camera, points) -> np.ndarray:
    """Which points (..., 3) the camera sees: in front of the skin's depth (2 %)."""
    xy, depth = camera.project(points.reshape(-1, 3), SIZE)
    pix = np.floor(xy).astype(int)
    skin = skin_depth(mesh, camera, SIZE)
    inside = (pix[:, 0] >= 0) & (pix[:, 0] < SIZE[0]) & (pix[:, 1] >= 0) & (pix[:, 1] < SIZE[1])
    near = skin[pix[:, 1].clip(0, SIZE[1] - 1), pix[:, 0].clip(0, SIZE[0] - 1)]
    return (inside & (depth <= 1.02 * near)).reshape(points.shape[:-1])


def across_the_tips(ed, camera) -> np.ndarray:
    """A horizontal stroke through the middle of the tips the camera sees."""
    tips = screen(camera, ed.points[seen(ed.mesh, camera, ed.points[:, -1]), -1])
    y = float(np.median(tips[:, 1]))
    x = float(np.median(tips[:, 0]))
    return np.array([[x - 60.0, y], [x + 60.0, y]])


def inside(ed, points) -> np.ndarray:
    """Signed distances of every vertex but the roots to the editor's skin."""
    return ed._skin.distance(points[:, 1:].reshape(-1, 3))


def test_a_dab_falls_off_smoothly_to_zero_at_the_radius(camera):
    from follicle.editing.editor import _View

    view = _View(camera, SIZE)
    centre = np.array([320.0, 240.0])
    offsets = np.array([0.0, 5.0, 9.999, 10.0, 12.0])
    pixels = centre + np.stack([offsets, np.zeros(5)], axis=1)
    points = (camera.eye + 0.8 * view.rays(pixels))[None]  # one guide, 5 vertices
    reach, depth = np.empty((1, 5)), np.empty((1, 5))
    seen = np.ones((1, 5), bool)
    hit = dab(points, view.matrix, *SIZE, *centre, 10.0, seen, reach, depth)
    np.testing.assert_allclose(reach[0], [1.0, 0.5625, 0.0, 0.0, 0.0], atol=1e-3)
    assert hit[0] and 0.0 < reach[0, 2] < 1e-6
    # only the root under the brush: nothing to move
    seen[0, 1:] = False
    assert not dab(points, view.matrix, *SIZE, *centre, 10.0, seen, reach, depth)[0]


@pytest.mark.slow
def test_comb_keeps_every_length_and_drags_the_tips_along_the_stroke(guides, camera):
    ed = editor(guides)
    before = ed.points.copy()
    # from the densest cluster of tips the camera sees, 120 pixels to the right
    tips = screen(camera, before[:, -1])
    tips[~seen(ed.mesh, camera, before[:, -1])] = np.nan
    crowd = (np.linalg.norm(tips[:, None] - tips[None], axis=2) < 25).sum(axis=1)
    start = tips[np.argmax(crowd)]
    path = np.array([start, start + [120.0, 0.0]])
    changed = ed.stroke("comb", path, camera, radius=60, strength=1.0, size=SIZE)
    assert len(changed) >= 10
    np.testing.assert_allclose(segment_lengths(ed.points), segment_lengths(before), atol=1e-6)
    assert np.array_equal(ed.points[:, 0], before[:, 0])  # roots stay
    # the stroke goes right: the tips it started on went right (and, swinging about the
    # vertices above them, somewhat up)
    under = np.flatnonzero(np.linalg.norm(tips - path[0], axis=1) < 25)
    assert len(under) >= 3 and set(under) <= set(changed)
    moved = screen(camera, ed.points[under, -1]) - tips[under]
    assert np.all(moved[:, 0] > 10.0) and np.all(moved[:, 0] > np.abs(moved[:, 1]))
    untouched = np.setdiff1d(np.arange(len(before)), changed)
    assert np.array_equal(ed.points[untouched], before[untouched])


def test_comb_carries_the_guide_past_the_brush_without_folding_it(guides, camera):
    """A stroke across the middle of guides drags their tips along too (as a comb
    carries the lengths behind it), and no guide folds where the brush lets go."""
    ed = editor(guides)
    before = ed.points.copy()
    middle = screen(camera, before[:, 10])
    middle[~seen(ed.mesh, camera, before[:, 10])] = np.nan
    crowd = (np.linalg.norm(middle[:, None] - middle[None], axis=2) < 15).sum(axis=1)
    start = middle[np.argmax(crowd)]
    path = np.array([start, start + [80.0, 0.0]])
    changed = ed.stroke("comb", path, camera, radius=30, strength=1.0, size=SIZE)
    under = np.flatnonzero(np.linalg.norm(middle - start, axis=1) < 10)
    tips = screen(camera, before[under, -1])
    assert len(under) >= 3 and set(under) <= set(changed)
    assert np.all(np.linalg.norm(tips - start, axis=1) > 60)  # the tips are off the brush
    mid_moved = screen(camera, ed.points[under, 10])[:, 0] - middle[under, 0]
    tip_moved = screen(camera, ed.points[under, -1])[:, 0] - tips[:, 0]
    # swinging about the root, the carried tip goes further than the middle it hangs from
    assert np.all(mid_moved > 5.0) and np.all(tip_moved > mid_moved)
    d = np.diff(ed.points[changed], axis=1)
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    turn = np.degrees(np.arccos(np.clip(np.sum(d[:, 1:] * d[:, :-1], axis=2), -1, 1)))
    assert turn.max() < 60.0, turn.max()
    np.testing.assert_allclose(segment_lengths(ed.points), segment_lengths(before), atol=1e-6)


def crosses(polyline: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether a screen polyline (V, 2) meets the segment a-b (orientation tests)."""

    def side(p, q, r):
        return (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (
            r[..., 0] - p[..., 0]
        )

    p, q = polyline[:-1], polyline[1:]
    return bool(np.any((side(p, q, a) * side(p, q, b) <= 0) & (side(a, b, p) * side(a, b, q) <= 0)))


def test_cut_shortens_exactly_the_guides_the_stroke_crosses_where_it_crosses(guides, camera):
    ed = editor(guides)
    before = ed.points.copy()
    tips, roots = screen(camera, before[:, -1]), screen(camera, before[:, 0])
    y = float(np.median(0.5 * (tips[:, 1] + roots[:, 1])))
    x = float(np.median(tips[:, 0]))
    a, b = np.array([x - 80.0, y]), np.array([x + 80.0, y])
    changed = ed.stroke("cut", [a, b], camera, radius=5, size=SIZE)
    # the guides with a segment the camera sees (both ends) that crosses the stroke
    visible = seen(guides.mesh, camera, before)
    proj = screen(camera, before)
    expected = [
        g
        for g in range(len(before))
        if any(
            visible[g, i] and visible[g, i + 1] and crosses(proj[g, i : i + 2], a, b)
            for i in range(before.shape[1] - 1)
        )
    ]
    assert len(changed) >= 10 and changed.tolist() == expected
    lengths = segment_lengths(before).sum(axis=1)
    after = segment_lengths(ed.points).sum(axis=1)
    for g in changed:
        assert after[g] < lengths[g] - 1e-6
        tip = screen(camera, ed.points[g, -1])  # on the stroke
        assert abs(tip[1] - y) < 1e-6 and a[0] <= tip[0] <= b[0]
    untouched = np.setdiff1d(np.arange(len(before)), changed)
    assert np.array_equal(ed.points[untouched], before[untouched])


def test_undo_and_redo_restore_the_bytes(guides, camera):
    ed = editor(guides)
    start = ed.points.copy()
    path = across_the_tips(ed, camera)
    assert len(ed.stroke("comb", path, camera, radius=60, strength=1.0, size=SIZE))
    combed = ed.points.copy()
    assert len(ed.stroke("smooth", path, camera, radius=60, size=SIZE))
    roots = np.median(screen(camera, ed.points[:, 0]), axis=0)
    assert len(ed.stroke("delete", [roots], camera, radius=60, size=SIZE))
    assert ed.undo() and ed.undo()
    assert np.array_equal(ed.points, combed)
    assert ed.undo() and not ed.undo()
    assert np.array_equal(ed.points, start)
    assert ed.redo() and np.array_equal(ed.points, combed)
    ed.stroke("puff", path, camera, radius=60, size=SIZE)
    assert not ed.can_redo  # a new stroke drops what was taken back


def test_undoing_every_stroke_gives_back_the_loaded_guides_to_the_bit(head, guides, camera):
    """The start is the guides as loaded, not their float64 rest shapes rounded back
    (one float32 step, 3e-8 m, off): a groom grown from them is the file's, byte for byte."""
    ed = editor(guides)
    path = across_the_tips(ed, camera)
    ed.stroke("comb", path, camera, radius=60, strength=1.0, size=SIZE)
    ed.stroke("length", path, camera, radius=60, strength=0.5, size=SIZE)
    while ed.undo():
        pass
    back = ed.guides.curves
    assert back.points.tobytes() == guides.curves.points.tobytes()
    assert np.array_equal(back.offsets, guides.curves.offsets)
    for key, value in guides.curves.curve_data.items():
        assert back.curve_data[key].tobytes() == value.tobytes(), key
    grown = follicle.Groom(head, ed.guides).generate(count=2000)
    loaded = follicle.Groom(head, guides).generate(count=2000)
    assert grown.points.tobytes() == loaded.points.tobytes()
    assert ed.redo() and ed.redo() and not ed.redo()  # and forward again
    assert back.points.tobytes() != ed.guides.curves.points.tobytes()


@pytest.mark.parametrize("brush", ["comb", "smooth", "puff", "length", "add"])
def test_no_vertex_is_left_inside_the_skin(guides, camera, brush):
    ed = editor(guides)
    before = ed.points.copy()
    path = across_the_tips(ed, camera)
    # push towards the head: a stroke from the tips up over the face
    path = np.array([path[0], [path[1, 0], path[1, 1] - 200.0]])
    strength = -0.5 if brush == "length" else 1.0
    changed = ed.stroke(brush, path, camera, radius=80, strength=strength, size=SIZE)
    assert len(changed) > 0
    d = inside(ed, ed.points[changed])
    assert d.min() >= ed._clearance * (1.0 - 1e-6)
    if brush != "add":
        assert not np.array_equal(ed.points, before)


def test_length_grows_and_shrinks_the_guides_under_it(guides, camera):
    ed = editor(guides)
    before = segment_lengths(ed.points).sum(axis=1)
    path = across_the_tips(ed, camera)
    grown = ed.stroke("length", path, camera, radius=60, strength=0.5, size=SIZE)
    after = segment_lengths(ed.points).sum(axis=1)
    assert len(grown) and np.all(after[grown] > before[grown])
    assert np.max(after[grown] / before[grown]) > 1.2
    ed.undo()
    shrunk = ed.stroke("length", path, camera, radius=60, strength=-0.5, size=SIZE)
    after = segment_lengths(ed.points).sum(axis=1)
    assert np.array_equal(np.sort(shrunk), np.sort(grown))
    assert np.all(after[shrunk] < before[shrunk]) and np.min(after[shrunk] / before[shrunk]) < 0.8


def turning(points: np.ndarray) -> np.ndarray:
    """The angle each guide turns by at each inner vertex (S, V − 2)."""
    seg = np.diff(points, axis=1)
    seg /= np.linalg.norm(seg, axis=2, keepdims=True)
    return np.arccos(np.clip(np.einsum("svk,svk->sv", seg[:, 1:], seg[:, :-1]), -1, 1))


@pytest.mark.slow
def test_smooth_straightens_and_puff_lifts_from_the_root(head, guides, camera):
    ed = editor(follicle.Guides(builtin_guides("curly", head, count=300), head))
    path = across_the_tips(ed, camera)
    before = ed.points.copy()
    smoothed = ed.stroke("smooth", path, camera, radius=60, strength=1.0, size=SIZE)
    assert len(smoothed) >= 10
    # at the inner vertices that were well under the brush, the curls turn much less
    xy = screen(camera, before[smoothed, 1:-1])
    under = (np.abs(xy[..., 1] - path[0, 1]) < 20) & (xy[..., 0] > path[0, 0] + 20)
    under &= xy[..., 0] < path[1, 0] - 20
    assert under.sum() >= 20
    ahead, after = turning(before[smoothed]), turning(ed.points[smoothed])
    assert after[under].sum() < 0.85 * ahead[under].sum()
    np.testing.assert_allclose(segment_lengths(ed.points), segment_lengths(before), atol=1e-6)
    ed = editor(guides)
    before = ed.points.copy()
    roots = screen(camera, before[:, 0])
    lifted = ed.stroke("puff", [np.median(roots, axis=0)], camera, radius=120, size=SIZE)
    normal = ed._root_frames.normal[lifted]
    first = lambda p: p[lifted, 1] - p[lifted, 0]  # noqa: E731
    up = lambda p: np.einsum("sk,sk->s", first(p), normal) / np.linalg.norm(first(p), axis=1)  # noqa: E731
    assert len(lifted) and np.all(up(ed.points) >= up(before) - 1e-9)
    assert np.mean(up(ed.points) - up(before)) > 0.05


def test_add_and_delete_change_the_count(guides, camera):
    ed = editor(guides)
    n = ed.guides.count
    lo, hi = np.array([240.0, 140.0]), np.array([400.0, 140.0])  # over the forehead
    added = ed.stroke("add", [lo, hi], camera, radius=40, size=SIZE)
    assert len(added) == 5 and ed.guides.count == n + 5  # 160 px at one radius apart
    assert np.array_equal(added, np.arange(n, n + 5))
    new = ed.points[added]
    # on the skin under the stroke, as long as their neighbours
    np.testing.assert_allclose(screen(camera, new[:, 0])[:, 1], 140.0, atol=0.5)
    assert np.all(segment_lengths(new).sum(1) > 0.05)
    planted = ed.guides.curves[added[:3]]
    gone = ed.stroke("delete", [lo, hi], camera, radius=10, size=SIZE)
    assert len(gone) >= 5 and ed.guides.count == n + 5 - len(gone)
    assert set(added) <= set(gone)
    # the guides the camera sees, alone: one stroke over them all would leave none
    few = follicle.GuideEditor(follicle.Guides(planted, ed.mesh))
    with pytest.raises(InputError, match="every guide"):
        few.stroke("delete", [lo, hi], camera, radius=20, size=SIZE)
    assert few.guides.count == 3


def test_the_same_strokes_give_the_same_bytes_and_save_round_trips(guides, camera, tmp_path):
    runs = []
    for _ in range(2):
        ed = editor(guides)
        path = across_the_tips(ed, camera)
        for brush in ("comb", "smooth", "length", "cut", "add"):
            ed.stroke(brush, path, camera, radius=50, strength=0.4, size=SIZE)
        runs.append(ed)
    assert runs[0].points.tobytes() == runs[1].points.tobytes()
    out = runs[0].save(tmp_path / "edited.npz")
    back = follicle.load_guides(out, guides.mesh)
    assert back.count == runs[0].guides.count
    np.testing.assert_allclose(
        back.rest_shapes(back.vertex_count),
        runs[0].guides.rest_shapes(back.vertex_count),
        atol=1e-6,
    )


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"brush": "teleport"}, "brush"),
        ({"path": [[1.0, 2.0, 3.0]]}, "path"),
        ({"path": []}, "path"),
        ({"path": [[np.nan, 1.0]]}, "path"),
        ({"radius": 0}, "radius"),
        ({"strength": 2.0}, "strength"),
        ({"brush": "comb", "strength": -0.5}, "strength"),
        ({"size": (640,)}, "size"),
        ({"camera": "front"}, "camera"),
        ({"spacing": 3}, "unknown option"),
    ],
)
def test_bad_strokes_name_the_argument(guides, camera, kwargs, match):
    ed = editor(guides)
    args = {"brush": "smooth", "path": [[10.0, 10.0]], "camera": camera, "radius": 10.0}
    args.update({"size": SIZE, **kwargs})
    with pytest.raises(InputError, match=match):
        ed.stroke(**args)
    assert ed.points.tobytes() == editor(guides).points.tobytes()


@pytest.fixture(scope="module")
def above(head):
    lo, hi = head.bounds("rest")
    centre = (lo + hi) / 2
    return follicle.Camera(eye=centre + np.array([0.0, 0.6, 0.4]), target=centre)


@pytest.mark.slow
def test_part_combs_each_side_away_and_paints_the_groups(head, above, tmp_path):
    g = follicle.load_guides("builtin:short", head)
    ed = follicle.GuideEditor(g)
    before = ed.points.copy()
    line = np.array([[300.0, 40.0], [300.0, 220.0]])  # front to crown, right of the middle
    parted = ed.stroke("part", line, above, radius=40, strength=0.6, size=SIZE)
    assert len(parted) >= 10
    np.testing.assert_allclose(segment_lengths(ed.points), segment_lengths(before), atol=1e-6)
    roots = screen(above, before[parted, 0])
    moved = screen(above, ed.points[parted, -1]) - screen(above, before[parted, -1])
    left = roots[:, 0] < 300.0
    assert left.any() and (~left).any()
    assert np.all(moved[left, 0] < 0.0) and np.all(moved[~left, 0] > 0.0)  # away from it
    # and none crosses it: every vertex on its root's side, as far from it as the root
    xs = screen(above, ed.points[parted])[..., 0] - 300.0
    gap = np.abs(roots[:, 0] - 300.0)
    assert np.all(np.where(left[:, None], -xs, xs) >= gap[:, None] - 1.0)
    # two new groups, one a side, for the roots near the line; the far ones keep theirs
    labels = [ed.groups.label(int(k)) for k in ed.guides.group]
    old = [g.groups.label(int(k)) for k in g.group]
    new = {ed.groups.label(k) for k in range(ed.groups.count)} - set(old)
    assert len(new) == 2
    got = np.array(labels)[parted]
    assert len(set(got[left])) == 1 and len(set(got[~left])) == 1
    assert set(got[left]) | set(got[~left]) == new
    every = screen(above, before[:, 0])
    far = np.flatnonzero(np.abs(every[:, 0] - 300.0) > 50.0)  # a texel's width past the band
    assert len(far) > 50 and [labels[k] for k in far] == [old[k] for k in far]
    # hairs grow from the parted groups: each rooted in a new group takes its own side
    hair = follicle.Groom(head, ed.guides).generate(count=3000)
    assert hair.curve_count == 3000
    # the painted groups round-trip through a PNG, as [groom].groups reads them
    png = ed.save_groups(tmp_path / "parting.png")
    back = follicle.groom.groups.InterpolationGroups(follicle.Texture.load(png))
    uv = ed._root_frames.uv
    assert [back.label(int(k)) for k in back.group_of(uv)] == labels
    assert ed.undo() and [ed.groups.label(int(k)) for k in ed.guides.group] == old


@pytest.mark.slow
def test_a_parting_with_no_guide_on_one_side_is_refused(head, above):
    ed = follicle.GuideEditor(follicle.load_guides("builtin:short", head))
    roots = screen(above, ed.points[:, 0])
    x = roots[:, 0].max() + 2.0  # just past the last root on screen: nothing on its right
    y0, y1 = roots[:, 1].min(), roots[:, 1].max()
    with pytest.raises(InputError, match="no guide"):
        ed.stroke("part", [[x, y0], [x, y1]], above, radius=40, size=SIZE)
    assert not ed.can_undo


def test_joined_pieces_are_one_stroke_to_undo_and_replay(guides, camera, tmp_path):
    ed = editor(guides)
    start = ed.points.copy()
    path = across_the_tips(ed, camera)
    pieces = np.linspace(path[0], path[1], 5)
    for k in range(4):
        ed.stroke("comb", pieces[k : k + 2], camera, 60, 1.0, SIZE, join=k > 0)
    assert [e.get("join", False) for e in ed.log] == [False, True, True, True]
    log = ed.save_strokes(tmp_path / "drag.json")
    again = editor(guides)
    again.replay(log)
    assert again.points.tobytes() == ed.points.tobytes()
    assert ed.undo() and np.array_equal(ed.points, start) and not ed.undo()


@pytest.mark.parametrize("skip", [None, 0.9999])
@pytest.mark.slow
def test_regrowing_only_the_hairs_on_changed_guides_equals_growing_all(head, guides, camera, skip):
    """Groom.regrow after comb, cut and length strokes: the same bytes as Groom.follow of
    every hair (clumps on: a hair also hangs on its clump centre's guides), and the
    hairs on no changed guide kept as they were, not grown again. With vertex skipping
    (Šik 2012 §2.2.9) a hair's vertex count follows its shape, so regrown hairs change
    their counts and the curves are joined anew."""
    params = GroomParams(count=3000, clump_count=60, skip_threshold=skip)
    groom = follicle.Groom(head, guides, params)
    counts_changed = False
    ed = editor(guides)
    shown = groom.follow(ed.points)
    mid = across_the_tips(ed, camera).mean(axis=0)
    strokes = [  # short strokes: a few guides of many
        ("comb", mid + [[-20.0, 0.0], [20.0, 0.0]], 30, 0.8),
        ("cut", mid + [[-20.0, -40.0], [20.0, -40.0]], 5, 0.5),
        ("length", mid + [[-20.0, -80.0], [0.0, -80.0]], 30, 0.5),
    ]
    for brush, path, radius, strength in strokes:
        changed = ed.stroke(brush, path, camera, radius, strength, SIZE)
        assert 0 < len(changed) < guides.count // 2
        full = groom.follow(ed.points)
        kept = shown.copy()
        kept.point_data["width"][:] += 1.0  # a mark on every hair of the last regrowth
        regrown = groom.regrow(kept, ed.points, changed)
        assert regrown.points.tobytes() == full.points.tobytes()
        assert np.array_equal(regrown.offsets, full.offsets)
        for key, value in full.curve_data.items():
            assert np.array_equal(regrown.curve_data[key], value), key
        marked = regrown.point_data["width"] > full.point_data["width"] + 0.5
        again = ~marked[regrown.offsets[:-1]]  # per curve: grown again
        assert 0 < again.sum() < 0.9 * regrown.curve_count  # some, not all
        counts_changed |= not np.array_equal(shown.counts, full.counts)
        shown = groom.regrow(shown, ed.points, changed)
        assert shown == full
    assert counts_changed == (skip is not None)  # both ways of splicing were run
    assert groom.regrow(shown, ed.points, []) is shown
    with pytest.raises(InputError, match="changed"):
        groom.regrow(shown, ed.points, [guides.count])
