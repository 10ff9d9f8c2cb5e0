"""Per-family table of bone_heat_peer's scores (scripts/bone_heat_vs_blender.sh)."""
import json
import os
import sys
from collections import defaultdict

rows = [json.load(open(p)) for p in sys.argv[1:] if os.path.exists(p)]
print("| character | vertices | joints | gatcore L1 | Blender L1 | gatcore dominant | Blender dominant "
      "| Blender-solved vertices |")
print("|---|---:|---:|---:|---:|---:|---:|---:|")
for r in rows:
    name = os.path.basename(os.path.dirname(r["character"])) + "/" + os.path.basename(r["character"])
    print(f"| {name} | {r['vertices']} | {r['joints']} | {r['gatcore_l1']:.3f} | {r['blender_l1']:.3f} "
          f"| {r['gatcore_dominant']:.3f} | {r['blender_dominant']:.3f} | {r['solved_vertices']} |")
print()
fam = defaultdict(list)
for r in rows:
    f = os.path.basename(os.path.dirname(r["character"]))
    if f.startswith("gat_peer"):
        f = "procedural"
    fam[f].append(r)
    fam["all"].append(r)


def mean(xs):
    return sum(xs) / len(xs) if xs else float("nan")


print("| family | characters | gatcore L1 | Blender L1 | ratio | gatcore dominant | Blender dominant "
      "| Blender-solved share | gatcore L1 (solved) | Blender L1 (solved) |")
# "solved": the vertices Blender weighted at all (it gives up on a mesh object
# with a piece no bone heats); those means skip characters with none.
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for f, rs in sorted(fam.items(), key=lambda kv: (kv[0] == "all", kv[0])):
    g, b = mean([r["gatcore_l1"] for r in rs]), mean([r["blender_l1"] for r in rs])
    print(f"| {f} | {len(rs)} | {g:.3f} | {b:.3f} | {g / b:.2f} | {mean([r['gatcore_dominant'] for r in rs]):.3f} "
          f"| {mean([r['blender_dominant'] for r in rs]):.3f} "
          f"| {mean([r['solved_vertices'] / r['vertices'] for r in rs]):.2f} "
          f"| {mean([r['gatcore_l1_solved'] for r in rs if r['solved_vertices']]):.3f} "
          f"| {mean([r['blender_l1_solved'] for r in rs if r['solved_vertices']]):.3f} |")

# Per boundary (eval/boundaries.hpp): of the vertices whose artist's dominant
# joint is on either side, the share each method puts on the other side.
acc = defaultdict(lambda: [0, 0, 0])
for r in rows:
    for which, col in (("gatcore_boundaries", 1), ("blender_boundaries", 2)):
        for b in r.get(which, []):
            if col == 1:
                acc[b["boundary"]][0] += b["vertices"]
            acc[b["boundary"]][col] += b["crossed"]
if acc:
    print()
    print("| boundary | vertices | gatcore crossed | Blender crossed |")
    print("|---|---:|---:|---:|")
    for name in ("head/neck", "chest/neck", "hips/spine", "upper arm/chest", "knee", "ankle"):
        if name in acc:
            v, g, b = acc[name]
            print(f"| {name} | {v} | {g / v:.3f} | {b / v:.3f} |")
