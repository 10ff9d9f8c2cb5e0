#!/bin/sh
# gatcore's bone heat beside Blender's automatic weights on characters:
#   scripts/bone_heat_vs_blender.sh BUILD_DIR CACHE_DIR [--merge] CHARACTER.glb...
# Blender's weights (tests/blender/auto_weights.py, headless; --merge: the
# glTF importer's Merge Vertices) are cached in CACHE_DIR (keep it out of the
# repository: build/ or /tmp) and reused; gatcore's bone heat is recomputed
# each run (PEER_FLAGS: bone heat settings to try, e.g. --nearest-visible). Prints one line per character and a table per family (the
# character's folder) and overall; writes CACHE_DIR/*.score.json.
set -eu
build=$1 cache=$2
shift 2
merge=""
if [ "${1:-}" = "--merge" ]; then merge=--merge; shift; fi
here=$(cd "$(dirname "$0")/.." && pwd)
command -v blender > /dev/null || { echo "SKIPPED: blender not installed"; exit 0; }
mkdir -p "$cache"
scores=""
for f in "$@"; do
  fam=$(basename "$(dirname "$f")")
  name=$fam.$(basename "$f" .glb)${merge:+.merge}
  if [ ! -s "$cache/$name.json" ]; then
    blender -b --factory-startup --python-exit-code 1 -P "$here/tests/blender/auto_weights.py" -- \
      "$f" "$cache/$name.json" $merge > "$cache/$name.log" 2>&1 || { echo "FAILED: Blender on $f (log: $cache/$name.log)"; continue; }
  fi
  rm -f "$cache/$name.score.json"  # a failed run must not leave an old score in the table
  # shellcheck disable=SC2086  # PEER_FLAGS: bone heat settings to try (bone_heat_peer --help)
  if "$build/tests/bone_heat_peer" "$f" "$cache/$name.json" --json "$cache/$name.score.json" ${PEER_FLAGS:-}; then
    scores="$scores $cache/$name.score.json"
  else
    echo "FAILED: $f"
  fi
done
python3 "$here/scripts/bone_heat_vs_blender_table.py" $scores
