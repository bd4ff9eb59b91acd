"""From Blender and back

You are a Blender artist: you modelled a head and drew a few guide curves in Blender,
and you want thousands of hairs grown from them, back in Blender to render with
Cycles. This tutorial grows the groom from a mesh and guides as Blender exports them,
writes USD for the `blender` target, and checks the file as Blender will read it. The
docs build has no Blender, so the steps inside Blender are described, not run.
"""

# %%
# ## What Blender gives you
#
# In Blender: select the head, *File › Export › Wavefront (.obj)* (or USD), and the
# guide curves (a Curves object, or legacy NURBS, poly or Bézier curves), *File ›
# Export › Universal Scene Description*. Here, the built-in head and guides stand in
# for them, written the same way:
sh("follicle export builtin:head -o head.obj")

# %%
import follicle

mesh = follicle.load_mesh("head.obj")
guides = follicle.load_guides("builtin:long", mesh)
follicle.save(guides.curves, "guides.usdc")
print(follicle.load_curves("guides.usdc"))

# %%
# ## The groom
#
# A scene that names the two files; follicle binds each guide to the nearest point of
# the mesh, then interpolates the hair between them.
from pathlib import Path

Path("groom.toml").write_text(
    """
[mesh]
path = "head.obj"

[guides]
path = "guides.usdc"

[groom]
count = 3000
clump_count = 150
clump_tip = 0.35
frizz_tip = 0.002
root_color = [0.12, 0.06, 0.02]
tip_color = [0.35, 0.2, 0.08]

[output]
target = "blender"
"""
)

# %%
sh("follicle render groom.toml -o preview.png --size 320 320")

# %%
# ![a quick look before Blender: 3,000 hairs from the guides](preview.png)
#
# ## USD for Blender
#
# `[output].target = "blender"` (or `--target blender`) writes the root UVs as
# `surface_uv_coordinate`, the ids as 32-bit ints (Blender drops 64-bit ones) and leaves
# out the normals Blender ignores; the skin goes beside the hair and the guides as
# their own curves. `follicle check` confirms Blender reads all of it.
sh("follicle grow groom.toml -o groom.usdc")
sh("follicle check groom.usdc --target blender")

# %%
# Alembic is no way to Blender: its importer keeps the points and widths only, and the
# check says so.
sh("follicle grow groom.toml -o groom.abc")
sh("follicle check groom.abc --target blender", expect=1)

# %%
# ## In Blender
#
# *File › Import › Universal Scene Description*, `groom.usdc`, default settings: the
# skin arrives with its UVs, the hair as a Curves object (points exact, radius = width
# / 2, `displayColor`, `surface_uv_coordinate`), the guides as another. Give the hair a
# *Principled Hair BSDF* and render with Cycles. `tests/blender_scripts/render_groom.py`
# in the repository does all of that from a Python that has `bpy` (`pip install bpy`):
#
# ```bash
# python tests/blender_scripts/render_groom.py groom.usdc cycles.png --size 640 --samples 16
# ```
#
# which made this picture of the demo's groom (20,000 hairs on the bust) — made by
# Blender outside the docs build:
#
# ![our groom rendered by Cycles in Blender](../blender.png)
#
# [Targets](../how-to/formats/targets.md) lists what Blender keeps of each attribute,
# measured in Blender itself; a groom grown from melanin arrives with each hair's
# melanin for Principled Hair.
