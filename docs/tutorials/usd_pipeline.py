"""A USD pipeline: payloads, skin and animation

You are a pipeline TD: grooms travel through your studio as USD, Houdini reads them
with its own attribute names, big grooms must load lazily, and the skin and the
animation must come along. This tutorial writes a groom for the `houdini` target as a
root layer with payloads, looks inside with the USD Python API (`pxr`, from
`usd-core`), and exports a simulated nod as time-sampled USD.
"""

# %%
# ## A groom in payloads
#
# `--layout payloads` writes a small root layer and one payload file per part in
# `OUT.payloads/`, so a stage opens without loading the hair (with `--scheduler`, the
# workers write the parts side by side). `--chunk` is the hairs per part: 3,000 hairs
# in 1,000s here, millions in 131,072s by default.
from pathlib import Path

Path("groom.toml").write_text(
    """
[mesh]
path = "builtin:bust"

[guides]
path = "builtin:long"

[groom]
count = 3000
seed = 11
"""
)

# %%
sh("follicle grow groom.toml -o groom.usda --target houdini --layout payloads --chunk 1000")

# %%
for path in sorted(Path(".").glob("groom.usda*")) + sorted(Path("groom.usda.payloads").iterdir()):
    print(path)

# %%
# ## Inside the stage
#
# Opened without its payloads, the stage is the hierarchy alone; loading them brings in
# the curves. The skin is `/Groom/Skin` (with `--no-skin` left out), the guides
# `/Groom/Guides`, the hair under `/Groom/Hair`, with Houdini's names: `Cd` for colour,
# `skinprim` / `skinprimuv` binding each hair to the skin triangle it grows from.
from pxr import Usd, UsdGeom

stage = Usd.Stage.Open("groom.usda", Usd.Stage.LoadNone)
print("unloaded:", [str(p.GetPath()) for p in stage.Traverse()])
stage.Load()
for prim in stage.Traverse():
    if prim.IsA(UsdGeom.BasisCurves) or prim.IsA(UsdGeom.Mesh):
        names = sorted(
            a.GetName() for a in prim.GetAttributes() if a.GetName().startswith("primvars:")
        )
        print(prim.GetPath(), prim.GetTypeName(), names)
print(
    "up axis",
    UsdGeom.GetStageUpAxis(stage),
    "metres per unit",
    UsdGeom.GetStageMetersPerUnit(stage),
)

# %%
# follicle reads it back whole, payloads and all, and `check` reads it as Houdini will:
sh("follicle check groom.usda --target houdini")

# %%
# ## Animation
#
# A simulated nod (24 frames), exported as the guides' points sampled per frame with
# the skin moving with the head; Houdini deforms the hair from the guides (Guide
# Deform), or follicle renders it ([Dynamics](../how-to/dynamics.md)).
sh("follicle simulate groom.toml --motion nod --frames 24 -o nod.npz")
sh("follicle export nod.npz -o nod.usdc --target houdini")

# %%
stage = Usd.Stage.Open("nod.usdc")
print(
    "frames",
    stage.GetStartTimeCode(),
    "to",
    stage.GetEndTimeCode(),
    "at",
    stage.GetTimeCodesPerSecond(),
    "fps",
)
for prim in stage.Traverse():
    points = prim.GetAttribute("points")
    if points and points.GetNumTimeSamples():
        print(prim.GetPath(), points.GetNumTimeSamples(), "time samples of points")
head = UsdGeom.Xformable(stage.GetPrimAtPath("/Groom/Head"))
print(
    "/Groom/Head", len(head.GetTimeSamples()), "time samples of its transform: the skin rides on it"
)

# %%
# In Houdini: a *Sublayer* or *Reference* LOP (Solaris), or *File › Import › USD* in
# SOPs; a payload layout loads per part. [USD](../how-to/formats/usd.md) describes the
# layout and the attributes, [Targets](../how-to/formats/targets.md) each tool's names,
# and [Beyond one machine](../how-to/beyond-one-machine.md) writing payloads from a
# cluster.
