#!/bin/sh
# Every shared reproducer through the gat CLI: a non-zero exit within the
# time limit and one line naming the file (no crash, hang, or bare
# standard-library message such as "stof" / "std::bad_alloc").
# Then the files our own fuzzers found (FOUND_DIR, tests/fuzz/found).
# Usage: cli_bad_inputs.sh GAT REPRO_DIR FOUND_DIR
gat="$1"
repro="$2"
found="$3"
fail=0
# Outputs the refused commands must not write: in a folder of this run's own
# (a fixed /tmp name kept a file an earlier run or another build wrote).
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

check() {  # check NAME_IN_MESSAGE COMMAND...
  name="$1"
  shift
  out=$(timeout 60 "$@" 2>&1)
  rc=$?
  lines=$(printf '%s\n' "$out" | grep -c .)
  if [ "$rc" -eq 0 ] || [ "$rc" -ge 124 ] || [ "$lines" -ne 1 ] || ! printf '%s' "$out" | grep -qF -- "$name"; then
    echo "FAIL (exit $rc, $lines lines): $*"
    printf '%s\n' "$out" | head -n 5
    fail=1
  else
    echo "ok: $out"
  fi
}
for f in "$repro"/*.bvh "$repro"/*.gcm "$repro"/*.pc2 "$repro"/*.json "$repro"/*/dataset.json; do
  check "$(basename "$f")" "$gat" info "$f"
done
for f in "$found"/*.glb; do
  check "$(basename "$f")" "$gat" info "$f"
  check "$(basename "$f")" "$gat" predict-weights --method bone-heat "$f" -o "$work/weights.glb"
done
for f in "$found"/*.gcm; do
  check "$(basename "$f")" "$gat" info "$f"
  check "$(basename "$f")" "$gat" eval --model "$f" --samples 1
done
# Training on datasets gat dataset build would refuse: refused before any work
# (motion_stride 0 used to loop until the OOM killer).
for d in cli_motion_stride_0 cli_dataset_out_of_range; do
  check "dataset.json" "$gat" train --data "$repro/$d/dataset.json" --epochs 1 --out "$work/out.gcm"
done
check "random_poses" "$gat" train --data "$repro/cli_dataset_random_poses_2e9.json" --epochs 1 --out "$work/out.gcm"
# Checkpoints whose header was edited (format version 1: the header was not covered).
check "cli_checkpoint_lr_nan.gcm" "$gat" train --resume "$repro/cli_checkpoint_lr_nan.gcm" --epochs 2 --out "$work/out.gcm"
check "cli_checkpoint_target_scale_abc.gcm" "$gat" eval --model "$repro/cli_checkpoint_target_scale_abc.gcm" --samples 1
check "--samples" "$gat" eval --model "$repro/cli_checkpoint_lr_nan.gcm" --samples 2000000000
[ -z "$(ls -A "$work")" ] || { echo "FAIL: an output file was written: $(ls "$work")"; fail=1; }

exit $fail
