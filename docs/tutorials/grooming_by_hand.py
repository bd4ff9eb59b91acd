"""Grooming by hand

You want a style the procedural settings do not give — hair combed back, a side
parting, a fringe cut straight — and you want it repeatable. The brushes of
`follicle.GuideEditor` shape the guides as a mouse does in `follicle view`: each
stroke is a line of pixels in a view through a camera. This tutorial makes a few
strokes from Python, looks at the hair before and after, and saves the strokes as a
log that `follicle groom` replays into the same guides, byte for byte.
"""

# %%
# ## Before
#
# The built-in bust and its `builtin:short` guides, 4,000 hairs as they grow.
import numpy as np

import follicle

mesh = follicle.load_mesh("builtin:bust")
editor = follicle.GuideEditor(follicle.load_guides("builtin:short", mesh))
look = follicle.Camera(eye=(0.35, 0.45, 0.55), target=(0.0, 0.04, 0.0), fov_y=30)
before = follicle.Groom(mesh, editor.guides).generate(4000)
follicle.render_image(before, mesh=mesh, camera=look, size=(320, 320), out="before.png")

# %%
# ![the short guides as they grow](before.png)
#
# ## Strokes
#
# A stroke is a list of pixels in a `SIZE` view through a camera, and a brush radius in
# pixels. Here the pixels come from points on the head, projected through the camera
# the stroke is drawn from (what you would drag over in the viewer): two combs back over
# the top, a parting over the left eye seen from above, and the fringe combed down and
# cut straight at the brow.
SIZE = (960, 540)
side = follicle.Camera(eye=(0.9, 0.1, 0.1), target=(0.0, 0.03, 0.0), fov_y=30)
above = follicle.Camera(eye=(0.0, 0.9, 0.15), target=(0.0, 0.05, 0.0), fov_y=30)
high_front = follicle.Camera(eye=(0.0, 0.6, 0.6), target=(0.0, 0.05, 0.0), fov_y=30)
front = follicle.Camera(eye=(0.0, 0.2, 0.85), target=(0.0, 0.04, 0.0), fov_y=30)


def pixels(camera, points):
    """World points (metres) as the pixels of the view they are seen at."""
    xy, _ = camera.project(np.asarray(points, np.float64), SIZE)
    return np.round(xy, 1).tolist()


for r in (0.105, 0.095):  # comb back, along the skull's profile
    angles = np.radians([45, 70, 90, 115, 140, 170])
    profile = [[0.0, 0.03 + r * np.sin(a), r * np.cos(a)] for a in angles]
    editor.stroke("comb", pixels(side, profile), side, radius=26, strength=0.6, size=SIZE)
parting = [[0.035, 0.095, 0.06], [0.035, 0.12, -0.04]]
editor.stroke("part", pixels(above, parting), above, radius=24, strength=1.0, size=SIZE)
for x in np.linspace(-0.055, 0.025, 9):  # the fringe, forward and down
    down = [[x, 0.115, 0.0], [x, 0.1, 0.06], [x, 0.07, 0.1], [x, 0.03, 0.13]]
    editor.stroke("comb", pixels(high_front, down), high_front, radius=18, strength=1.0, size=SIZE)
brow = [[-0.06, 0.035, 0.1], [0.04, 0.035, 0.1]]
editor.stroke("cut", pixels(front, brow), front, radius=10, size=SIZE)
print(len(editor.log), "strokes")

# %%
# ## After
#
# The groom grows from the edited guides; the parting brush also painted two
# interpolation groups, one a side, so no hair blends guides from both sides of it.
editor.save_groups("groups.png")
groom = follicle.Groom(mesh, editor.guides)
groom.params = groom.params.replace(groups="groups.png")
after = groom.generate(4000)
follicle.render_image(after, mesh=mesh, camera=look, size=(320, 320), out="after.png")

# %%
# ![combed back, parted, a fringe cut at the brow](after.png)
#
# ## The strokes as a log
#
# A stroke log (JSON) names the mesh and guides it started from; `follicle groom`
# replays it headless into a guides file (and the groups the parting painted), the
# same bytes as the editor's own guides. Undo and redo (`editor.undo()`) edit the log
# too.
editor.save_strokes("strokes.json", mesh="builtin:bust", guides="builtin:short")
editor.save("edited.npz")

# %%
sh("follicle groom strokes.json -o guides.npz --groups replayed_groups.png")

# %%
from pathlib import Path

same = Path("guides.npz").read_bytes() == Path("edited.npz").read_bytes()
print("replayed guides identical to the editor's:", same)

# %%
# A scene grows from them like any guides, here with 4,000 hairs:
Path("groomed.toml").write_text(
    """
[mesh]
path = "builtin:bust"

[guides]
path = "guides.npz"

[groom]
count = 4000
groups = "replayed_groups.png"

[render]
eye = [0.35, 0.45, 0.55]
target = [0.0, 0.04, 0.0]
fov = 30.0
"""
)

# %%
sh("follicle render groomed.toml -o groomed.png --size 320 320")

# %%
# ![the replayed groom, rendered from its scene](groomed.png)
#
# In the viewer (`follicle view groomed.toml`; a window, so not run here) the same
# brushes are on the mouse, and the panel saves the strokes and the edited scene.
# [Grooming by hand](../how-to/grooming-by-hand.md) describes every brush and what it
# keeps; `examples/hand_groomed.py` is a longer groom made this way.
