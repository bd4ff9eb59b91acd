"""A sweep of grooms on a Dask cluster

You are a researcher who needs many grooms — a dataset for learning, or a study of
how one parameter changes the look — each with its files, its picture and a record of
what made it. `follicle batch` makes every combination of the values you sweep and the
seeds you ask for, on a Dask cluster, with a manifest of parameters, files and SHA-256s.
This tutorial sweeps 8 small grooms on a local cluster of 2 worker processes; the same
command takes a scheduler's address for a real cluster, and `--vary` more values for
1,000 grooms.
"""

# %%
# ## The base scene
#
# Curly hair on the built-in bust, 1,000 hairs each (pictures at 160²).
from pathlib import Path

Path("curls.toml").write_text(
    """
[mesh]
path = "builtin:bust"

[guides]
path = "builtin:curly"

[groom]
count = 1000
root_color = [0.03, 0.015, 0.008]
tip_color = [0.09, 0.05, 0.025]

[render]
size = [160, 160]
"""
)

# %%
# ## The sweep
#
# Four curl radii from 2 mm to 8 mm (`START:STOP:N`, ends included) × two seeds, one
# Dask task per groom on `local:2` (two worker processes here; or `tcp://host:8786`),
# each groom's hair as `.npz`, and the manifest as Parquet (typed columns; it needs
# `pyarrow`). The files are the same, byte for byte, as one process makes.
sh(
    "follicle batch curls.toml -o sweep --vary groom.curl_radius=0.002:0.008:4 --seeds 0:2 --curves .npz --manifest parquet --scheduler local:2"
)

# %%
# ## The manifest
#
# One row a groom: its folder, the swept values, the seed, each file and its SHA-256.
import pyarrow.parquet as pq

table = pq.read_table("sweep/manifest.parquet")
print(table.schema)
for row in table.to_pylist():
    print({k: v for k, v in row.items() if not k.endswith("sha256")})

# %%
# ## A contact sheet
#
# Each groom's `hair.png`, in the manifest's order: curl radius across, seed down.
from PIL import Image

rows = table.to_pylist()
sheet = Image.new("RGB", (4 * 160, 2 * 160))
for index, row in enumerate(rows):
    picture = Image.open(Path("sweep") / row["image"]).convert("RGB")
    sheet.paste(picture, ((index // 2) * 160, (index % 2) * 160))
sheet.save("sweep.png")

# %%
# ![8 grooms: curl radius 2 to 8 mm across, seeds 0 and 1 down](sweep.png)
#
# Run the same command again after a stop and it keeps the grooms already made. The
# hair files load with `follicle.load_curves`; for training data, each groom's arrays
# are in its `.npz`. [Beyond one machine](../how-to/beyond-one-machine.md) covers
# clusters, sharding one big groom, and frames of a simulation on many workers;
# [Sizing a cluster](../scale.md) the memory and time per worker.
