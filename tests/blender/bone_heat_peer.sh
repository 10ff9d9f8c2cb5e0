#!/bin/sh
# ctest bone_heat_blender_peer: gatcore's bone heat beside Blender's automatic
# weights (auto_weights.py, headless), scored the same way by bone_heat_peer,
# on two procedural characters and, when ../shared/data is there, a few small
# shared ones (the full sweep: scripts/bone_heat_vs_blender.sh). Passes when
# gatcore's mean L1 is within 10 % of Blender's (at most 1.1 x) over the
# procedural characters and over the shared ones; otherwise says by how much.
#   bone_heat_peer.sh BUILD_DIR SOURCE_DIR
set -eu
build=$1 src=$2
if ! command -v blender > /dev/null; then
  echo "SKIPPED: blender not installed (apt-get install blender)"
  exit 0
fi
work=$build/bone_heat_peer_work
rm -rf "$work"
mkdir -p "$work/gat_peer"
"$build/tests/bone_heat_peer" --procedural humanoid 0 "$work/gat_peer/humanoid0.glb"
"$build/tests/bone_heat_peer" --procedural creature 1 "$work/gat_peer/creature1.glb"
data=$src/../shared/data/characters
shared=""
for f in quaternius/modular_women/Casual.glb quaternius/animals/Fox.glb quaternius/creatures/dinosaurs_pack_Trex.glb \
  khronos/CesiumMan.glb; do
  if [ -f "$data/$f" ]; then shared="$shared $data/$f"; else echo "SKIPPED (no shared data): $f"; fi
done
# check GROUP FILE...: runs the peer on each, compares the means.
check() {
  group=$1
  shift
  sh "$src/scripts/bone_heat_vs_blender.sh" "$build" "$work/cache" "$@" | tee "$work/$group.txt"
  if grep -q '^FAILED' "$work/$group.txt"; then echo "FAILED: $group: a peer run failed"; exit 1; fi
  python3 - "$work/cache" "$group" <<'PY'
import glob, json, sys
rows = [json.load(open(p)) for p in glob.glob(sys.argv[1] + "/*.score.json")]
rows = [r for r in rows if (sys.argv[2] == "procedural") == ("gat_peer" in r["character"])]
g = sum(r["gatcore_l1"] for r in rows) / len(rows)
b = sum(r["blender_l1"] for r in rows) / len(rows)
ok = g <= 1.1 * b
print(f"{sys.argv[2]}: {len(rows)} characters, gatcore L1 {g:.4f}, Blender L1 {b:.4f}, ratio {g / b:.3f}"
      f" ({'within' if ok else 'NOT within'} 10 %)")
sys.exit(0 if ok else 1)
PY
}
check procedural "$work/gat_peer/humanoid0.glb" "$work/gat_peer/creature1.glb"
[ -z "$shared" ] || check shared $shared
echo "bone-heat-peer-ok"
