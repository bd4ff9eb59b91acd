"""The guides' own attributes (a colour the hairs inherit, ``[groom].inherit``) through
brush strokes and settling: edited and settled guides keep them, moved with the points,
and hair grown in the editor or the viewer takes the colours ``follicle grow`` gives for
the edited guides.

The guides' colour runs red → blue linearly in arc length, so the colour anywhere on a
guide is known by hand: at a share u of the guide's length as loaded it is
(1 − u, 0, u). A cut guide keeps the colours of the part left; one grown longer holds
its tip's blue over the new part; any blend of such guides has red + blue = 1."""

from __future__ import annotations

import numpy as np
import pytest

import follicle
from follicle.curves import HairCurves
from follicle.groom.brushes import segment_lengths
from follicle.groom.builtin_guides import builtin_guides
from follicle.io.dispatch import save
from follicle.pipeline import grow
from follicle.scene import parse_scene
from follicle.view import Controller

SIZE = (640, 480)
RED, BLUE = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])


def gradient(u: np.ndarray) -> np.ndarray:
    """The guides' colour at share ``u`` of their length as loaded."""
    u = np.asarray(u, np.float64)[..., None]
    return (1.0 - u) * RED + u * BLUE


@pytest.fixture(scope="module")
def head():
    return follicle.load_mesh("builtin:head")


@pytest.fixture(scope="module")
def guides_file(head, tmp_path_factory):
    """300 long guides whose colour runs red → blue in arc length, a float and an
    integer curve attribute, saved as a file `follicle grow` reads."""
    hc = builtin_guides("long", head, count=300)
    parts = []
    for i in range(hc.curve_count):
        p = hc.points[hc.offsets[i] : hc.offsets[i + 1]].astype(np.float64)
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        parts.append(gradient(arc / arc[-1]))
    color = np.concatenate(parts).astype(np.float32)
    data = {"stiff": np.linspace(0.5, 2.0, hc.curve_count), "tag": np.arange(hc.curve_count)}
    curves = HairCurves(hc.points, hc.offsets, {"color": color}, {**hc.curve_data, **data})
    return save(curves, tmp_path_factory.mktemp("attributed") / "attributed.npz")


@pytest.fixture(scope="module")
def guides(head, guides_file):
    return follicle.load_guides(guides_file, head)


@pytest.fixture(scope="module")
def camera(head):
    lo, hi = head.bounds("rest")
    centre = (lo + hi) / 2
    return follicle.Camera(eye=centre + np.array([0.0, 0.1, 0.8]), target=centre)


def scene(guides_path, **groom):
    return parse_scene(
        {
            "mesh": {"path": "builtin:head"},
            "guides": {"path": str(guides_path)},
            "groom": {"count": 1500, "inherit": ["color"], **groom},
            "render": {"msaa": 0, "shadows": False},
        }
    )


def tips_stroke(ed, camera) -> np.ndarray:
    """A horizontal stroke across the middle of the guides the camera sees."""
    roots = camera.project(ed.points[:, 0], SIZE)[0]
    tips = camera.project(ed.points[:, -1], SIZE)[0]
    y = float(np.median(0.5 * (tips[:, 1] + roots[:, 1])))
    x = float(np.median(tips[:, 0]))
    return np.array([[x - 80.0, y], [x + 80.0, y]])


def colours(ed) -> np.ndarray:
    g = ed.guides
    return g.curves.point_data["color"].reshape(g.count, g.vertex_count, 3).astype(np.float64)


def test_strokes_carry_the_colours_with_the_points(guides, camera):
    ed = follicle.GuideEditor(guides)
    v = guides.vertex_count
    share = np.linspace(0.0, 1.0, v)
    np.testing.assert_allclose(colours(ed), gradient(np.broadcast_to(share, (300, v))), atol=1e-6)
    loaded = segment_lengths(ed.points).sum(axis=1)
    path = tips_stroke(ed, camera)
    combed = ed.stroke("comb", path, camera, radius=60, strength=1.0, size=SIZE)
    assert len(combed) > 20
    # comb keeps every segment's length: each vertex keeps its colour
    np.testing.assert_allclose(colours(ed), gradient(np.broadcast_to(share, (300, v))), atol=1e-6)
    old = ed.points.copy()
    cut = ed.stroke("cut", tips_stroke(ed, camera), camera, radius=5, size=SIZE)
    assert len(cut) > 10
    left = segment_lengths(ed.points).sum(axis=1)[cut] / loaded[cut]
    assert left.max() < 1.0 and left.min() < 0.5
    # each vertex of a cut guide lies on the guide as it was: the colour there, found by
    # hand from where along the old polyline it lies (vertex j of it at share j / (V − 1))
    for g in cut:
        a, b = old[g, :-1], old[g, 1:]
        seg = np.linalg.norm(b - a, axis=1)
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        for k, p in enumerate(ed.points[g]):
            t = np.clip(np.einsum("jk,jk->j", p - a, b - a) / seg**2, 0.0, 1.0)
            off = np.linalg.norm(a + t[:, None] * (b - a) - p, axis=1)
            j = int(np.argmin(off))
            assert off[j] < 1e-6
            u = np.interp(arc[j] + t[j] * seg[j], arc, share)
            np.testing.assert_allclose(colours(ed)[g, k], gradient(u), atol=1e-5)
    # grown longer: the new part holds the tip's colour
    before = colours(ed)
    lengths = segment_lengths(ed.points).sum(axis=1)
    grown = ed.stroke("length", path, camera, radius=60, strength=1.0, size=SIZE)
    longer = grown[segment_lengths(ed.points).sum(axis=1)[grown] > 1.2 * lengths[grown]]
    assert len(longer) > 5
    now = colours(ed)[longer]
    tip = before[longer, -1]
    ratio = lengths[longer] / segment_lengths(ed.points).sum(axis=1)[longer]  # old / new
    # (past a vertex or two of the old tip: each dab resamples the guide again, and a
    # resampled vertex next to the old tip takes some of the colour before it)
    beyond = share[None, :] > ratio[:, None] + 2.0 / (v - 1)
    assert beyond.sum() > 10
    np.testing.assert_allclose(now[beyond], np.repeat(tip, beyond.sum(axis=1), axis=0), atol=5e-4)
    # red + blue = 1 and no green on every guide, the new ones blends of their neighbours
    added = ed.stroke("add", [[240.0, 140.0], [400.0, 140.0]], camera, radius=40, size=SIZE)
    assert len(added) == 5
    c = colours(ed)
    np.testing.assert_allclose(c[..., 0] + c[..., 2], 1.0, atol=1e-6)
    assert np.all(c[..., 1] == 0.0)
    assert np.all(np.diff(c[added, :, 2], axis=1) >= -1e-6)  # bluer towards the tip
    assert c[added, 0, 0].min() > 0.99 and c[added, -1, 2].min() > 0.2  # red roots, blue tips
    data = ed.guides.curves.curve_data
    assert data["tag"].dtype == guides.curves.curve_data["tag"].dtype
    assert set(data["tag"][added].tolist()) <= set(range(300))  # a neighbour's, whole
    assert np.all((data["stiff"][added] >= 0.5) & (data["stiff"][added] <= 2.0))
    # delete keeps the others' rows; undoing everything gives back the loaded bytes
    kept = ed.guides
    gone = ed.stroke("delete", [[320.0, 140.0]], camera, radius=30, size=SIZE)
    rest = np.setdiff1d(np.arange(kept.count), gone)
    assert len(gone) and np.array_equal(colours(ed), colours_of(kept)[rest])
    assert np.array_equal(ed.guides.curves.curve_data["tag"], kept.curves.curve_data["tag"][rest])
    while ed.undo():
        pass
    assert ed.guides is guides


def colours_of(g) -> np.ndarray:
    return g.curves.point_data["color"].reshape(g.count, g.vertex_count, 3).astype(np.float64)


@pytest.mark.slow
def test_hair_grown_from_edited_guides_is_what_follicle_grow_gives(guides, camera, tmp_path):
    ed = follicle.GuideEditor(guides)
    path = tips_stroke(ed, camera)
    ed.stroke("comb", path, camera, radius=60, strength=1.0, size=SIZE)
    ed.stroke("cut", tips_stroke(ed, camera), camera, radius=5, size=SIZE)
    saved = ed.save(tmp_path / "edited.npz")
    _, want = grow(scene(saved))
    groom = follicle.Groom(guides.mesh, guides, scene(saved).groom).with_guides(ed.guides)
    got = groom.generate()
    assert np.array_equal(got.point_data["color"], want.point_data["color"])
    # the cut guides' hairs are bluer nowhere than their guides' new tips
    assert want.point_data["color"][:, 2].max() <= 1.0 + 1e-6


@pytest.mark.slow
def test_the_viewer_grows_the_edited_guides_colours(guides_file, tmp_path):
    c = Controller(scene(guides_file), size=(320, 180), fps=30.0)
    try:
        c.step_frame()
        rest = c.editor.points
        tips = c.camera.project(rest[:, -1], c.size)[0]
        roots = c.camera.project(rest[:, 0], c.size)[0]
        x, y = np.median(tips[:, 0]), np.median(0.5 * (tips[:, 1] + roots[:, 1]))
        c.set_brush("cut", radius=5)
        c.begin_stroke(x - 40, y)
        for dx in range(-20, 60, 40):
            assert c.drag_stroke(x + dx, y) is not None
            c.step_frame()
            shown = c.hair()  # the preview: the hairs of the edited guides, colours too
            full = c.groom.with_guides(c.editor.guides).follow(c.editor.points)
            n = shown.curve_count
            assert np.array_equal(shown.point_data["color"], full[:n].point_data["color"])
        c.end_stroke()
        assert len(c.editor._undo) == 1
        c.reset()
        saved = c.save_guides(tmp_path / "g.npz")
        _, want = grow(scene(saved))
        hair = c.hair()
        assert c.groom.guides is c.editor.guides  # the groom took the cut guides
        assert np.array_equal(hair.point_data["color"], want.point_data["color"])
    finally:
        c.release()


@pytest.mark.slow
def test_settled_guides_keep_their_colours(guides_file):
    _, plain = grow(scene(guides_file))
    _, settled = grow(scene(guides_file, settle=0.2))
    assert not np.array_equal(settled.points, plain.points)  # the hair moved …
    # … its colours did not: settling keeps lengths, so each vertex's share of its guide
    np.testing.assert_allclose(settled.point_data["color"], plain.point_data["color"], atol=2e-3)
