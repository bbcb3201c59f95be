#!/usr/bin/env bash
# make demo: the main job on the bundled sample input.
set -euo pipefail
SOMM=${1:-build/tools/somm/somm}
cd "$(dirname "$0")/.."
echo "== somm index --level 2 (hand-checked points)"
printf '0.5 0.25\n0.25 0.5\n0.7 0.7\n0x1p-2 0x1p-1\n' | "$SOMM" index --level 2
echo "== somm microtri --level 2"
printf '0\n11\n15\n' | "$SOMM" microtri --level 2
