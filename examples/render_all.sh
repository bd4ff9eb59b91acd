#!/usr/bin/env bash
# Render every example scene to docs/examples/<name>.png (640 × 640) and print the time
# each took. Run from anywhere: paths are relative to the repository root.
#
#   examples/render_all.sh                  # all scenes
#   examples/render_all.sh wavy curly       # some of them
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
follicle="${FOLLICLE:-$root/.venv/bin/follicle}"
[ -x "$follicle" ] || follicle=follicle
mkdir -p "$root/docs/examples"
if [ ! -f "$root/examples/assets/torus.obj" ] || [ ! -f "$root/examples/assets/hand_groomed.npz" ]; then
    "$root/.venv/bin/python" "$root/examples/make_assets.py"
fi
names=("$@")
if [ ${#names[@]} -eq 0 ]; then
    names=(long_straight wavy curly short_fur parting blond_multistrand hand_groomed)
fi
for name in "${names[@]}"; do
    TIMEFORMAT="$(printf '%-18s' "$name") %1R s"
    time "$follicle" render "$root/examples/$name.toml" \
        -o "$root/docs/examples/$name.png" --size 640 640 >/dev/null
done
