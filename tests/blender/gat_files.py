"""What the Blender checks share (tests/blender/*.py, run inside Blender):
gatcore's own numbers read straight from its files, and a clean import."""
import json
import struct

import numpy as np

# Debian 12's Blender 3.4 glTF importer uses np.bool, gone in its numpy 1.24.
if "bool" not in np.__dict__:
    np.bool = bool

import bpy  # noqa: E402

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
    """The mesh objects of a fresh scene holding only `path`."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)
    return sorted((o for o in bpy.context.scene.objects if o.type == "MESH"), key=lambda o: o.name)


def check_shape_keys(obj, cache, label):
    """One shape key per cache sample (after the basis), equal to it; the
    'deform' action present. Returns the worst difference."""
    keys = obj.data.shape_keys.key_blocks
    frames = len(keys) - 1  # the basis
    assert frames == cache.shape[0], f"{label}: {frames} shape keys, the cache has {cache.shape[0]} samples"
    assert cache.shape[1] == len(obj.data.vertices), \
        f"{label}: cache has {cache.shape[1]} points, object {len(obj.data.vertices)}"
    actions = [a.name for a in bpy.data.actions]
    assert any(a.startswith("deform") for a in actions), f"no 'deform' action (actions: {actions})"
    worst = 0.0
    for f in range(frames):
        co = np.array([p.co[:] for p in keys[f + 1].data])
        worst = max(worst, np.abs(co - cache[f]).max())
    assert worst < TOL, f"{label}: shape keys differ from the point cache by {worst}"
    return worst


def check_mesh_cache(obj, cache_pc2, cache, first_frame, label):
    """The Mesh Cache modifier (PC2, default axes, Frame Start = first_frame,
    as the README says: Blender 3.4 ignores the .pc2 header's start frame),
    the Armature modifier off (the cache holds the deformed positions), the
    shape keys muted: Blender's evaluated mesh at scene frame first_frame + k
    equals sample k. Returns the worst difference."""
    for m in obj.modifiers:
        m.show_viewport = False
    if obj.data.shape_keys:
        for kb in obj.data.shape_keys.key_blocks:
            kb.mute = True
    mod = obj.modifiers.new("gat", "MESH_CACHE")
    mod.cache_format = "PC2"
    mod.filepath = cache_pc2
    mod.frame_start = first_frame
    scene = bpy.context.scene
    worst = 0.0
    for f in range(cache.shape[0]):
        scene.frame_set(first_frame + f)
        ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        co = np.array([v.co[:] for v in ev.data.vertices])
        assert co.shape == cache[f].shape, f"{label}: Blender evaluates {co.shape[0]} vertices, cache {cache.shape[1]}"
        worst = max(worst, np.abs(co - cache[f]).max())
    assert worst < TOL, f"{label}: Blender's Mesh Cache result differs from the cache by {worst}"
    return worst
