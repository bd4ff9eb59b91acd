"""Hair on your own mesh

You have a mesh — a creature, a prop, a head from your modelling tool — and you want
fur on it, saved as a file your tools read and as a picture to look at. This tutorial
makes a small creature with [trimesh](https://trimesh.org), writes it as an OBJ in
centimetres (as many modelling tools do), grows 3,000 hairs on it in Python, saves
them, and grows the same groom again from a scene file on the command line.
"""

# %%
# ## The mesh you bring
#
# Any OBJ, PLY, GLB, STL, OFF, USD or Alembic mesh will do. Here it is a capsule-shaped
# body, 24 cm long and lying along X, written in centimetres.
import trimesh

body = trimesh.creation.capsule(height=16.0, radius=4.0, count=[32, 32])  # cm, along Z
body.apply_transform(trimesh.transformations.rotation_matrix(1.5708, [0, 1, 0]))
body.export("creature.obj")
print(
    len(body.vertices), "vertices,", len(body.faces), "faces, extent", body.extents.round(1), "cm"
)

# %%
# ## Load it and grow
#
# `load_mesh` converts the file's units to metres (follicle works in metres, +Y up);
# `units="cm"` says what the file is in. `builtin:short` guides grow on any mesh: 300
# roots spread evenly, each guide marched along the normal and combed back. The groom
# interpolates 3,000 hairs between them. (Guides made for this mesh alone, straight out
# or combed your way, are `follicle.generate_guides`: see
# [Your own mesh: generated guides](../how-to/own-mesh.md).)
import follicle

mesh = follicle.load_mesh("creature.obj", units="cm")
guides = follicle.load_guides("builtin:short", mesh)
groom = follicle.Groom(mesh, guides)
hair = groom.generate(3000)
print(hair.curve_count, "hairs,", hair.point_count, "points")
print("bounds (m):", hair.bounds()[0].round(3), hair.bounds()[1].round(3))

# %%
# ## Look at it
#
# `render_image` draws the hair and the skin; it frames both when no camera is given.
follicle.render_image(hair, mesh=mesh, size=(320, 320), out="creature.png")

# %%
# ![3,000 short hairs on the capsule](creature.png)
#
# ## Restyle, same roots
#
# Settings are values: `replace` makes a checked copy, and the groom regrows from the
# same roots. Longer, frizzier tips and a reddish colour:
groom.params = groom.params.replace(
    frizz_tip=0.004, root_color=(0.09, 0.03, 0.01), tip_color=(0.3, 0.12, 0.04)
)
hair = groom.generate(3000)
follicle.render_image(hair, mesh=mesh, size=(320, 320), out="creature_frizz.png")

# %%
# ![the same roots, frizzier and red](creature_frizz.png)
#
# ## Save it
#
# The native `.npz` keeps every array exactly; the suffix picks the format, so the same
# call writes USD, Alembic, cyHair and the others ([Formats](../how-to/formats/index.md)).
follicle.save(hair, "creature_hair.npz")
follicle.save(hair, "creature_hair.usda")
print(follicle.load_curves("creature_hair.npz").curve_count, "hairs read back")

# %%
# ## The same groom as a scene file
#
# A scene file (TOML) holds the same choices, so the command line can grow and render
# it; relative paths are read from the scene's folder. Every key is in
# [Scene keys](../reference/scene.md).
from pathlib import Path

Path("creature.toml").write_text(
    """
[mesh]
path = "creature.obj"
units = "cm"

[guides]
path = "builtin:short"

[groom]
count = 3000
frizz_tip = 0.004
root_color = [0.09, 0.03, 0.01]
tip_color = [0.3, 0.12, 0.04]
"""
)

# %%
sh("follicle grow creature.toml -o creature.usdc")
sh("follicle info creature.usdc")
sh("follicle render creature.toml -o creature_cli.png --size 320 320")

# %%
# ![the scene rendered by follicle render](creature_cli.png)
#
# Next: [send it to a game engine](game_engines.md), or
# [to Blender](blender.md).
