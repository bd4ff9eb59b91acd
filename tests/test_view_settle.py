"""The viewer and ``[groom].settle``: it shows the rest pose ``follicle render`` grows
from (the guides settled by :func:`follicle.pipeline.groom_inputs`) on open, and after a
change of a key that pose comes from it settles again in the background, with a status
line meanwhile, and then rests on what the pipeline gives for the scene as changed."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.pipeline import groom_inputs, groom_scene
from follicle.scene import parse_scene
from follicle.view import Controller

SECONDS = 0.3


def scene(**groom):
    return parse_scene(
        {
            "guides": {"path": "builtin:long"},
            "groom": {"count": 1500, "settle": SECONDS, **groom},
            "render": {"msaa": 0, "shadows": False},
        }
    )


def rest(guides) -> bytes:
    return guides.curves.points.tobytes()


def agrees(c: Controller) -> None:
    """The viewer's groom and simulation rest on the guides the pipeline gives for its
    scene now, and the hair shown at time 0 is the groom's."""
    inputs = groom_inputs(c.scene)
    assert rest(c.groom.guides) == rest(inputs.guides)
    assert c.sim._guides is c.groom.guides  # the simulation rests on them too
    assert c.time == 0.0
    hair = c.hair()
    shown = groom_scene(c.scene, inputs).follow(c.sim, count=hair.curve_count)
    assert np.array_equal(hair.points, shown.points)


@pytest.mark.slow
def test_the_viewer_settles_again_when_the_rest_pose_changes():
    c = Controller(scene(), size=(160, 90), fps=30.0)
    try:
        plain = groom_inputs(scene(settle=0.0)).guides
        assert rest(c.groom.guides) != rest(plain)  # settled on open, as render
        agrees(c)
        c.step_frame()
        # weaker gravity: the guides settle again (in the background, a status line says)
        c.set_param("sim", "gravity", (0.0, -3.0, 0.0))
        assert c.settling and "settling the guides (0.3 s)" in c.status
        c.step_frame()  # the viewer goes on drawing meanwhile
        assert c.wait_settled(120.0) and not c.settling and c.status == ""
        agrees(c)
        # a key the pose does not come from settles nothing
        c.set_param("sim", "motion", "nod")
        assert not c.settling
        # two changes in a row: only the last one's pose is taken
        c.set_param("sim", "damping", 3.0)
        c.set_param("sim", "damping", 4.0)
        assert c.wait_settled(120.0)
        agrees(c)
        c.set_param("sim", "damping", 5.0)
        assert c.settling
        c.release()  # the end of a session drops the settle going on
        assert not c.settling
        # settle 0: the guides as loaded
        c.set_param("groom", "settle", 0.0)
        assert c.wait_settled(120.0)
        agrees(c)
        assert rest(c.groom.guides) == rest(plain)
    finally:
        c.release()


@pytest.mark.slow
def test_hand_strokes_are_replayed_on_the_guides_settled_again():
    c = Controller(scene(), size=(320, 180), fps=30.0)
    try:
        c.step_frame()
        tips = c.camera.project(c.editor.points[:, -1], c.size)[0]
        x, y = np.median(tips, axis=0)
        c.set_brush("comb", radius=40, strength=1.0)
        c.begin_stroke(x, y)
        c.drag_stroke(x + 60, y)
        c.end_stroke()
        log = list(c.editor.log)
        c.set_param("sim", "gravity", (0.0, -3.0, 0.0))
        assert c.wait_settled(120.0)
        settled = groom_inputs(c.scene).guides
        assert c.editor.log == log and c.editor.can_undo
        assert rest(c.groom.guides) == rest(c.editor.guides) != rest(settled)
        c.undo_groom()  # the stroke taken back: the guides settled for the scene now
        assert rest(c.editor.guides) == rest(settled)
    finally:
        c.release()
