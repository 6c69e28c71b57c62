#!/usr/bin/env bash
# Renders every scene and formula file in examples/ into the gallery of docs/scenes.md.
#   bash examples/render_examples.sh [OUTDIR] [SIZE] [SAMPLES]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/gallery/scenes}
size=${2:-480x360}
samples=${3:-4}
mkdir -p "$out"
cargo build --release --quiet
for file in examples/*.lgc; do
    name=$(basename "$file" .lgc)
    target/release/lgc render "$file" -o "$out/$name.png" --size "$size" --samples "$samples" 2>&1 | sed "s/^/$name: /"
done
