#!/bin/sh
# gat predict-weights and gat deform go through the runtime (runtime::WeightPredictor,
# runtime::bone_heat_weights, runtime::Deformer); tool_path_reference computes the same
# files with the character layer's functions on the imported character (the path the tool
# took before). Every file must be the same byte for byte: one path, the old numbers.
#   tool_runtime_path.sh GAT TOOL_PATH_REFERENCE BUILD_ROOT
# BUILD_ROOT holds the CLI tests' fixtures gat_h5.glb, gat_swing.bvh and
# gat_small_dataset.json; gat_cm_ns.gcm and gat_cm_dg.gcm are in the working directory.
set -e
G=$1
R=$2
B=$3
h5=$B/gat_h5.glb
bvh=$B/gat_swing.bvh
same() {
  if cmp "$1" "$2"; then echo "same: $1 $2"; else echo "DIFFERENT: $1 $2"; exit 1; fi
}
rm -f tp_*
$G train -q --threads 2 --model skinweights-any --data "$B/gat_small_dataset.json" --epochs 1 --batch 2 \
  --sampling full --pair-scorer 16 --out tp_any.gcm
$G train -q --threads 2 --model densegats --joint-columns nearest:4 --data "$B/gat_small_dataset.json" --epochs 1 \
  --samples 1 --batch 2 --out tp_nj.gcm

# Skin weights: a name-matched model (plain; mixed with bone heat with a control joint, then a
# min weight), skinweights-any (mixed, min weight), bone heat alone (default and with options).
$G predict-weights gat_cm_ns.gcm "$h5" -o tp_ns.glb -q
$R weights gat_cm_ns.gcm "$h5" tp_ns_ref.glb 4 0 0 -
same tp_ns.glb tp_ns_ref.glb
$G predict-weights gat_cm_ns.gcm "$h5" -o tp_ns_blend.glb --max-influences 6 --heat-blend 0.5 --control Chest \
  --min-weight 0.02 -q
$R weights gat_cm_ns.gcm "$h5" tp_ns_blend_ref.glb 6 0.5 0.02 Chest
same tp_ns_blend.glb tp_ns_blend_ref.glb
$G predict-weights tp_any.gcm "$h5" -o tp_any.glb --max-influences 3 --heat-blend 0.3 --min-weight 0.05 -q
$R weights tp_any.gcm "$h5" tp_any_ref.glb 3 0.3 0.05 -
same tp_any.glb tp_any_ref.glb
$G predict-weights --method bone-heat "$h5" -o tp_heat.glb -q
$R weights heat "$h5" tp_heat_ref.glb 4 0 -1 -
same tp_heat.glb tp_heat_ref.glb
$G predict-weights --method bone-heat "$h5" -o tp_heat_opt.glb --max-influences 6 --min-weight 0.05 --control Chest -q
$R weights heat "$h5" tp_heat_opt_ref.glb 6 0 0.05 Chest
same tp_heat_opt.glb tp_heat_opt_ref.glb

# Deformation: bone columns and nearest-joint columns, morph targets and point cache.
for m in gat_cm_dg tp_nj; do
  $G deform $m.gcm "$h5" "$bvh" --frames 1:5 -o tp_${m}_deform.glb --point-cache tp_${m}_deform.pc2 -q
  $R deform $m.gcm "$h5" "$bvh" 1 5 tp_${m}_deform_ref.glb tp_${m}_deform_ref.pc2
  same tp_${m}_deform.glb tp_${m}_deform_ref.glb
  same tp_${m}_deform.pc2 tp_${m}_deform_ref.pc2
done
echo runtime-path-ok
