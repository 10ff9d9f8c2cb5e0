#!/bin/sh
# A real client for gat's files: Debian's Blender, headless, imports what
# predict-weights and deform write and checks it numerically
# (check_gat_outputs.py), then makes a two-object character with Blender's
# own exporter (make_multi_mesh.py) and checks its per-object point caches
# and shape keys (check_multi_mesh.py). ctest gat_blender_import runs it in the build
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
# bl SCRIPT ARGS...: Blender headless on one of the check scripts; its
# output, without Blender's blank lines; its exit status (a pipe into grep
# would hide a failed check).
bl() {
  script=$1
  shift
  rc=0
  blender -b --factory-startup --python-exit-code 1 -P "$here/$script" -- "$@" > "gat_bl_$script.log" 2>&1 || rc=$?
  grep -v '^$' "gat_bl_$script.log" || true
  [ "$rc" = 0 ] || { echo "FAILED: $script (exit $rc)"; exit 1; }
}
rm -f gat_bl_weights.glb gat_bl_deform.glb gat_bl_deform.pc2 gat_bl_multi.glb gat_bl_multi_deform.glb gat_bl_multi_*.pc2
"$gat" predict-weights "$ns" "$character" -o gat_bl_weights.glb --quiet
"$gat" deform "$dg" gat_bl_weights.glb "$motion" -o gat_bl_deform.glb --point-cache gat_bl_deform.pc2 \
  --up z --start-frame 1 --frames 0:4 --quiet
bl check_gat_outputs.py gat_bl_weights.glb gat_bl_deform.glb gat_bl_deform.pc2 1

# A multi-mesh character: one point cache per object, each taken by Blender.
bl make_multi_mesh.py gat_bl_weights.glb gat_bl_multi.glb
"$gat" deform "$dg" gat_bl_multi.glb "$motion" -o gat_bl_multi_deform.glb --point-cache gat_bl_multi.pc2 \
  --up z --start-frame 1 --frames 0:4 --quiet
bl check_multi_mesh.py gat_bl_multi.glb gat_bl_multi_deform.glb gat_bl_multi 1 Lower Upper
