#!/usr/bin/env bash
# Renders the README gallery: corpus surfaces with their corpus boxes.
#   bash examples/gallery.sh [OUTDIR] [SIZE]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/gallery}
size=${2:-480x360}
mkdir -p "$out"
cargo build --release --quiet
lgc=target/release/lgc
python3 - "$out" "$size" <<'PY' | while IFS=$'\t' read -r name expr box; do
import json, sys
corpus = json.load(open("examples/surfaces.json"))
for name in ["sphere", "torus", "tangle_cube", "gyroid", "heart", "barth_sextic",
             "kummer", "goursat", "decocube", "blend", "mitchell", "clebsch"]:
    s = corpus[name]
    print(name, s["expr"], ",".join(str(v) for v in s["box"]), sep="\t")
PY
    "$lgc" render "$expr" --box "$box" -o "$out/$name.png" --size "$size" --samples 4 2>&1 | sed "s/^/$name: /"
done
