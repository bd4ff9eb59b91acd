"""A head shake in the wind

You have a groom and a shot: the character shakes its head, a breeze blows, and the
hair must not pass through the shoulder. This tutorial simulates the guide hairs of a
small groom under a built-in head shake, adds wind and a collider, renders frames of
the result, and exports the animation for a renderer or an engine.
"""

# %%
# ## The scene
#
# The built-in head with long hair, and a `[sim]` table: the `shake` motion (a fading
# "no", `motion_period` seconds, then holding still), a steady wind with gusts, and a
# capsule collider for the shoulders (the built-in head ends at the neck). Every key is
# in [Scene keys](../reference/scene.md#sim).
from pathlib import Path

Path("shot.toml").write_text(
    """
[mesh]
path = "builtin:head"

[guides]
path = "builtin:long"

[groom]
count = 2000
seed = 3
root_color = [0.05, 0.025, 0.012]
tip_color = [0.12, 0.07, 0.035]

[sim]
motion = "shake"
motion_period = 1.0
wind = [0.6, 0.0, 0.3]        # m/s, from the front left
wind_gust = 0.5
wind_gust_period = 1.0

[[sim.colliders]]             # the shoulders: a capsule across, below the head
kind = "capsule"
a = [-0.18, -0.30, -0.02]
b = [0.18, -0.30, -0.02]
radius = 0.07

[render]
eye = [0.6, 0.05, 0.9]
target = [0.0, -0.12, 0.0]
"""
)

# %%
# ## Simulate
#
# `follicle simulate` steps the scene's 300 guides through 24 frames at 24 frames/s and
# stores each frame's guides and head transform in a cache (`.npz`); `--motion` would
# override the scene's motion (`nod`, `turn`, `shake`).
sh("follicle simulate shot.toml --frames 24 --fps 24 -o shot.npz")

# %%
# ## Look at frames
#
# `follicle render` grows the scene's hairs on each frame's simulated guides and draws
# them through one camera; `--frames` picks a range (STOP excluded). Frame 0 is the rest
# state, frame 6 a quarter into the shake, frame 12 its middle.
sh("follicle render shot.npz -o frames --frames 0:13 --size 320 320")

# %%
from PIL import Image

strip = Image.new("RGB", (960, 320))
for column, frame in enumerate((0, 6, 12)):
    strip.paste(Image.open(f"frames/frame_{frame:04d}.png").convert("RGB"), (320 * column, 0))
strip.save("shake.png")

# %%
# ![frames 0, 6 and 12 of the shake](shake.png)
#
# `-o shot.mp4` writes a video instead of a folder of frames (it needs the
# `imageio-ffmpeg` extra).
#
# ## The cache, in Python
#
# The cache is a plain `.npz`: positions per frame, the head's transform per frame, the
# scene it came from. The final stretch and penetration tell you the solver held:
import numpy as np

cache = np.load("shot.npz")
print(cache["positions"].shape, "(frames, guides, vertices, xyz)")
tips = cache["positions"][:, :, -1]
travel = np.linalg.norm(tips - tips[0], axis=-1).max()
print(f"largest tip travel from rest: {travel:.3f} m")

# %%
# ## Export the animation
#
# A cache exports alone to animated USD or Alembic — the guides' points sampled per
# frame, with the target's names — for Houdini, Blender or Unreal to grow and render
# their own hair from, and `follicle check` reads it as the tool would.
sh("follicle export shot.npz -o shot_unreal.abc --target unreal")
sh("follicle check shot_unreal.abc --target unreal")
sh("follicle export shot.npz -o shot.usdc --target houdini")
sh("follicle info shot.usdc")

# %%
# The same in Python, frame by frame, is `follicle.Simulator` and `Groom.follow`
# ([Dynamics](../how-to/dynamics.md), which also covers skin animation from a file,
# settling, and the solver's settings).
