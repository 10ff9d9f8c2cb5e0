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
import json
import struct
import sys

import numpy as np

# Debian 12's Blender 3.4 glTF importer uses np.bool, gone in its numpy 1.24.
if "bool" not in np.__dict__:
    np.bool = bool

import bpy  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
weights_glb, deformed_glb, cache_pc2, first_frame = argv[0], argv[1], argv[2], int(argv[3])
TOL = 1e-5


def glb(path):
    data = open(path, "rb").read()
    assert data[:4] == b"glTF", f"{path}: not a .glb"
    n = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + n])
    at = 20 + n
    blob = data[at + 8:] if len(data) > at else b""
    return doc, blob


def accessor(doc, blob, index):
    a = doc["accessors"][index]
    v = doc["bufferViews"][a["bufferView"]]
    comps = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[a["type"]]
    dtype = {5126: np.float32, 5121: np.uint8, 5123: np.uint16, 5125: np.uint32}[a["componentType"]]
    start = v.get("byteOffset", 0) + a.get("byteOffset", 0)
    stride = v.get("byteStride", 0) or comps * np.dtype(dtype).itemsize
    out = np.empty((a["count"], comps), dtype=np.float64)
    for i in range(a["count"]):
        out[i] = np.frombuffer(blob, dtype=dtype, count=comps, offset=start + i * stride)
    if a.get("normalized") and dtype != np.float32:
        out /= np.iinfo(dtype).max
    return out


def read_pc2(path):
    data = open(path, "rb").read()
    assert data[:12] == b"POINTCACHE2\0", f"{path}: not a .pc2"
    _, points, start, rate, samples = struct.unpack_from("<iiffi", data, 12)
    pts = np.frombuffer(data, dtype="<f4", offset=32).reshape(samples, points, 3).astype(np.float64)
    return start, pts


def import_glb(path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    assert len(meshes) == 1, f"{path}: expected one mesh object, got {[o.name for o in meshes]}"
    return meshes[0]


# 1. Skin weights.
obj = import_glb(weights_glb)
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
obj = import_glb(deformed_glb)
start, cache = read_pc2(cache_pc2)
assert start == first_frame, f"{cache_pc2}: starts at frame {start}, expected {first_frame}"
keys = obj.data.shape_keys.key_blocks
frames = len(keys) - 1  # the basis
assert frames == cache.shape[0], f"{frames} shape keys, the cache has {cache.shape[0]} samples"
assert cache.shape[1] == len(obj.data.vertices), f"cache has {cache.shape[1]} points, object {len(obj.data.vertices)}"
actions = [a.name for a in bpy.data.actions]
assert any(a.startswith("deform") for a in actions), f"no 'deform' action (actions: {actions})"
worst = 0.0
for f in range(frames):
    co = np.array([p.co[:] for p in keys[f + 1].data])
    worst = max(worst, np.abs(co - cache[f]).max())
print(f"shape keys: {frames} frames, action 'deform', max |shape key - point cache| {worst:.2e}")
assert worst < TOL, f"shape keys differ from the point cache by {worst}"

# 3. The Mesh Cache modifier, default settings, the Armature modifier off
# (the cache already holds the deformed positions), the shape keys muted.
for m in obj.modifiers:
    m.show_viewport = False
for kb in keys:
    kb.mute = True
mod = obj.modifiers.new("gat", "MESH_CACHE")
mod.cache_format = "PC2"
mod.filepath = cache_pc2
mod.frame_start = first_frame  # the README's step: Blender reads samples from this scene frame on
scene = bpy.context.scene
worst = 0.0
for f in range(cache.shape[0]):
    scene.frame_set(first_frame + f)
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    co = np.array([v.co[:] for v in ev.data.vertices])
    worst = max(worst, np.abs(co - cache[f]).max())
print(f"mesh cache: frames {first_frame}..{first_frame + cache.shape[0] - 1}, max |evaluated - cache| {worst:.2e}")
assert worst < TOL, f"Blender's Mesh Cache result differs from the cache by {worst}"
print("blender-ok")
