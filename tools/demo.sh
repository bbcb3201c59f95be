#!/usr/bin/env bash
# make demo: the main job on the bundled oak tree — bake, the memory table, the ray-tracing bench table (every any-hit
# method on the same rays), and renders (texture, omm4-rank, state-overlay) as PNGs in out/.
set -euo pipefail
SOMM=${1:-build/tools/somm/somm}
cd "$(dirname "$0")/.."
mkdir -p out
SCENE=data/oak-tree/oaktree.gltf
LEVEL=8
# A close view of the crown (rays cross several alpha-tested leaf cards), and the whole tree for the pictures.
CROWN=0.8,3.3,2.2,0.1,3.2,0.15,0,1,0,60
HELP=$("$SOMM" --help)
has() { grep -q "^  $1 " <<<"$HELP"; }

echo "== somm index --level 2: (u, v) -> bird-curve index"
printf '0.5 0.25\n0.25 0.5\n' | "$SOMM" index --level 2 | tr '\n' ' '
echo

OMM=()
if has bake; then
  ENC=()
  if grep -q -- --encoding <<<"$("$SOMM" bake --help)"; then ENC=(--encoding all); fi
  echo "== somm bake $SCENE --level $LEVEL ${ENC[*]}"
  "$SOMM" bake "$SCENE" -o out/oak.somm --level "$LEVEL" "${ENC[@]}"
  OMM=(--omm out/oak.somm)
  echo "== somm info out/oak.somm (memory per encoding)"
  "$SOMM" info out/oak.somm
fi
if has compare; then
  echo "== somm compare $SCENE --levels 4,6,8: memory table (bytes and ratio to flat)"
  "$SOMM" compare "$SCENE" --levels 4,6,8 --formats 2,4
fi

echo "== somm bench $SCENE (crown close-up, 512x384, 3 interleaved repeats)"
"$SOMM" bench "$SCENE" "${OMM[@]}" --level "$LEVEL" --camera "$CROWN" --width 512 --height 384 --repeat 3

RANK=omm4-rank
"$SOMM" render "$SCENE" "${OMM[@]}" --level "$LEVEL" --method "$RANK" --width 8 --height 8 -o out/probe.png >/dev/null 2>&1 ||
  RANK=omm4-flat
rm -f out/probe.png
for m in texture "$RANK" state-overlay; do
  "$SOMM" render "$SCENE" "${OMM[@]}" --level "$LEVEL" --method "$m" --width 800 --height 800 --spp 4 -o "out/oak-$m.png" \
    | head -1
done
"$SOMM" render "$SCENE" "${OMM[@]}" --level "$LEVEL" --method state-overlay --camera "$CROWN" --width 800 --height 600 \
  --spp 4 -o out/oak-state-overlay-crown.png | head -1
if cmp -s out/oak-texture.png "out/oak-$RANK.png"; then
  echo "out/oak-$RANK.png is identical to out/oak-texture.png (4-state micromaps are exact)"
else
  echo "out/oak-$RANK.png DIFFERS from out/oak-texture.png" >&2
  exit 1
fi
