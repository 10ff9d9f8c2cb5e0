#!/bin/sh
# A real client for gat's files: Debian's Blender, headless, imports what
# predict-weights and deform write and checks it numerically
# (check_gat_outputs.py). ctest gat_blender_import runs it in the build
# directory after the gat_character_models fixtures:
#   run.sh GAT NS_MODEL DG_MODEL CHARACTER.glb MOTION.bvh
# Reports itself skipped when Blender is absent (scripts/install_deps.sh
# installs it).
set -eu
gat=$1 ns=$2 dg=$3 character=$4 motion=$5
here=$(cd "$(dirname "$0")" && pwd)
if ! command -v blender > /dev/null; then
  echo "SKIPPED: blender not installed (apt-get install blender)"
  exit 0
fi
rm -f gat_bl_weights.glb gat_bl_deform.glb gat_bl_deform.pc2
"$gat" predict-weights "$ns" "$character" -o gat_bl_weights.glb --quiet
"$gat" deform "$dg" gat_bl_weights.glb "$motion" -o gat_bl_deform.glb --point-cache gat_bl_deform.pc2 \
  --up z --start-frame 1 --frames 0:4 --quiet
blender -b --factory-startup --python-exit-code 1 -P "$here/check_gat_outputs.py" -- \
  gat_bl_weights.glb gat_bl_deform.glb gat_bl_deform.pc2 1 2>&1 | grep -v '^$'
