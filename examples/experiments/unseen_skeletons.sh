#!/usr/bin/env bash
# Skin weights on skeletons a model never saw: leave-one-family-out
# on the shared characters, every method on each fold's test characters in one
# table (bone precision / recall at 1e-4, L1 mean / max, dominant-bone
# accuracy, deformation error at the two worst of --poses random poses).
#
#   examples/experiments/unseen_skeletons.sh [--folds "women creatures khronos"] [--minutes M]
#       [--sampling consecutive|random|full] [--pair-scorer W,...] [--world-columns ignore|use]
#       [--precision fp32|bf16] [--lr-schedule step|cosine|plateau] [--average-decay D] [--classifier-dropout P] [--loss kl|l1]
#       [--seed S] [--heat-blend S] [--augment KINDS [--augment-copies N]]
#       [--corpus use|ignore|auto] [--validation-family FAM] [--evaluate-only] [--out DIR] [--data DIR] [--gat BIN]
#
# Folds (test family; every other family trains, one character of each
# training family validates):
#   women      train Quaternius modular men + animals + creatures, test the modular women
#   men        train the modular women + animals + creatures, test the modular men
#   creatures  train the modular men + women + animals, test the creatures
#   khronos    train every Quaternius character, test the Khronos sample rigs
#   animated_humans  (corpus) train every shared Quaternius family (and, with
#              --corpus use, the other corpus families), test the corpus's
#              humanoids on rigs unlike the shared ones: the 12 Animated Men/Women
#              outfits (one 31-joint rig), Cowboy, Alien and three.js RobotExpressive
# With --corpus use (auto: when data/characters/corpus exists) every fold also
# trains on the corpus families other than its test family: fish (40 + 3 FBX),
# farm_animals (FBX farm animals and pets), animated_humans, monsters (space
# enemies, monster and fruit characters) and creature_packs (the corpus's
# cyberpunk and platformer characters, the shared creatures' packs: never in
# the creatures fold, neither trained on nor tested, so its test set is the
# 11 shared creatures with or without the corpus). Khronos only ever tests.
#   humanoids  the same-skeleton check (not an unseen skeleton): the NeuroSkinning
#              experiment's humanoid split (train the modular men + women, validate
#              men/Casual and women/Casual, test men/Farmer and women/Punk), where the
#              paper's neuroskinning (super-skeleton outputs) is also trained, with the
#              same budget and --keep-best, to show what the skeleton-agnostic model
#              gives up on a skeleton the paper's model knows (with random vertex
#              sampling, its better setting: in 12 minutes, validation KL 0.095 against
#              0.80 with consecutive windows, whose max pool sees part of a character)
# Methods: bone-heat (Baran & Popovic 2007; no training) and skinweights-any
# (trained on the fold's training characters for --minutes of wall time, epochs
# of 4 characters x 512 consecutive vertices (--sampling; full: whole meshes),
# validated every epoch). The test characters see the epoch of the lowest
# validation L1 of the top-4 weights (gat train --keep-best, whose default
# for skin-weight models is --keep-best-by l1), not of the lowest validation
# loss: the training loss (over each vertex's candidate bones, before the top-4 cut)
# stops tracking the weights' L1 late in training (docs/experiments/skin-weights.md,
# "Which checkpoint to evaluate"). The chosen checkpoint is also evaluated on
# the validation characters by gat eval, and both figures are logged.
# skinweights-any starts as bone heat over each vertex's 8 nearest bones (its
# logits' prior) and learns corrections to it; --pair-scorer W scores every
# (vertex, candidate) with one shared MLP of hidden width W (gat train
# --pair-scorer). --world-columns use lets skinweights-any read the vertex's
# world-frame position and normal (gat train --world-columns; the default,
# ignore, gives it only quantities measured from the character's own bones).
# After training, gat calibrate chooses the best checkpoint's post-processing
# (a heat blend and a min weight) on the fold's validation characters; the
# method skinweights-any is the calibrated checkpoint, skinweights-any-raw the
# model's own top-4 weights.
# --validation-family FAM validates on every character of FAM (a family the
# fold would train on) and trains on none of them, instead of one character
# of each training family: the kept epoch and the calibration are then
# chosen on a family the model never saw, as the test family is.
# --heat-blend S also evaluates the uncalibrated checkpoint with its weights
# mixed with bone heat's, (1 - S) * model + S * bone heat per vertex (gat eval
# --heat-blend), as the method skinweights-any+heat in the tables.
# --evaluate-only re-runs only the evaluation of folds already trained in
# --out (bone heat, calibration, the three rows).
# --augment KINDS adds --augment-copies (default 2) augmented variants of
# every *training* character (gat dataset build --augment KINDS, seeded by
# --seed; docs/experiments/augmentations.md): the variants of the validation
# and test characters are dropped, so no variant of a test family is ever
# trained on and the validation and test sets are the unaugmented ones of the
# run without --augment.
# --lr-schedule trains skinweights-any with that learning-rate schedule (gat
# train --lr-schedule; cosine anneals from the initial rate over the fold's
# --minutes); without it, the model's default.
# --classifier-dropout P trains skinweights-any with dropout P after each of
# its classifier's hidden layers (gat train --classifier-dropout; 0: none);
# without it, the model's default (0.5).
# --loss trains skinweights-any with that skin-weight loss (gat train --loss
# kl|l1); without it, the model's default.
# --average-decay D trains skinweights-any with a moving average of its
# weights (gat train --average-decay): validation, --keep-best and the
# evaluated model use the average.
# --precision bf16 trains both models with bf16 products
# (gat train --precision; fp32 where the CPU lacks AVX512_BF16, as gat train
# says). The super-skeleton models
# (neuroskinning, fc) cannot name the bones of an unseen family's skeleton, so
# they are not run here (see neuroskinning.sh for them on shared skeletons).
# modular_women/Adventurer.glb is skipped: its leg weights are NaN.
# Output: DIR (default build/experiments/unseen_skeletons): datasets,
# checkpoints, logs, per-method JSON and DIR/report.md (every method per
# character, then the check per test character: skinweights-any's
# L1 below bone heat's, its dominant bone >= 85 %, and the counts). Needs python3.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
folds="women creatures khronos" minutes=8 seed=7 poses=16 sampling=consecutive pair_scorer= world_columns= precision=fp32
heat_blend= validation_family= augment= augment_copies=2 corpus=auto evaluate_only=0 lr_schedule= average_decay= classifier_dropout= loss=
out="$root/build/experiments/unseen_skeletons"
data="${GATCORE_DATA:-$root/../shared/data}"
gat="$root/build/tools/gat"
die() { echo "unseen_skeletons.sh: $*" >&2; exit 2; }
while [ $# -gt 0 ]; do
  case "$1" in
    --folds) folds="${2:?--folds needs a list}"; shift 2 ;;
    --minutes) minutes="${2:?--minutes needs a value}"; shift 2 ;;
    --seed) seed="${2:?--seed needs a value}"; shift 2 ;;
    --poses) poses="${2:?--poses needs a value}"; shift 2 ;;
    --sampling) sampling="${2:?--sampling needs a value}"; shift 2 ;;
    --pair-scorer) pair_scorer="${2:?--pair-scorer needs widths}"; shift 2 ;;
    --world-columns) world_columns="${2:?--world-columns needs ignore or use}"; shift 2 ;;
    --precision) precision="${2:?--precision needs fp32 or bf16}"; shift 2 ;;
    --lr-schedule) lr_schedule="${2:?--lr-schedule needs step, cosine or plateau}"; shift 2 ;;
    --average-decay) average_decay="${2:?--average-decay needs a decay in [0, 1)}"; shift 2 ;;
    --classifier-dropout) classifier_dropout="${2:?--classifier-dropout needs a probability}"; shift 2 ;;
    --loss) loss="${2:?--loss needs kl or l1}"; shift 2 ;;
    --heat-blend) heat_blend="${2:?--heat-blend needs a share in (0, 1]}"; shift 2 ;;
    --evaluate-only) evaluate_only=1; shift ;;
    --validation-family) validation_family="${2:?--validation-family needs a family}"; shift 2 ;;
    --corpus) corpus="${2:?--corpus needs use, ignore or auto}"; shift 2 ;;
    --augment) augment="${2:?--augment needs a list of kinds}"; shift 2 ;;
    --augment-copies) augment_copies="${2:?--augment-copies needs a count}"; shift 2 ;;
    --out) out="${2:?--out needs a directory}"; shift 2 ;;
    --data) data="${2:?--data needs a directory}"; shift 2 ;;
    --gat) gat="${2:?--gat needs a path}"; shift 2 ;;
    -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1' "$0"; exit 0 ;;
    *) die "unknown option $1" ;;
  esac
done
[ -x "$gat" ] || die "gat not found at $gat (build it: ninja -C build gat, or pass --gat)"
q="$data/characters/quaternius" k="$data/characters/khronos"
c="$data/characters/corpus"
for d in "$q/modular_men" "$q/modular_women" "$q/animals" "$q/creatures" "$k"; do
  [ -d "$d" ] || die "data not found: $d (pass --data or set GATCORE_DATA)"
done
case "$corpus" in
  use) [ -d "$c" ] || die "--corpus use: the corpus is not at $c" ;;
  ignore) ;;
  auto) if [ -d "$c" ]; then corpus=use; else corpus=ignore; fi ;;
  *) die "--corpus takes use, ignore or auto, not $corpus" ;;
esac
command -v python3 >/dev/null || die "python3 is needed for the report"
log() { printf '[%s] %s\n' "$(date -u +%H:%M:%S)" "$*"; }

# check_validation DIR NAME: evaluates NAME.best.gcm on the fold's
# validation characters with gat eval and logs that L1 beside the one the
# trainer measured (the trainer's is over each vertex's candidate bones, the
# eval's over the character's joints: they differ where the artist's weights
# lie outside the candidates).
check_validation() {
  local d="$1" m="$2" stem l1
  stem="$d/$m.best.validation"
  "$gat" eval --model "$d/$m.best.gcm" --part validation --poses 1 --seed "$seed" --json "$stem.json" >"$stem.log" 2>&1 \
    || { cat "$stem.log" >&2; die "validation eval of $d/$m.best.gcm failed"; }
  l1="$(python3 -c 'import json,sys; print("%.4f" % json.load(open(sys.argv[1]))["overall"]["l1_mean"])' "$stem.json")"
  log "$(basename "$d"): $m $(grep '^best validation' "$d/$m.train.log" | tail -n 1); gat eval on the validation characters: L1 $l1"
}

# calibrate_and_evaluate DIR FOLD: the best checkpoint's post-processing
# (heat blend, min weight) chosen on the fold's validation characters by gat
# calibrate (DIR/skinweights-any.calibrated.gcm), then the test characters
# evaluated with it (method skinweights-any) and without it (the model's own
# top-4 weights: skinweights-any-raw).
calibrate_and_evaluate() {
  local d="$1" f="$2"
  "$gat" calibrate "$d/skinweights-any.best.gcm" -o "$d/skinweights-any.calibrated.gcm" -q >"$d/calibrate.log" 2>&1 \
    || { cat "$d/calibrate.log" >&2; die "calibration on $f failed"; }
  log "$f: $(grep '^chosen' "$d/calibrate.log")"
  "$gat" eval --model "$d/skinweights-any.calibrated.gcm" --poses "$poses" --seed "$seed" --confusions 8 \
    --json "$d/skinweights-any.json" >"$d/skinweights-any.log" 2>&1 || { cat "$d/skinweights-any.log" >&2; die "eval on $f failed"; }
  "$gat" eval --model "$d/skinweights-any.best.gcm" --poses "$poses" --seed "$seed" --confusions 8 \
    --json "$d/skinweights-any-raw.json" >"$d/skinweights-any-raw.log" 2>&1 \
    || { cat "$d/skinweights-any-raw.log" >&2; die "eval without calibration on $f failed"; }
}

# evaluate_fold DIR FOLD: bone heat on the test characters, the trained model
# calibrated and not, and (--heat-blend) its fixed mix with bone heat.
evaluate_fold() {
  local d="$1" f="$2"
  "$gat" eval --baseline bone-heat --data "$d/dataset.json" --poses "$poses" --seed "$seed" --confusions 8 \
    --json "$d/bone-heat.json" >"$d/bone-heat.log" 2>&1 || { cat "$d/bone-heat.log" >&2; die "bone heat on $f failed"; }
  calibrate_and_evaluate "$d" "$f"
  if [ -n "$heat_blend" ]; then
    "$gat" eval --model "$d/skinweights-any.best.gcm" --heat-blend "$heat_blend" --min-weight 0 --poses "$poses" \
      --seed "$seed" --json "$d/skinweights-any+heat.json" >"$d/skinweights-any+heat.log" 2>&1 \
      || { cat "$d/skinweights-any+heat.log" >&2; die "eval with --heat-blend on $f failed"; }
  fi
  log "$f: evaluated"
}

# family_files FAMILY: the family's files. A corpus family is one source's
# characters (a pack, or packs of one kind and author): its members never
# straddle training and test. creature_packs are the corpus characters of the
# packs the shared creatures come from (cyberpunk, platformer): they never
# train the creatures fold, and are not in its test set either, so that the
# creatures' figures stay comparable with runs without the corpus.
family_files() {
  case "$1" in
    khronos) ls "$k"/*.glb ;;
    modular_men | modular_women | animals | creatures) ls "$q/$1"/*.glb ;;
    creature_packs) ls "$c"/quaternius/cyberpunk_pack_*.glb "$c"/quaternius/platformer_game_pack_*.glb ;;
    fish) ls "$c"/quaternius/cute_fish_pack_*.glb "$c"/quaternius/fish_pack_*.glb \
      "$c"/quaternius_fbx/Animal_Pack_Vol.2_Piranha.fbx "$c"/quaternius_fbx/Animals_Pack_Fish.fbx \
      "$c"/quaternius_fbx/Animals_Pack_Whale.fbx ;;
    farm_animals) ls "$c"/quaternius_fbx/Farm_Animals_*.fbx "$c"/quaternius_fbx/Animal_Pack_Vol.2_Dog.fbx \
      "$c"/quaternius_fbx/Animals_Pack_Chick.fbx "$c"/quaternius_fbx/Animals_Pack_Red_Fox.fbx ;;
    animated_humans) ls "$c"/quaternius_fbx/Animated_Men_*.fbx "$c"/quaternius_fbx/Animated_Women_*.fbx \
      "$c"/quaternius_fbx/Cowboy_Pack_Cowboy.fbx "$c"/quaternius_fbx/Alien_Animated_Alien.fbx "$c"/threejs/RobotExpressive.glb ;;
    monsters) ls "$c"/quaternius/ultimate_space_pack_*.glb "$c"/quaternius_fbx/Monster_Pack_*.fbx \
      "$c"/quaternius_fbx/Fruit_Characters_*.fbx ;;
    *) die "unknown family $1" ;;
  esac
}
corpus_families() { [ "$corpus" = use ] && echo "fish farm_animals animated_humans monsters creature_packs" || true; }
# without FAMILY...: the corpus families minus the ones named
corpus_without() {
  local f x keep
  for f in $(corpus_families); do
    keep=1
    for x in "$@"; do [ "$f" = "$x" ] && keep=0; done
    [ $keep = 1 ] && echo "$f"
  done
}
train_families() {
  case "$1" in
    women) echo "modular_men animals creatures $(corpus_without)" ;;
    men) echo "modular_women animals creatures $(corpus_without)" ;;
    creatures) echo "modular_men modular_women animals $(corpus_without creature_packs)" ;;
    khronos) echo "modular_men modular_women animals creatures $(corpus_without)" ;;
    animated_humans) echo "modular_men modular_women animals creatures $(corpus_without animated_humans)" ;;
    humanoids) echo "modular_men modular_women" ;;
    *) die "unknown fold $1 (women, men, creatures, khronos, animated_humans, humanoids)" ;;
  esac
}
test_family() {
  case "$1" in
    women) echo modular_women ;;
    men) echo modular_men ;;
    humanoids) echo "" ;;
    animated_humans) [ -d "$c" ] || die "the animated_humans fold tests corpus characters: $c is missing"
      echo animated_humans ;;
    *) echo "$1" ;;
  esac
}

# Every fold's --validation-family is checked before any fold trains.
if [ -n "$validation_family" ]; then
  for fold in $folds; do
    case " $(echo $(train_families "$fold")) " in
      *" $validation_family "*) ;;
      *) die "--validation-family $validation_family is not one of the $fold fold's training families: $(echo $(train_families "$fold"))" ;;
    esac
  done
fi

for fold in $folds; do
  dir="$out/$fold"
  if [ "$evaluate_only" = 1 ]; then
    for x in dataset.json skinweights-any.best.gcm; do
      [ -f "$dir/$x" ] || die "--evaluate-only: $dir/$x is missing (run the fold first)"
    done
    evaluate_fold "$dir" "$fold"
    continue
  fi
  mkdir -p "$dir"
  files=() val="" test=""
  for fam in $(train_families "$fold") $(test_family "$fold"); do
    first=1
    for f in $(family_files "$fam"); do
      "$gat" info "$f" >/dev/null 2>&1 || { log "skipping $f (does not load)"; continue; }
      files+=("$f")
      name="$(basename "$(dirname "$f")")/$(basename "$f")"
      if [ "$fold" = humanoids ]; then
        case "$name" in
          modular_men/Farmer.glb | modular_women/Punk.glb) test="${test:+$test,}$name" ;;
          modular_men/Casual.glb | modular_women/Casual.glb) val="${val:+$val,}$name" ;;
        esac
      elif [ "$fam" = "$(test_family "$fold")" ]; then test="${test:+$test,}$name"
      elif [ -n "$validation_family" ]; then
        [ "$fam" = "$validation_family" ] && val="${val:+$val,}$name"
      elif [ $first = 1 ]; then val="${val:+$val,}$name"; first=0; fi
    done
  done
  "$gat" dataset build --seed "$seed" -o "$dir/dataset.json" --validation-characters "$val" \
    --test-characters "$test" ${augment:+--augment "$augment" --augment-copies "$augment_copies" --augment-seed "$seed"} \
    "${files[@]}" >"$dir/dataset.log" 2>&1 || { cat "$dir/dataset.log" >&2; die "dataset build of $fold failed"; }
  if [ -n "$augment" ]; then  # keep the training characters' variants only
    python3 - "$dir/dataset.json" <<'PY' || die "dropping the held-out variants of $fold failed"
import json, os, sys
path = sys.argv[1]
d = json.load(open(path))
chars, split = d["characters"], d["split"]
train = set(split["train"])
keep = [i for i, c in enumerate(chars) if not c.startswith("augment:") or i in train]
new = {old: k for k, old in enumerate(keep)}
d["characters"] = [chars[i] for i in keep]
d["split"] = {part: [new[i] for i in idx if i in new] for part, idx in split.items()}
tmp = path + ".tmp"
json.dump(d, open(tmp, "w"), indent=1)
os.replace(tmp, path)
print(f"{path}: kept {len(keep)} of {len(chars)} characters (variants of training characters only)")
PY
  fi
  log "$fold: $(tail -n 1 "$dir/dataset.log")"
  "$gat" train --model skinweights-any --data "$dir/dataset.json" --seed "$seed" --epochs 100000 --minutes "$minutes" \
    --val-every 1 --batch 4 --sample-vertices 512 --sampling "$sampling" ${pair_scorer:+--pair-scorer "$pair_scorer"} \
    ${world_columns:+--world-columns "$world_columns"} \
    --precision "$precision" ${lr_schedule:+--lr-schedule "$lr_schedule"} \
    ${average_decay:+--average-decay "$average_decay"} ${classifier_dropout:+--classifier-dropout "$classifier_dropout"} \
    ${loss:+--loss "$loss"} --out "$dir/skinweights-any.gcm" \
    --keep-best "$dir/skinweights-any.best.gcm" >"$dir/skinweights-any.train.log" 2>&1 \
    || { cat "$dir/skinweights-any.train.log" >&2; die "training on $fold failed"; }
  log "$fold: $(tail -n 1 "$dir/skinweights-any.train.log")"
  check_validation "$dir" skinweights-any
  log "$fold: skinweights-any $(grep -c '^epoch' "$dir/skinweights-any.train.log") epochs"
  evaluate_fold "$dir" "$fold"
  if [ "$fold" = humanoids ]; then  # the paper's model, on the skeleton it was trained on
    "$gat" train --model neuroskinning --data "$dir/dataset.json" --seed "$seed" --epochs 100000 --minutes "$minutes" \
      --val-every 1 --batch 4 --sample-vertices 512 --sampling random --precision "$precision" --out "$dir/neuroskinning.gcm" \
      --keep-best "$dir/neuroskinning.best.gcm" >"$dir/neuroskinning.train.log" 2>&1 \
      || { cat "$dir/neuroskinning.train.log" >&2; die "neuroskinning training on $fold failed"; }
    check_validation "$dir" neuroskinning
    "$gat" eval --model "$dir/neuroskinning.best.gcm" --poses "$poses" --seed "$seed" --json "$dir/neuroskinning.json" \
      >"$dir/neuroskinning.log" 2>&1 || { cat "$dir/neuroskinning.log" >&2; die "neuroskinning eval on $fold failed"; }
    log "$fold: neuroskinning $(grep -c '^epoch' "$dir/neuroskinning.train.log") epochs"
  fi
done

python3 - "$out" $folds >"$out/report.md" <<'PY'
import json, os, sys
out, folds = sys.argv[1], sys.argv[2:]
print("| fold | character | method | precision | recall | L1 mean | L1 max | dominant bone | deform. mean / h | deform. max / h |")
print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|")
for fold in folds:
    for m in ("bone-heat", "skinweights-any", "skinweights-any-raw", "skinweights-any+heat", "neuroskinning"):
        p = os.path.join(out, fold, m + ".json")
        if not os.path.exists(p):
            continue
        j = json.load(open(p))
        for c in j["characters"] + [dict(j["overall"], name="**overall**")]:
            print(f"| {fold} | {c['name']} | {m} | {c['precision']:.3f} | {c['recall']:.3f} | {c['l1_mean']:.4f} | "
                  f"{c['l1_max']:.4f} | {c['dominant']:.3f} | {c['deform_mean']:.5f} | {c['deform_max']:.4f} |")
# The bar per test character: the model's L1 below bone heat's, its
# dominant bone at least 85 % (for skinweights-any, and with --heat-blend for
# the mix too).
for m in ("skinweights-any", "skinweights-any-raw", "skinweights-any+heat"):
    rows, below, high, total = [], 0, 0, 0
    for fold in folds:
        paths = [os.path.join(out, fold, x + ".json") for x in ("bone-heat", m)]
        if not all(os.path.exists(p) for p in paths):
            continue
        heat, model = ({c["name"]: c for c in json.load(open(p))["characters"]} for p in paths)
        for name, c in model.items():
            if name not in heat:
                continue
            h = heat[name]
            lower, enough = c["l1_mean"] < h["l1_mean"], c["dominant"] >= 0.85
            below, high, total = below + lower, high + enough, total + 1
            rows.append(f"| {fold} | {name} | {h['l1_mean']:.4f} / {h['dominant']:.3f} | {c['l1_mean']:.4f} / "
                        f"{c['dominant']:.3f} | {'yes' if lower else '**no**'} | {'yes' if enough else '**no**'} |")
    if not total:
        continue
    print()
    print(f"| fold | character | bone heat L1 / dominant | {m} L1 / dominant | L1 below bone heat | dominant >= 0.85 |")
    print("|---|---|---:|---:|---|---|")
    print("\n".join(rows))
    print(f"\n{m}: L1 below bone heat on {below} of {total} test characters, dominant bone >= 85 % on {high} of {total}.")
PY
log "report: $out/report.md"
