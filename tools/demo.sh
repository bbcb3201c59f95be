#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# make demo: the main job on the bundled oak tree — bake with every encoding, the memory tables, the ray-tracing bench
# table (every any-hit method on the same rays), and renders (texture, omm4-rank, state-overlay) as PNGs in out/.
set -euo pipefail
SOMM=${1:-build/tools/somm/somm}
cd "$(dirname "$0")/.."
mkdir -p out
SCENE=data/oak-tree/oaktree.gltf
LEVEL=8
# A close view of the crown (rays cross several alpha-tested leaf cards); the whole tree for the pictures.
CROWN=0.8,3.3,2.2,0.1,3.2,0.15,0,1,0,60
OMM=(--omm out/oak.somm)

echo "== somm index --level 2: (u, v) -> bird-curve index"
printf '0.5 0.25\n0.25 0.5\n' | "$SOMM" index --level 2 | tr '\n' ' '
echo

echo "== somm bake $SCENE --level $LEVEL --encoding all"
"$SOMM" bake "$SCENE" -o out/oak.somm --level "$LEVEL" --encoding all
echo "== somm info out/oak.somm (memory per encoding)"
"$SOMM" info out/oak.somm
echo "== somm compare $SCENE --levels 4,6,8: memory table (bytes and ratio to flat)"
"$SOMM" compare "$SCENE" --levels 4,6,8 --formats 2,4

echo "== somm bench $SCENE (crown close-up, 512x384, 3 interleaved repeats)"
"$SOMM" bench "$SCENE" "${OMM[@]}" --camera "$CROWN" --width 512 --height 384 --repeat 3

for m in texture omm4-rank state-overlay; do
  "$SOMM" render "$SCENE" "${OMM[@]}" --method "$m" --width 800 --height 800 --spp 4 -o "out/oak-$m.png"
done
"$SOMM" render "$SCENE" "${OMM[@]}" --method state-overlay --camera "$CROWN" --width 800 --height 600 --spp 4 \
  -o out/oak-state-overlay-crown.png
if cmp -s out/oak-texture.png out/oak-omm4-rank.png; then
  echo "out/oak-omm4-rank.png is byte-identical to out/oak-texture.png (4-state micromaps are exact)"
else
  echo "out/oak-omm4-rank.png DIFFERS from out/oak-texture.png" >&2
  exit 1
fi
