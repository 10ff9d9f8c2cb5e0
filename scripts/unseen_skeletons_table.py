"""Tables of leave-one-family-out runs (examples/experiments/unseen_skeletons.sh).

    python3 scripts/unseen_skeletons_table.py LABEL=OUT_DIR [LABEL=OUT_DIR ...]

Each OUT_DIR is one run's --out (one seed, one setting). Prints, per fold:
every method's mean L1 (and its ratio to bone heat's), dominant-bone
accuracy, precision / recall, deformation error and the test characters
below bone heat's L1; the calibration each run chose; the boundaries; and
the per-character L1 / dominant bone.
"""
import json
import os
import re
import sys

FOLDS = ["women", "men", "creatures", "khronos", "animated_humans"]
METHODS = [("bone-heat", "bone heat"), ("skinweights-any", "skinweights-any, calibrated"),
           ("skinweights-any-raw", "skinweights-any, own top 4"), ("skinweights-any+heat", "mix 0.3, uncalibrated")]

runs = []
for arg in sys.argv[1:]:
    label, _, path = arg.partition("=")
    if not path:
        sys.exit("usage: unseen_skeletons_table.py LABEL=OUT_DIR ...")
    runs.append((label, path))


def load(run, fold, method):
    p = os.path.join(run, fold, method + ".json")
    return json.load(open(p)) if os.path.exists(p) else None


def chosen(run, fold):
    p = os.path.join(run, fold, "calibrate.log")
    if not os.path.exists(p):
        return ""
    for line in open(p):
        m = re.match(r"chosen: heat blend ([0-9.]+), min weight ([0-9.]+)", line)
        if m:
            return f"blend {m.group(1)}, min {m.group(2)}"
    return ""


def epochs(run, fold):
    p = os.path.join(run, fold, "skinweights-any.train.log")
    if not os.path.exists(p):
        return ""
    n = sum(1 for line in open(p) if line.startswith("epoch "))
    best = [line for line in open(p) if line.startswith("best validation")]
    m = re.search(r"at epoch (\d+)", best[-1]) if best else None
    return f"{m.group(1)} of {n}" if m else str(n)


print("| fold (test characters) | run | method | L1 | × bone heat | dominant | precision | recall "
      "| deform. mean / h | deform. max / h | below bone heat |")
print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
for fold in FOLDS:
    for i, (label, run) in enumerate(runs):
        heat = load(run, fold, "bone-heat")
        if not heat:
            continue
        hc = {c["name"]: c["l1_mean"] for c in heat["characters"]}
        for key, name in METHODS:
            j = load(run, fold, key)
            if not j or (key == "bone-heat" and i > 0):
                continue
            o = j["overall"]
            below = "" if key == "bone-heat" else "%d/%d" % (
                sum(c["l1_mean"] < hc[c["name"]] for c in j["characters"]), len(j["characters"]))
            what = name + (f" ({chosen(run, fold)})" if key == "skinweights-any" and chosen(run, fold) else "")
            print(f"| {fold} ({len(j['characters'])}) | {'' if key == 'bone-heat' else label} | {what} "
                  f"| {o['l1_mean']:.4f} | {o['l1_mean'] / heat['overall']['l1_mean']:.2f} | {o['dominant']:.3f} "
                  f"| {o['precision']:.3f} | {o['recall']:.3f} | {o['deform_mean']:.5f} | {o['deform_max']:.4f} "
                  f"| {below} |")

print("\nEpoch kept (best validation L1) of the epochs run, per fold and run:\n")
print("| run | " + " | ".join(FOLDS) + " |")
print("|---|" + "---:|" * len(FOLDS))
for label, run in runs:
    print(f"| {label} | " + " | ".join(epochs(run, f) for f in FOLDS) + " |")

print("\nBoundaries: vertices whose dominant bone is on the other side of the artist's boundary / vertices at "
      "that boundary, summed over the fold's test characters (gat eval --confusions):\n")
header = None
for fold in FOLDS:
    for i, (label, run) in enumerate(runs):
        for key in ("bone-heat", "skinweights-any"):
            j = load(run, fold, key)
            if not j or not j["overall"].get("boundaries") or (key == "bone-heat" and i > 0):
                continue
            b = j["overall"]["boundaries"]
            if header is None:
                header = [x["boundary"] for x in b]
                print("| fold | method | " + " | ".join(header) + " |")
                print("|---|---|" + "---:|" * len(header))
            who = "bone heat" if key == "bone-heat" else f"calibrated, {label}"
            print(f"| {fold} | {who} | " + " | ".join(f"{x['crossed']} / {x['vertices']}" for x in b) + " |")

print("\nPer character: L1 / dominant bone (bone heat, then the calibrated model of each run):\n")
print("| fold | character | bone heat | " + " | ".join(label for label, _ in runs) + " |")
print("|---|---|---:|" + "---:|" * len(runs))
for fold in FOLDS:
    heat = None
    for _, run in runs:
        heat = heat or load(run, fold, "bone-heat")
    if not heat:
        continue
    models = [load(run, fold, "skinweights-any") for _, run in runs]
    models = [{c["name"]: c for c in m["characters"]} if m else {} for m in models]
    for c in heat["characters"]:
        cells = []
        for m in models:
            x = m.get(c["name"])
            cells.append(f"{x['l1_mean']:.4f} / {x['dominant']:.3f}" if x else "")
        print(f"| {fold} | {c['name']} | {c['l1_mean']:.4f} / {c['dominant']:.3f} | " + " | ".join(cells) + " |")
