#!/usr/bin/env bash
# The DenseGATs experiment (the paper's Tables 2-3, Fig. 8-10) on the
# shared Quaternius humanoids: builds the dataset, trains densegats, its two
# ablations, Ori.GAT and the NeuroSkinning network as a displacement
# regressor on random poses within the built-in humanoid joint limits,
# evaluates every model and plain LBS / DQS against the reference deformer
# (Delta Mush on LBS) on the test characters over retargeted CMU motions,
# renders error colour maps and loss curves, and writes report.md + report.json.
# Deterministic given the seed (training is bit-reproducible per seed and
# thread count; the time budget only decides how many epochs run).
#
# usage: examples/experiments/densegats.sh [--budget ci|full] [--out DIR] [--seed S]
#   environment overrides (defaults per budget below):
#     DG_MINUTES   training minutes per model (0: --epochs only)   DG_EPOCHS   epoch cap per model
#     DG_MINUTES_<model>  (e.g. DG_MINUTES_densegats=40, '-' for '_'): that model's own budget
#     DG_LONG_MINUTES  > 0: afterwards each of DG_LONG_MODELS (default: the DenseGATs runs) is resumed for
#                  that many more minutes into <label>-long.gcm and evaluated too (the equal-budget
#                  comparison stays intact); DG_LONG_EPOCHS caps the extra epochs
#     A DG_MODELS label ending in -l1 (densegats-l1) trains that model with gat train --loss l1;
#     ending in -skip (densegats-l1-skip, densegats-skip) also with gat train --linear-skip.
#     DG_DISTORTION  gat dataset build --distortion-scales (default 1,4,16; 'none': the paper's features only)
#     DG_POSES     random poses per training character per epoch   DG_SUBSAMPLE vertices per sample
#     DG_STRIDE    evaluate every k-th motion frame                DG_MOTIONS  test BVHs (space separated;
#                  default: CMU walk, and at the full budget CMU jump too)
#     DG_MODELS    models to train                                 DG_THREADS  OpenMP threads
#     DG_NICE      niceness of training / evaluation               GAT         the gat binary
#     GATCORE_DATA the shared data (default: ../shared/data beside the repository)
# Outputs (DIR, default build/experiments/densegats-<budget>): dataset.json, <model>.gcm
# (the humanoid DenseGATs model: densegats.gcm), train_<model>.log, report.md,
# report.json, img/*.png.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
budget=full out="" seed=0
while [ $# -gt 0 ]; do
  case "$1" in
    --budget) budget="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    -h|--help) sed -n '2,25p' "$0"; exit 0 ;;
    *) echo "densegats.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
case "$budget" in
  ci)   : "${DG_MINUTES:=0}" "${DG_EPOCHS:=1}" "${DG_POSES:=1}" "${DG_SUBSAMPLE:=200}" "${DG_STRIDE:=172}"
        : "${DG_MAPFRAMES:=1}" "${DG_LONG_MINUTES:=0}" ;;
  full) : "${DG_MINUTES:=8}" "${DG_EPOCHS:=100000}" "${DG_POSES:=16}" "${DG_SUBSAMPLE:=1000}" "${DG_STRIDE:=8}"
        : "${DG_MAPFRAMES:=2}" "${DG_LONG_MINUTES:=6}" ;;
  *) echo "densegats.sh: --budget expects ci or full, got '$budget'" >&2; exit 2 ;;
esac
data="${GATCORE_DATA:-$root/../shared/data}"
out="${out:-$root/build/experiments/densegats-$budget}"
gat="${GAT:-$root/build/tools/gat}"
: "${DG_MODELS:=densegats densegats-l1 densegats-l1-skip densegats-noself densegats-nodense origat neuroskinning}"
if [ -z "${DG_MOTIONS:-}" ]; then  # full budget: the jump too, when the data has it
  DG_MOTIONS="$data/motion/cmu/walk.bvh"
  if [ "$budget" = full ] && [ -f "$data/motion/cmu/jump.bvh" ]; then DG_MOTIONS+=" $data/motion/cmu/jump.bvh"; fi
fi
: "${DG_DISTORTION:=1,4,16}"
: "${DG_THREADS:=2}" "${DG_NICE:=10}"
men="$data/characters/quaternius/modular_men"
women="$data/characters/quaternius/modular_women"
if [ ! -d "$men" ] || [ ! -d "$women" ]; then
  echo "SKIPPED: data not found ($men, $women)"
  exit 0
fi
[ -x "$gat" ] || { echo "densegats.sh: $gat not built (ninja -C build gat)" >&2; exit 1; }
mkdir -p "$out/img"
run() { nice -n "$DG_NICE" "$@"; }
export OMP_WAIT_POLICY=passive
t_start=$(date +%s)

# 1. Dataset: 15 Quaternius humanoids (modular_women/Adventurer.glb has NaN leg
# weights and is skipped), split by character with the seed: 11 train / 2
# validation / 2 test. Training poses: random within the humanoid joint limits
# (no motions in the dataset: the test motions are never seen in training).
# DenseGATs inputs: the paper's features plus the detail-distortion columns at
# DG_DISTORTION's smoothing scales (docs/RESULTS.md explains why).
echo "== dataset (seed $seed)"
run "$gat" dataset build --skip-bad -o "$out/dataset.json" "$men" "$women" \
  --joint-limits humanoid --random-poses "$DG_POSES" --subsample "$DG_SUBSAMPLE" \
  --seed "$seed" --validation 0.14 --test 0.14 --distortion-scales "$DG_DISTORTION" 2>&1 | tee "$out/dataset.log"

# 2. Training, one model after the other, each with the same budget. A label
# ending in -l1 trains that model with the L1 loss (gat train --loss l1)
# instead of the paper's MSE.
train_args=(--data "$out/dataset.json" --seed "$seed" --threads "$DG_THREADS" --epochs "$DG_EPOCHS")
declare -A wall minutes
for m in $DG_MODELS; do
  own="DG_MINUTES_${m//-/_}"
  minutes[$m]="${!own:-$DG_MINUTES}"
  echo "== train $m (${minutes[$m]} min)"
  model="${m%-skip}"
  extra=()
  [ "$model" != "$m" ] && extra+=(--linear-skip)
  base="$model"
  model="${model%-l1}"
  [ "$model" != "$base" ] && extra+=(--loss l1)
  [ "${minutes[$m]}" != 0 ] && extra+=(--minutes "${minutes[$m]}")
  [ "$model" = neuroskinning ] && extra+=(--task displacement)
  t0=$(date +%s)
  rm -f "$out/$m.gcm"
  run "$gat" train --model "$model" "${extra[@]}" "${train_args[@]}" --out "$out/$m.gcm" > "$out/train_$m.log" 2>&1 \
    || { cat "$out/train_$m.log" >&2; exit 1; }
  wall[$m]=$(( $(date +%s) - t0 ))
  tail -n 2 "$out/train_$m.log"
done

# 2b. Longer runs (DG_LONG_MODELS, default densegats and densegats-l1): the equal-budget
# models resumed for DG_LONG_MINUTES more (deterministic), as <label>-long.
if [ -z "${DG_LONG_MODELS+x}" ]; then  # default: the DenseGATs runs among DG_MODELS
  DG_LONG_MODELS=""
  for m in densegats densegats-l1 densegats-l1-skip; do [[ " $DG_MODELS " == *" $m "* ]] && DG_LONG_MODELS+=" $m"; done
fi
models_eval="$DG_MODELS"
if [ "$DG_LONG_MINUTES" != 0 ]; then
  for m in $DG_LONG_MODELS; do
    [[ " $DG_MODELS " == *" $m "* ]] || { echo "densegats.sh: DG_LONG_MODELS: $m is not in DG_MODELS" >&2; exit 2; }
    echo "== train $m-long (+$DG_LONG_MINUTES min)"
    cp "$out/$m.gcm" "$out/$m-long.gcm"
    t0=$(date +%s)
    run "$gat" train --resume "$out/$m-long.gcm" --minutes "$DG_LONG_MINUTES" --epochs "$(( DG_EPOCHS + ${DG_LONG_EPOCHS:-100000} ))" \
      --threads "$DG_THREADS" --out "$out/$m-long.gcm" > "$out/train_$m-long.log" 2>&1 \
      || { cat "$out/train_$m-long.log" >&2; exit 1; }
    wall[$m-long]=$(( $(date +%s) - t0 ))
    minutes[$m-long]="${minutes[$m]}+$DG_LONG_MINUTES"
    tail -n 2 "$out/train_$m-long.log"
    models_eval="$models_eval $m-long"
  done
fi

# 3. Evaluation of every model and LBS / DQS on the test characters, every
# DG_STRIDE-th frame of the test motions; error maps of DG_MAPFRAMES frames.
echo "== evaluate"
# The linear probe (the least-squares map of the same input columns) is a row of its own.
eval_args=(--data "$out/dataset.json" --stride "$DG_STRIDE" --json "$out/report.json" --markdown "$out/eval.md"
           --errormaps "$out/img" --errormap-frames "$DG_MAPFRAMES" --errormap-size 256 --linear-probe)
for mo in $DG_MOTIONS; do eval_args+=(--motion "$mo"); done
for m in $models_eval; do eval_args+=(--model "$m=$out/$m.gcm" --loss-curve "$m=$out/train_$m.log"); done
t0=$(date +%s)
run "$gat" eval "${eval_args[@]}" | tee "$out/eval.log"
eval_wall=$(( $(date +%s) - t0 ))

# 4. The report.
{
  echo "# DenseGATs experiment ($budget budget, seed $seed)"
  echo
  echo "- dataset: $out/dataset.json ($(grep -o '[0-9]* characters (train [0-9]*, validation [0-9]*, test [0-9]*)' "$out/dataset.log"))"
  echo "- DenseGATs inputs: the paper's features + detail distortion at scales ${DG_DISTORTION}"
  echo "- training: ${DG_POSES} random poses per character per epoch, ${DG_SUBSAMPLE}-vertex windows, budget ${DG_MINUTES} min / ${DG_EPOCHS} epochs per model (unless listed below), ${DG_THREADS} threads, nice ${DG_NICE}"
  echo "- test motions: $DG_MOTIONS, every ${DG_STRIDE}th frame"
  echo "- machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load average at the end $(cut -d' ' -f1-3 /proc/loadavg)"
  echo
  echo "| model | budget (min) | epochs | last train loss | last val loss | wall (s) |"
  echo "|---|---:|---:|---:|---:|---:|"
  for m in $models_eval; do
    last=$(grep '^epoch ' "$out/train_$m.log" | tail -n 1)
    ep=$(echo "$last" | sed -n 's/^epoch \([0-9]*\)\/.*/\1/p')
    tl=$(echo "$last" | sed -n 's/.*train loss \([0-9.e+-]*\).*/\1/p')
    vl=$(echo "$last" | sed -n 's/.*val loss \([0-9.e+-]*\).*/\1/p')
    echo "| $m | ${minutes[$m]} | $ep | $tl | $vl | ${wall[$m]} |"
  done
  echo
  echo "Evaluation wall time: ${eval_wall} s; total: $(( $(date +%s) - t_start )) s."
  echo
  cat "$out/eval.md"
} > "$out/report.md.tmp"
mv "$out/report.md.tmp" "$out/report.md"
echo "== report: $out/report.md  (models: $out/*.gcm)"
