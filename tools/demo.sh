#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# make demo: the main job on the bundled oak tree — bake with every encoding, the memory tables, the ray-tracing bench
# table (every any-hit method on the same rays), and renders (texture, omm4-rank, state-overlay) as PNGs in out/;
# then the same on a real foliage model, data/redeclipse-tree01, and on 6000 procedural leaf cards with a 1024² atlas
# (where micromaps trace faster than the texture test).
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

# A real foliage model (data/redeclipse-tree01, CC-BY-SA): bark and leaves in one 512² atlas, engine cutoff 0.7,
# a camera inside the crown. Micromaps are baked in memory at level 8 into one scene-wide array; bench exits 1 if a
# 4-state method is not pixel-identical to texture or if the view hits no alpha-tested geometry.
TREE=data/redeclipse-tree01/tree01.obj
TREECAM=0,-260,200,30,0,250,0,0,1,60
echo "== somm scene-info $TREE"
"$SOMM" scene-info "$TREE" | sed -n 1,2p
echo "== somm bench $TREE (inside the crown, level $LEVEL, 512x384, 3 interleaved repeats)"
"$SOMM" bench "$TREE" --cutoff 0.7 --level "$LEVEL" --camera "$TREECAM" --width 512 --height 384 --repeat 3
for m in texture omm4-rank; do
  "$SOMM" render "$TREE" --cutoff 0.7 --level "$LEVEL" --camera "$TREECAM" --method "$m" --width 640 --height 480 \
    -o "out/tree01-$m.png" >/dev/null
done
"$SOMM" render "$TREE" --cutoff 0.7 --level "$LEVEL" --camera "$TREECAM" --method state-overlay --width 640 \
  --height 480 -o out/tree01-state-overlay.png >/dev/null
if cmp -s out/tree01-texture.png out/tree01-omm4-rank.png; then
  echo "out/tree01-omm4-rank.png is byte-identical to out/tree01-texture.png"
else
  echo "out/tree01-omm4-rank.png DIFFERS from out/tree01-texture.png" >&2
  exit 1
fi

# Where micromaps win on a CPU: 6000 layered leaf cards over a 1024² leaf atlas (procedural, deterministic). The texture
# test is costly here (a bilinear fetch from a texture that does not stay in cache, ~4 candidate hits per ray), and
# micromaps settle almost every hit without it. bench exits 1 if a 4-state method is not pixel-identical to texture.
echo "== somm gen-scene leaf-cards --cards 6000 --size 1024 -o out/cards.glb"
"$SOMM" gen-scene leaf-cards --cards 6000 --size 1024 -o out/cards.glb
echo "== somm bench out/cards.glb (level 6, 320x240, 3 interleaved repeats)"
"$SOMM" bench out/cards.glb --level 6 --width 320 --height 240 --repeat 3

echo "== somm bake $SCENE -o out/oak.glb: the tree as glTF with its micromaps in EXT_mesh_opacity_micromap"
"$SOMM" bake "$SCENE" -o out/oak.glb --level "$LEVEL"
if command -v python3 > /dev/null; then python3 tests/gltf/validate_micromap_gltf.py --strict out/oak.glb; fi
"$SOMM" render out/oak.glb --method omm4-flat --width 400 --height 400 -o out/oak-glb-omm4-flat.png
"$SOMM" render out/oak.glb --method texture --width 400 --height 400 -o out/oak-glb-texture.png
if cmp -s out/oak-glb-texture.png out/oak-glb-omm4-flat.png; then
  echo "out/oak.glb: its embedded micromaps render byte-identically to the texture test"
else
  echo "out/oak.glb: the embedded micromaps render DIFFERENTLY from the texture test" >&2
  exit 1
fi
