#!/bin/sh
# The progress line of every long `gat` command (tools/gat/progress.hpp):
# drawn in place ("\r\033[K what: done/total ...") on stderr when it is a
# terminal, never with --quiet, never into a pipe or a file (logs get only
# the summaries). Run by ctest (gat_progress_tty) in the build directory
# after the character fixtures:
#   progress_tty.sh GAT CHARACTER.glb MOTION.bvh DATASET.json
# A terminal comes from util-linux's `script` (a pseudo-terminal).
set -eu
g=$1 character=$2 motion=$3 data=$4
fail() { echo "FAILED: $*"; exit 1; }
command -v script > /dev/null || fail "script (util-linux) not found: no pseudo-terminal to test with"
esc=$(printf '\033')
cr=$(printf '\r')

# on_tty NAME CMD...: runs CMD on a pseudo-terminal, its output (stdout and
# stderr, as a terminal shows them) in NAME.tty.
on_tty() {
  tty_name=$1
  shift
  script -qec "$*" /dev/null < /dev/null > "$tty_name.tty" 2>&1 ||
    fail "$tty_name on a terminal: exit $? ($(tail -c 400 "$tty_name.tty"))"
}
# expect_line NAME WHAT: NAME.tty holds a progress line "\r\033[K WHAT: ".
expect_line() {
  grep -q "${cr}${esc}\[K$2: " "$1.tty" || fail "$1: no progress line '$2: ...' on the terminal: $(tail -c 400 "$1.tty" | cat -v)"
}
# no_line NAME FILE: FILE has no escape sequence and no carriage return
# but the terminal's own line ends ("\r\n").
no_line() {
  if sed "s/${cr}\$//" "$2" | grep -q "${cr}\|${esc}"; then
    fail "$1: terminal control characters in $2: $(cat -v "$2" | head -c 400)"
  fi
}

# name | command line | the progress line's "what"
while IFS='|' read -r name cmd what; do
  [ -n "$name" ] || continue
  on_tty "$name" "$g $cmd"
  expect_line "$name" "$what"
  on_tty "${name}_quiet" "$g $cmd --quiet"
  no_line "$name --quiet" "${name}_quiet.tty"
  # Not a terminal: stdout and stderr to files, only the summaries.
  $g $cmd > "${name}_pipe.out" 2> "${name}_pipe.err" || fail "$name into files: exit $?"
  no_line "$name into files" "${name}_pipe.out"
  no_line "$name into files" "${name}_pipe.err"
  [ -s "${name}_pipe.out" ] || fail "$name into files: no summary"
done <<EOF
pt_dataset|dataset build -o gat_pt_ds.json procedural:humanoid:0 procedural:humanoid:1 --random-poses 1 --subsample 200 --dm-iterations 2 --validation 0.5|checking characters
pt_eval|eval --model gat_cm_dg.gcm --samples 1|predicting
pt_deform|deform gat_cm_dg.gcm $character $motion --point-cache gat_pt.pc2 --frames 0:24|deforming
pt_weights|predict-weights gat_cm_ns.gcm $character -o gat_pt_weights.glb|predict-weights $character
pt_heat|predict-weights --method bone-heat $character -o gat_pt_heat.glb|predict-weights $character
pt_distill|distill gat_cm_dg.gcm --epochs 1 --samples 1 --out gat_pt_student.gcm|distilling
pt_baseline|eval --baseline bone-heat --data $data --part test --poses 1|evaluating test characters
EOF
# Rate and time left where the steps are alike (24 frames take long enough
# to be redrawn with a rate).
grep -q "deforming: [0-9]*/24 frames ([0-9]*%)  .* frames/s  ETA " pt_deform.tty ||
  fail "deform: no rate / ETA: $(tail -c 400 pt_deform.tty | cat -v)"
# Training draws its own line (epoch, batch, loss, ETA).
on_tty pt_train "$g train --epochs 1 --samples 4 --batch 1 --out gat_pt_train.gcm"
grep -q "${cr}epoch 1/1  batch [0-9]*/[0-9]*  loss .* ETA " pt_train.tty || fail "train: no progress line: $(cat -v pt_train.tty | head -c 400)"
on_tty pt_train_quiet "$g train --epochs 1 --samples 4 --batch 1 --out gat_pt_train.gcm --quiet"
no_line "train --quiet" pt_train_quiet.tty
echo progress-ok
