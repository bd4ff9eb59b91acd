"""A groom for Unreal and Unity

You are a technical director on a game: a groom has to reach Unreal Engine's Groom
importer and Unity's hair package, and each reads hair its own way — Unreal only the
`groom_*` attributes of its schema, in centimetres, at most 255 points a curve; Unity
refuses a whole file for one curve of fewer than 2 points. This tutorial grows a small
groom for each with `--target`, and checks each file with `follicle check` before it
goes to the engine, so a problem shows here and not in the importer.
"""

# %%
# ## The groom
#
# A scene file: long hair on the built-in bust, 2,000 hairs (a game groom has tens of
# thousands; the steps are the same). `follicle info groom.toml` would print it with
# every default filled in: the keys your team will want to pin down.
from pathlib import Path

Path("groom.toml").write_text(
    """
[mesh]
path = "builtin:bust"

[guides]
path = "builtin:long"

[groom]
count = 2000
seed = 7
groups = "builtin:parting"
clump_count = 120
clump_tip = 0.3
root_color = [0.02, 0.011, 0.006]
tip_color = [0.07, 0.042, 0.022]
"""
)

# %%
sh("follicle render groom.toml -o groom.png --size 320 320")

# %%
# ![the groom on the built-in bust](groom.png)
#
# ## Unreal: USD and Alembic
#
# `--target unreal` names the attributes as Unreal's groom schema does
# (`groom_color`, `groom_root_uv`, `groom_id`, `groom_group_id`: the interpolation
# group each hair grew in), puts the guides inside the groom with `groom_guide` = 1 and
# ids of their own (from 2³⁰, never a hair's) and each hair's three closest guides and
# weights, applies Unreal's `GroomAPI` in USD and writes Alembic in centimetres with the
# groom version properties. `follicle check` reads the file back as the engine would
# and lists what it would drop or refuse; it exits 0 when nothing.
sh("follicle grow groom.toml -o groom_unreal.usdc --target unreal")
sh("follicle check groom_unreal.usdc --target unreal")
sh("follicle grow groom.toml -o groom_unreal.abc --target unreal")
sh("follicle check groom_unreal.abc --target unreal")

# %%
# In Unreal: drag `groom_unreal.abc` into the Content Browser (the Groom plugins
# enabled), or import the USD with the USD Importer. The Alembic file holds hair and
# guides only — Unreal's Alembic groom importer refuses a file that holds a mesh — while
# the USD file carries the skin beside the hair for binding (`--no-skin` leaves it out).
#
# ## Unity
#
# Unity's hair package imports Alembic through Unity's Alembic importer, which keeps
# points, widths, UVs and velocities only. `--target unity` writes just those, in the
# units the hair package reads by default (points in metres, widths in centimetres):
# each hair's root UV on every one of its vertices (the package reads a root's UV at
# `UVs[i * vertexCount]`), one curves object per interpolation group, and no guides
# (the package would make a strand group of them). `check` confirms it. In the hair
# asset, choose "Preserve" under the Alembic groups for one strand group per
# interpolation group.
sh("follicle grow groom.toml -o groom_unity.abc --target unity")
sh("follicle check groom_unity.abc --target unity")

# %%
# ## What a check catches
#
# A file written for another tool — here, Houdini's names and 64-bit ids — checked for
# Unreal: one line per problem, each ending with its fix, and exit status 1, so a
# pipeline step can stop on it.
sh("follicle grow groom.toml -o groom_houdini.usdc --target houdini")
sh("follicle check groom_houdini.usdc --target unreal", expect=1)

# %%
# The fix the lines name is the export, not a hand edit: `follicle export` rewrites any
# hair file for another target.
sh("follicle export groom_houdini.usdc -o fixed_unreal.usdc --target unreal")
sh("follicle check fixed_unreal.usdc --target unreal")

# %%
# ## What is in the file
#
# The same check from Python, and a look at the attributes Unreal will read:
import follicle

hair = follicle.load_curves("groom_unreal.usdc")
print(hair)
print(sorted(hair.curve_data), sorted(hair.point_data))

# %%
# [Targets](../how-to/formats/targets.md) has the full table of names, types and units
# per tool; [USD](../how-to/formats/usd.md) and [Alembic](../how-to/formats/alembic.md)
# what each format keeps.
