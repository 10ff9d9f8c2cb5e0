#!/usr/bin/env bash
# Distillation experiment: a paper-size DenseGATs teacher, an
# Ori.GAT student distilled from it (gat distill), and the same Ori.GAT
# trained directly on the Delta Mush targets with the student's budget, all
# with the linear skip (the student's fitted to the teacher: within 1 % of
# the teacher in docs/RESULTS.md, 22.5 % worse without it), evaluated with
# LBS / DQS / the linear probe on the test characters of the DenseGATs
# dataset (densegats.sh's settings: 15 Quaternius humanoids, seed split,
# distortion columns 1,4,16, L1 loss) on the CMU walk and jump.
#
# usage: examples/experiments/distill.sh [--out DIR]
#   DS_TEACHER_MINUTES (default 14), DS_STUDENT_MINUTES (default 8), DS_STRIDE (8),
#   DS_TEACHER=<existing teacher .gcm trained on DIR/dataset.json> skips training it.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
gat="${GAT:-$root/build/tools/gat}"
data="${GATCORE_DATA:-$root/../shared/data}"
out="$root/build/experiments/distill"
[ "${1:-}" = --out ] && out="$2"
: "${DS_TEACHER_MINUTES:=14}" "${DS_STUDENT_MINUTES:=8}" "${DS_STRIDE:=8}" "${DS_THREADS:=2}"
men="$data/characters/quaternius/modular_men"
women="$data/characters/quaternius/modular_women"
if [ ! -d "$men" ] || [ ! -d "$women" ] || [ ! -f "$data/motion/cmu/walk.bvh" ]; then
  echo "SKIPPED: data not found ($data)"
  exit 0
fi
mkdir -p "$out"
export OMP_WAIT_POLICY=passive
echo "== dataset"
"$gat" dataset build --skip-bad -o "$out/dataset.json" "$men" "$women" --joint-limits humanoid --random-poses 16 \
  --subsample 1000 --seed 0 --validation 0.14 --test 0.14 --distortion-scales 1,4,16 > "$out/dataset.log" 2>&1
teacher="${DS_TEACHER:-$out/teacher.gcm}"
if [ -z "${DS_TEACHER:-}" ]; then
  echo "== teacher: densegats, L1, $DS_TEACHER_MINUTES min"
  "$gat" train --model densegats --loss l1 --linear-skip --data "$out/dataset.json" --minutes "$DS_TEACHER_MINUTES" --epochs 100000 \
    --threads "$DS_THREADS" --out "$teacher" > "$out/train_teacher.log" 2>&1
  tail -n 2 "$out/train_teacher.log"
fi
echo "== student: origat distilled from the teacher, $DS_STUDENT_MINUTES min"
"$gat" distill "$teacher" --model origat --linear-skip --data "$out/dataset.json" --minutes "$DS_STUDENT_MINUTES" --epochs 100000 \
  --threads "$DS_THREADS" --out "$out/student.gcm" > "$out/distill.log" 2>&1
tail -n 2 "$out/distill.log"
echo "== origat trained directly, L1, $DS_STUDENT_MINUTES min"
"$gat" train --model origat --loss l1 --linear-skip --data "$out/dataset.json" --minutes "$DS_STUDENT_MINUTES" --epochs 100000 \
  --threads "$DS_THREADS" --out "$out/origat.gcm" > "$out/train_origat.log" 2>&1
tail -n 2 "$out/train_origat.log"
for motion in walk jump; do
  stride=$DS_STRIDE
  [ "$motion" = jump ] && stride=$((2 * DS_STRIDE))  # 2752 frames against the walk's 344
  echo "== evaluate (test characters, CMU $motion, every ${stride}th frame)"
  "$gat" eval --data "$out/dataset.json" --motion "$data/motion/cmu/$motion.bvh" --stride "$stride" \
    --model "densegats-teacher=$teacher" --model "origat-distilled=$out/student.gcm" --model "origat-direct=$out/origat.gcm" \
    --linear-probe --markdown "$out/eval_$motion.md" --json "$out/eval_$motion.json" | tee "$out/eval_$motion.log"
done
