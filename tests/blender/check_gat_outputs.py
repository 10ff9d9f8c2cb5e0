"""Blender's view of gat's outputs (ctest gat_blender_import; run by
tests/blender/run.sh):

  blender -b --factory-startup --python-exit-code 1 -P check_gat_outputs.py -- \
      WEIGHTS.glb DEFORMED.glb CACHE.pc2 FIRST_FRAME

Checks, against gatcore's own numbers read straight from the files:
  1. predict-weights: every vertex group weight of the imported mesh equals
     the file's JOINTS_n / WEIGHTS_n (gatcore's prediction), per vertex and joint;
  2. deform: one shape key per frame, the 'deform' action, and each shape
     key's positions equal the point cache's sample of that frame (written
     with --up z, Blender's frame);
  3. the Mesh Cache modifier (PC2, default axes, Frame Start = FIRST_FRAME as
     the README says: Blender 3.4 ignores the .pc2 header's start frame) on
     the imported object makes Blender's evaluated mesh at scene frame
     FIRST_FRAME + k equal sample k.
Prints 'blender-ok' at the end; any failure raises (exit code 1)."""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gat_files import TOL, accessor, check_mesh_cache, check_shape_keys, glb, import_glb, read_pc2  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
weights_glb, deformed_glb, cache_pc2, first_frame = argv[0], argv[1], argv[2], int(argv[3])


def only_mesh(path):
    meshes = import_glb(path)
    assert len(meshes) == 1, f"{path}: expected one mesh object, got {[o.name for o in meshes]}"
    return meshes[0]


# 1. Skin weights.
obj = only_mesh(weights_glb)
doc, blob = glb(weights_glb)
prim = doc["meshes"][0]["primitives"][0]
joint_names = [doc["nodes"][j].get("name", f"Node_{j}") for j in doc["skins"][0]["joints"]]
n = len(obj.data.vertices)
want = np.zeros((n, len(joint_names)))
k = 0
while f"JOINTS_{k}" in prim["attributes"]:
    J = accessor(doc, blob, prim["attributes"][f"JOINTS_{k}"]).astype(int)
    W = accessor(doc, blob, prim["attributes"][f"WEIGHTS_{k}"])
    assert len(J) == n, f"{len(J)} file vertices, Blender has {n}"
    for c in range(4):
        np.add.at(want, (np.arange(n), J[:, c]), W[:, c])
    k += 1
got = np.zeros_like(want)
group_col = {g.index: joint_names.index(g.name) for g in obj.vertex_groups if g.name in joint_names}
for v in obj.data.vertices:
    for ge in v.groups:
        if ge.group in group_col:
            got[v.index, group_col[ge.group]] = ge.weight
err = np.abs(got - want).max()
print(f"vertex groups: {len(obj.vertex_groups)} groups, {n} vertices, max |Blender - file| weight {err:.2e}")
assert err < TOL, f"vertex group weights differ from the file's by {err}"
assert (want > 0).sum() > n, "no skin weights read"

# 2. Shape keys, the deform action, against the point cache.
obj = only_mesh(deformed_glb)
start, cache = read_pc2(cache_pc2)
assert start == first_frame, f"{cache_pc2}: starts at frame {start}, expected {first_frame}"
worst = check_shape_keys(obj, cache, deformed_glb)
print(f"shape keys: {cache.shape[0]} frames, action 'deform', max |shape key - point cache| {worst:.2e}")

# 3. The Mesh Cache modifier, the README's settings.
worst = check_mesh_cache(obj, cache_pc2, cache, first_frame, cache_pc2)
print(f"mesh cache: frames {first_frame}..{first_frame + cache.shape[0] - 1}, max |evaluated - cache| {worst:.2e}")
print("blender-ok")
