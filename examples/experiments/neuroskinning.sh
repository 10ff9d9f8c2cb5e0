#!/usr/bin/env bash
# NeuroSkinning experiment (Liu et al. 2019, Tables 3, 4, 8) on the shared
# Quaternius characters: predict the artists' skin weights of unseen
# characters with neuroskinning, neuroskinning-nopool, pointnet and fc.
#
#   examples/experiments/neuroskinning.sh [--budget tiny|full] [--minutes M] [--seed S]
#                                         [--out DIR] [--data DIR] [--gat BIN] [--docs-img DIR]
#
# Settings (both one model per method, trained on one super skeleton):
#   humanoids  Quaternius modular men (49 joints) + women (51 joints), one model
#              on the men+women super skeleton, per-character bone masks (like
#              the paper's Game A).
#   mixed      the humanoids + the Quaternius animals and creatures (other
#              skeletons, 25-51 joints) on their super skeleton with bone masks
#              (like the paper's Game B).
# Split (by character, never by pose): every group (men, women, animals,
# creatures) is split on its own by `gat dataset build --seed S --validation 0.1
# --test 0.1` (split_by_character: one validation and one test character per
# group); the humanoids setting uses the men's and women's picks, the mixed
# setting all four groups'. modular_women/Adventurer.glb is skipped: its leg
# weights are NaN (the loader rejects it).
#
# Budgets: full = every model trains until the first epoch ending after
# --minutes (default 6) minutes of wall time (epoch cap 100000), batches of 4
# characters x 512 random vertices (the paper: 12 x 2048; smaller steps give
# more optimiser steps in a short budget), validating every 10th epoch;
# tiny = 1 epoch, batches of 2 x 256 vertices, one training character per
# group, 2 poses (CI). Deterministic given the seed and the number of epochs each model
# reached (printed and recorded; a time budget makes that number depend on the
# machine's speed).
#
# Output (DIR, default build/experiments/neuroskinning): datasets, checkpoints
# (DIR/<setting>/<model>.gcm; the humanoid NeuroSkinning model is
# DIR/humanoids/neuroskinning.gcm), training logs, per-method JSON and error
# maps, DIR/results.json and DIR/report.md. --docs-img DIR also writes
# zlib-compressed per-character montages (one panel per method) there.
# Needs python3 (standard library only) for the split lists and the report.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
budget=full minutes=6 seed=7
out="$root/build/experiments/neuroskinning"
data="${GATCORE_DATA:-$root/../shared/data}"
gat="$root/build/tools/gat"
docs_img=""
models="neuroskinning neuroskinning-nopool pointnet fc"

die() { echo "neuroskinning.sh: $*" >&2; exit 2; }
while [ $# -gt 0 ]; do
  case "$1" in
    --budget) budget="${2:?--budget needs tiny or full}"; shift 2 ;;
    --minutes) minutes="${2:?--minutes needs a value}"; shift 2 ;;
    --seed) seed="${2:?--seed needs a value}"; shift 2 ;;
    --out) out="${2:?--out needs a directory}"; shift 2 ;;
    --data) data="${2:?--data needs a directory}"; shift 2 ;;
    --gat) gat="${2:?--gat needs a path}"; shift 2 ;;
    --docs-img) docs_img="${2:?--docs-img needs a directory}"; shift 2 ;;
    --models) models="${2:?--models needs a list}"; shift 2 ;;
    -h|--help) sed -n '2,40p' "$0"; exit 0 ;;
    *) die "unknown option '$1' (see --help)" ;;
  esac
done
case "$budget" in tiny|full) ;; *) die "--budget expects tiny or full, got '$budget'" ;; esac
[ -x "$gat" ] || die "gat not found at $gat (build it: ninja -C build gat, or pass --gat)"
q="$data/characters/quaternius"
for g in modular_men modular_women animals creatures; do
  [ -d "$q/$g" ] || die "data not found: $q/$g (pass --data or set GATCORE_DATA)"
done
command -v python3 >/dev/null || die "python3 is needed for the split lists and the report"

mkdir -p "$out/splits"
log() { printf '[%s] %s\n' "$(date -u +%H:%M:%S)" "$*"; }
log "budget $budget, seed $seed, data $data, output $out"

# 1. Per-group seeded splits.
for g in modular_men modular_women animals creatures; do
  "$gat" dataset build --skip-bad --seed "$seed" --validation 0.1 --test 0.1 -o "$out/splits/$g.json" "$q/$g" \
    >"$out/splits/$g.log" 2>&1 || { cat "$out/splits/$g.log" >&2; die "dataset build of $g failed"; }
done
# Prints "PART NAME" lines (NAME = <group dir>/<file>) for the groups given.
picks() {
  python3 - "$out/splits" "$budget" "$@" <<'EOF'
import json, os, sys
d, budget, groups = sys.argv[1], sys.argv[2], sys.argv[3:]
for g in groups:
    j = json.load(open(os.path.join(d, g + ".json")))
    name = lambda i: os.path.basename(os.path.dirname(j["characters"][i])) + "/" + os.path.basename(j["characters"][i])
    s = j["split"]
    train = s["train"][:1] if budget == "tiny" else s["train"]
    for part in ("train", "validation", "test"):
        for i in (train if part == "train" else s[part]):
            print(part, name(i))
EOF
}

# 2. Datasets.
build_setting() {  # setting groups...
  local setting="$1"; shift
  local files=() val="" test=""
  while read -r part name; do
    files+=("$q/$name")
    case "$part" in
      validation) val="${val:+$val,}$name" ;;
      test) test="${test:+$test,}$name" ;;
    esac
  done < <(picks "$@")
  mkdir -p "$out/$setting"
  "$gat" dataset build --seed "$seed" -o "$out/$setting/dataset.json" --validation-characters "$val" \
    --test-characters "$test" "${files[@]}" >"$out/$setting/dataset.log" 2>&1 \
    || { cat "$out/$setting/dataset.log" >&2; die "dataset build of $setting failed"; }
  log "$setting: $(tail -n 1 "$out/$setting/dataset.log"); validation $val; test $test"
}
build_setting humanoids modular_men modular_women
build_setting mixed modular_men modular_women animals creatures

# 3. Train and evaluate every model in both settings.
if [ "$budget" = tiny ]; then
  train_opts=(--epochs 1 --batch 2 --sample-vertices 256); eval_opts=(--poses 2 --size 96)
else
  train_opts=(--epochs 100000 --minutes "$minutes" --val-every 10 --batch 4 --sample-vertices 512)
  eval_opts=(--poses 16 --size 256)
fi
for setting in humanoids mixed; do
  for m in $models; do
    dir="$out/$setting"
    t0=$(date +%s)
    "$gat" train --model "$m" --data "$dir/dataset.json" --seed "$seed" "${train_opts[@]}" --out "$dir/$m.gcm" \
      >"$dir/$m.train.log" 2>&1 || { tail -n 20 "$dir/$m.train.log" >&2; die "training $m ($setting) failed"; }
    t1=$(date +%s)
    epochs=$(grep -c '^epoch ' "$dir/$m.train.log" || true)
    rm -rf "$dir/maps/$m"
    "$gat" eval --model "$dir/$m.gcm" --seed "$seed" "${eval_opts[@]}" --json "$dir/$m.json" \
      --errormaps "$dir/maps/$m" >"$dir/$m.eval.log" 2>&1 || { tail -n 20 "$dir/$m.eval.log" >&2; die "evaluating $m ($setting) failed"; }
    t2=$(date +%s)
    printf '{"setting": "%s", "model": "%s", "epochs": %d, "train_seconds": %d, "eval_seconds": %d}\n' \
      "$setting" "$m" "$epochs" $((t1 - t0)) $((t2 - t1)) >"$dir/$m.budget.json"
    log "$setting/$m: $epochs epochs in $((t1 - t0)) s, eval $((t2 - t1)) s: $(grep '^| \*\*overall' "$dir/$m.eval.log")"
  done
done

# 4. Report.
python3 - "$out" "$budget" "$seed" "$minutes" "$docs_img" $models <<'EOF'
import json, os, struct, sys, zlib
out, budget, seed, minutes, docs_img, models = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5], sys.argv[6:]
settings = ["humanoids", "mixed"]
results = {"budget": budget, "seed": seed, "minutes_per_model": float(minutes) if budget == "full" else None,
           "settings": {}}
md = ["# NeuroSkinning experiment report (%s budget, seed %d)" % (budget, seed), ""]
def row(name, c, extra=""):
    return "| %s |%s %.3f | %.3f | %.4f | %.4f | %.5f | %.4f |" % (
        name, extra, c["precision"], c["recall"], c["l1_mean"], c["l1_max"], c["deform_mean"], c["deform_max"])
for s in settings:
    ds = json.load(open(os.path.join(out, s, "dataset.json")))
    names = lambda idx: [os.path.basename(os.path.dirname(ds["characters"][i])) + "/" +
                         os.path.basename(ds["characters"][i]) for i in idx]
    entry = {"train": names(ds["split"]["train"]), "validation": names(ds["split"]["validation"]),
             "test": names(ds["split"]["test"]), "methods": {}}
    for m in models:
        r = json.load(open(os.path.join(out, s, m + ".json")))
        r["budget"] = json.load(open(os.path.join(out, s, m + ".budget.json")))
        entry["methods"][m] = r
    results["settings"][s] = entry
    md += ["## %s" % s, "", "%d training, %d validation, %d test characters." % (
        len(entry["train"]), len(entry["validation"]), len(entry["test"])), "",
        "- train: " + ", ".join(entry["train"]), "- validation: " + ", ".join(entry["validation"]),
        "- test: " + ", ".join(entry["test"]), "", "### Overall (mean over test characters; max: maximum)", "",
        "| method | epochs | train s | precision | recall | L1 mean | L1 max | deform. mean / h | deform. max / h |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for m in models:
        r = entry["methods"][m]
        md.append(row(m, r["overall"], " %d | %d |" % (r["budget"]["epochs"], r["budget"]["train_seconds"])))
    md += ["", "### Per test character", "",
           "| character | method | precision | recall | L1 mean | L1 max | deform. mean / h | deform. max / h |",
           "|---|---|---:|---:|---:|---:|---:|---:|"]
    for c in entry["test"]:
        key = c.rsplit(".", 1)[0]
        for m in models:
            for pc in entry["methods"][m]["characters"]:
                if pc["name"] == key:
                    md.append(row(key + " | " + m, pc))
    md.append("")
md += ["Deformation error: LBS with the predicted weights against LBS with the artists' weights in random poses",
       "(every non-root joint within +-0.5 rad per axis), the two worst poses pooled, divided by the character's",
       "height. Precision / recall: bone selected when the predicted weight > 1e-4 (truth: > 0), over the",
       "character's own bones; L1: per-vertex sum of |predicted - artist| weights (top-k post-processed).", ""]

def read_png(path):
    b = open(path, "rb").read()
    assert b[:8] == b"\x89PNG\r\n\x1a\n", path
    i, idat, w, h = 8, b"", 0, 0
    while i < len(b):
        n, t = struct.unpack(">I4s", b[i:i + 8])
        d = b[i + 8:i + 8 + n]
        if t == b"IHDR":
            w, h = struct.unpack(">II", d[:8])
            assert d[8:10] == b"\x08\x02", path + ": expected 8-bit RGB"
        elif t == b"IDAT":
            idat += d
        i += 12 + n
    raw = zlib.decompress(idat)
    rows = [raw[y * (3 * w + 1):(y + 1) * (3 * w + 1)] for y in range(h)]
    assert all(r[0] == 0 for r in rows), path + ": expected unfiltered rows"
    return w, h, [r[1:] for r in rows]
def write_png(path, w, h, rows):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    raw = b"".join(b"\x02" + bytes(a - p & 255 for a, p in zip(r, prev)) if k else b"\x00" + r
                   for k, (r, prev) in enumerate(zip(rows, [None] + rows)))
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) + \
        chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    tmp = path + ".tmp"
    open(tmp, "wb").write(data)
    os.replace(tmp, path)
if docs_img:
    os.makedirs(docs_img, exist_ok=True)
    md += ["## Error maps", "", "Per-vertex L1 weight error (blue 0 .. red >= 1), panels left to right: " +
           ", ".join(models) + ".", ""]
    for s in settings:
        for c in results["settings"][s]["test"]:
            key = c.rsplit(".", 1)[0]
            panels = [read_png(os.path.join(out, s, "maps", m, key.replace("/", "_") + ".png")) for m in models]
            h = panels[0][1]
            rows = [b"".join(p[2][y] for p in panels) for y in range(h)]
            name = "%s_%s.png" % (s, key.replace("/", "_"))
            write_png(os.path.join(docs_img, name), sum(p[0] for p in panels), h, rows)
            md += ["%s, %s:" % (s, key), "", "![%s %s](%s)" % (s, key, os.path.join(docs_img, name)), ""]
tmp = os.path.join(out, "results.json.tmp")
json.dump(results, open(tmp, "w"), indent=2)
os.replace(tmp, os.path.join(out, "results.json"))
tmp = os.path.join(out, "report.md.tmp")
open(tmp, "w").write("\n".join(md))
os.replace(tmp, os.path.join(out, "report.md"))
print("report: %s, %s" % (os.path.join(out, "report.md"), os.path.join(out, "results.json")))
EOF
log "done"
