#!/usr/bin/env bash
# The README's first command: installs missing Debian packages, builds the
# `gat` tool (Release, Ninja, into build/) and runs the real pipeline on the
# embedded procedural characters (no downloads):
#   1. a dataset of procedural humanoids and creatures (gat dataset build),
#   2. a skin-weight model (NeuroSkinning) and a corrective model (DenseGATs),
#      each trained for a short time budget (gat train --minutes),
#   3. the skin weights of an unseen procedural character (gat predict-weights),
#   4. that character, with its predicted weights, deformed by a procedural
#      motion with the learned corrections (gat deform): a glTF file with the
#      animation and Blender-ready point caches,
#   5. pictures: the weight error of the unseen character (gat eval --errormaps)
#      and where plain skinning departs from the reference deformer (gat errormap),
# and prints where the files are. About 2 minutes on 2 cores after the build,
# almost all of it the two --minutes budgets (125 s measured on a 2-vCPU VM at
# load average 3.5; README).
# Usage: bash scripts/demo.sh [--out DIR] [--minutes M (per model, default 1)]
# (`gat demo` is the kernels' smoke test: build/tools/gat demo.)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="build"
out="demo-out"
minutes=1
while (($#)); do
  case "$1" in
    --out) out="${2:?--out needs a directory}"; shift 2 ;;
    --minutes) minutes="${2:?--minutes needs a number}"; shift 2 ;;
    *) echo "demo.sh: unknown option '$1' (--out DIR, --minutes M)" >&2; exit 2 ;;
  esac
done

bash scripts/install_deps.sh
if [[ -f "$build/CMakeCache.txt" ]] && ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' "$build/CMakeCache.txt"; then
  echo "demo.sh: $build/ was configured with another generator; removing it" >&2
  rm -rf "$build"
fi
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build "$build" -j2 --target gat
gat="$root/$build/tools/gat"
mkdir -p "$out"
cd "$out"
t0=$(date +%s)
step() { echo; echo "== $*"; }

step "1. dataset: 8 procedural characters for training, 1 for validation, the unseen one for testing"
chars=()
for s in 0 1 2 3 4 5; do chars+=("procedural:humanoid:$s"); done
chars+=(procedural:creature:6 procedural:creature:7 procedural:humanoid:8 procedural:humanoid:42)
"$gat" dataset build -o dataset.json "${chars[@]}" --random-poses 6 --subsample 800 --seed 1 \
  --validation-characters procedural:humanoid:8 --test-characters procedural:humanoid:42 --quiet

step "2. training: a skin-weight model and a corrective model, $minutes minutes each"
"$gat" train --model neuroskinning --data dataset.json --minutes "$minutes" --epochs 1000 --out skin_weights.gcm
"$gat" train --model densegats --data dataset.json --minutes "$minutes" --epochs 1000 --samples 4 --out corrective.gcm

step "3. skin weights of the unseen character procedural:humanoid:42"
"$gat" dataset export-character procedural:humanoid:42 -o character.glb
"$gat" predict-weights skin_weights.gcm character.glb -o character_weights.glb

step "4. a procedural motion on it, with the learned corrections"
"$gat" dataset export-motion procedural:swing -o swing.bvh
"$gat" deform corrective.gcm character_weights.glb swing.bvh -o character_deformed.glb \
  --point-cache character_deformed.pc2 --up z --start-frame 1

step "5. pictures"
"$gat" eval --model skin_weights.gcm --data dataset.json --poses 4 --errormaps img | tail -n 4
"$gat" errormap character_weights.glb -o img/lbs_vs_delta_mush.png --motion swing.bvh --frame 12

echo
echo "demo finished in $(( $(date +%s) - t0 )) s (after the build). Files in $(pwd):"
echo "  character_weights.glb     the unseen character with predicted skin weights (open in Blender / any glTF viewer)"
echo "  character_deformed.glb    + the swing motion, LBS + learned correction, as morph targets (animation 'deform')"
echo "  character_deformed.pc2    the same as a point cache, Z-up, from frame 1 (Blender: Mesh Cache modifier, docs/getting-started.md)"
echo "  img/*.png                 weight error of the unseen character; LBS vs the reference deformer"
echo "  skin_weights.loss.png, corrective.loss.png   loss curves"
echo "  skin_weights.gcm, corrective.gcm             the models (safetensors checkpoints)"
