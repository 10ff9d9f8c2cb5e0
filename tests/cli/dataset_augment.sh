#!/bin/sh
# gat dataset build --augment: the variants are written into the dataset,
# named augment:KINDS:SEED:SOURCE (only the kinds asked for), each in its
# source's split part; the same --augment-seed gives the same file and the
# same realised characters (bone heat's evaluation of them is identical),
# another seed other variants; a bad --augment list is refused naming the
# item, and no file is written. Run by ctest (gat_dataset_augment) in the
# build directory: dataset_augment.sh GAT.
set -eu
g=$1
fail() { echo "FAILED: $*"; exit 1; }
src="procedural:humanoid:0 procedural:humanoid:1 procedural:creature:2 procedural:humanoid:3"
rm -f aug_a.json aug_b.json aug_c.json aug_bad.json

# shellcheck disable=SC2086
$g dataset build -q --seed 4 -o aug_a.json --augment rigid,rename,z-up --augment-copies 2 --augment-seed 5 $src > build.txt
grep -q '12 characters (train 6, validation 3, test 3)' build.txt || fail "4 characters x (1 + 2 variants): $(cat build.txt)"
# shellcheck disable=SC2086
$g dataset build -q --seed 4 -o aug_b.json --augment rigid,rename,z-up --augment-copies 2 --augment-seed 5 $src > /dev/null
cmp -s aug_a.json aug_b.json || fail "the same --augment-seed wrote different datasets"
# shellcheck disable=SC2086
$g dataset build -q --seed 4 -o aug_c.json --augment rigid,rename,z-up --augment-copies 2 --augment-seed 6 $src > /dev/null
cmp -s aug_a.json aug_c.json && fail "another --augment-seed wrote the same variants"

# Names and parts, from gat info's character list (part, name).
$g info aug_a.json > info.txt
grep -E '^  (train|validation|test) ' info.txt > parts.txt
[ "$(grep -c ' augment:' parts.txt)" = 8 ] || fail "expected 8 variants: $(cat parts.txt)"
for s in $src; do
  part=$(awk -v s="$s" '$2 == s { print $1 }' parts.txt)
  [ -n "$part" ] || fail "$s is not in the dataset"
  n=$(awk -v s="$s" -v p="$part" 'index($2, "augment:") == 1 && substr($2, length($2) - length(s) + 1) == s && $1 == p' parts.txt | wc -l)
  [ "$n" = 2 ] || fail "$s ($part): $n of its 2 variants in its part: $(cat parts.txt)"
done
grep ' augment:' parts.txt | awk '{ print $2 }' | while read -r name; do
  kinds=$(echo "$name" | cut -d: -f2)
  seed=$(echo "$name" | cut -d: -f3)
  echo "$seed" | grep -qE '^[0-9]+$' || fail "$name: no seed"
  echo "$kinds" | tr '+' '\n' | while read -r k; do
    case "$k" in rigid | rename | z-up) ;; *) fail "$name: kind '$k' was not asked for" ;; esac
  done
done

# The variants are realised the same from the same file: bone heat on the test part of both.
$g eval --baseline bone-heat --data aug_a.json --poses 1 --seed 3 --json eval_a.json > eval_a.txt
$g eval --baseline bone-heat --data aug_b.json --poses 1 --seed 3 --json eval_b.json > /dev/null
[ "$(grep -cE '^\| procedural:humanoid:1~aug[0-9]+ ' eval_a.txt)" = 2 ] || fail "expected 2 test variants: $(cat eval_a.txt)"
cmp -s eval_a.json eval_b.json || fail "the same dataset realised different variants"

# Bad lists: one line naming the item, non-zero exit, no file.
check_bad() {
  want=$1
  shift
  rc=0
  # shellcheck disable=SC2086
  $g dataset build -q -o aug_bad.json "$@" $src > out.txt 2> err.txt || rc=$?
  [ "$rc" != 0 ] || fail "--augment $*: accepted"
  grep -qF -- "$want" err.txt || fail "--augment $*: expected '$want', got: $(cat err.txt)"
  [ ! -e aug_bad.json ] || fail "--augment $*: a dataset was written"
}
check_bad "--augment: unknown augmentation 'bogus' (known: rigid, decimate" --augment rigid,bogus
check_bad "--augment: empty augmentation name in 'rigid,,z-up'" --augment rigid,,z-up
check_bad "--augment: augmentation 'rigid' is given twice" --augment rigid,rigid
check_bad "--augment-copies" --augment-copies 2
echo augment-ok
