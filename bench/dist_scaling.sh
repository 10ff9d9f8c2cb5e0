#!/bin/sh
# Data-parallel scaling of `gat train`: steps per second at 1, 2
# and 4 MPI ranks on this machine, one OpenMP thread per rank, the same
# global batch at every N. On a 2-core machine 4 ranks are oversubscribed, so
# beyond 2 this measures the overhead of the split (collectives, waiting for
# a descheduled rank), not a speed-up. Prints a Markdown table for
# bench/RESULTS.md ("Data-parallel training over MPI").
#   sh bench/dist_scaling.sh [GAT] [MODEL] [SAMPLE_VERTICES]
# default: build/tools/gat, neuroskinning at its paper batch (12) and 2048 vertices per sample.
set -eu
gat=${1:-build/tools/gat}
model=${2:-neuroskinning}
verts=${3:-2048}
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# 48 tube characters, batch 12: 4 steps per epoch; epoch 1 warms up, epoch 2 is timed (no validation;
# epoch 3 validates). The bytes include the epoch's start, where rank 0 sends the model and the Adam
# moments (3 x the gradient volume) to every rank.
args="--model $model --samples 48 --batch 12 --sample-vertices $verts --epochs 3 --val-every 1000 --seed 1"
echo "| ranks | threads / rank | steps/s | s / step | MB sent / step / rank | s in collectives / step |"
echo "|---:|---:|---:|---:|---:|---:|"
for n in 1 2 4; do
  if [ "$n" = 1 ]; then
    "$gat" train $args --out "$tmp/m.gcm" > "$tmp/log"
  else  # (Open MPI's options; another MPI's launcher takes its own)
    mpirun --oversubscribe --bind-to none -np "$n" "$gat" train $args --out "$tmp/m.gcm" > "$tmp/log"
  fi
  awk -v n="$n" '
    /^epoch 2\// { for (i = 1; i <= NF; ++i) if ($i ~ /^\(/) { s = substr($i, 2) + 0 } }
    /rank 0: / && ++k == 2 { mb = $5; coll = $10 }
    END { steps = 4; printf "| %d | 1 | %.3f | %.2f | %s | %s |\n", n, steps / s, s / steps, (n > 1 ? mb : "0"),
          (n > 1 ? sprintf("%.2f", coll / steps) : "0") }' "$tmp/log"
done
