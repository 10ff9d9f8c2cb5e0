"""Blender's automatic weights (bone heat) as a peer for gatcore's.

Run inside Blender, headless:
  blender -b --factory-startup --python-exit-code 1 -P auto_weights.py -- CHARACTER.glb OUT.json

Imports the character with the glTF importer's defaults, reads every skinned
mesh object's artist weights (its vertex groups), removes them, and runs
Object > Parent > With Automatic Weights (parent_set type='ARMATURE_AUTO') on
each mesh object with its own armature, as a user would. Writes OUT.json:
  {"source", "blender", "bones": [deform bone names],
   "heads": [x, y, z, ...]  (each bone's world rest head, same frame),
   "objects": [{"name", "vertices": n, "failed_bones": [...]}],
   "positions": [x, y, z, ...]   (world rest positions, glTF's Y-up frame),
   "artist": [[bone, weight, bone, weight, ...] per vertex],
   "auto":   [[bone, weight, ...] per vertex],
   "seconds": time spent in parent_set}
Bone indices refer to "bones"; vertices of all objects are concatenated in
object order. gatcore reads it back (tests/blender/bone_heat_peer.cpp),
maps Blender's frame onto its bind frame by the bone heads (a similarity: the
importer may move, turn and scale the character), matches the vertices to its
own by position and scores both methods with the
same metric. The artist weights are there to check that match: read through
it they must equal gatcore's own import of the file.
"""
import json
import os
import sys
import time

import numpy as np

if "bool" not in np.__dict__:  # Debian 12's Blender 3.4 glTF importer uses np.bool
    np.bool = bool

import bpy  # noqa: E402


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    merge = "--merge" in argv  # the importer's "Merge Vertices" (welds UV / normal seams)
    argv = [a for a in argv if a != "--merge"]
    if len(argv) != 2:
        raise SystemExit("usage: auto_weights.py -- CHARACTER.glb OUT.json [--merge]")
    src, out = argv
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if src.lower().endswith((".glb", ".gltf")):
        bpy.ops.import_scene.gltf(filepath=src, merge_vertices=merge)
    elif src.lower().endswith(".fbx"):
        bpy.ops.import_scene.fbx(filepath=src)
    else:
        raise SystemExit(f"{src}: expected .glb, .gltf or .fbx")

    meshes = []
    for o in sorted(bpy.context.scene.objects, key=lambda o: o.name):
        if o.type != "MESH":
            continue
        arm = next((m.object for m in o.modifiers if m.type == "ARMATURE" and m.object), None)
        if arm is None and o.parent is not None and o.parent.type == "ARMATURE":
            arm = o.parent
        if arm is not None and len(o.vertex_groups) > 0:
            meshes.append((o, arm))
    if not meshes:
        raise SystemExit(f"{src}: no skinned mesh object")

    bones, bone_id, heads = [], {}, []
    bone_head = {}
    for arm in {a for _, a in meshes}:
        for b in arm.data.bones:
            p = arm.matrix_world @ b.head_local
            bone_head.setdefault(b.name, (p.x, p.z, -p.y))

    def bid(name):
        if name not in bone_id:
            bone_id[name] = len(bones)
            bones.append(name)
            heads.extend(bone_head[name])
        return bone_id[name]

    positions, artist, auto, objects = [], [], [], []
    seconds = 0.0
    for o, arm in meshes:
        for b in arm.data.bones:
            if b.use_deform:
                bid(b.name)
        names = [g.name for g in o.vertex_groups]
        bone_names = {b.name for b in arm.data.bones}
        mw = o.matrix_world
        first = len(positions)
        for v in o.data.vertices:
            p = mw @ v.co
            positions.append((p.x, p.z, -p.y))  # Blender Z-up -> glTF Y-up
            row = []
            for g in v.groups:
                if g.weight > 0 and names[g.group] in bone_names:
                    row += [bid(names[g.group]), round(g.weight, 7)]
            artist.append(row)
        # Blender's automatic weights on this object alone, its armature active.
        o.vertex_groups.clear()
        for m in list(o.modifiers):
            if m.type == "ARMATURE":
                o.modifiers.remove(m)
        bpy.ops.object.mode_set(mode="OBJECT") if bpy.context.object and bpy.context.object.mode != "OBJECT" else None
        for x in bpy.context.scene.objects:
            x.select_set(False)
        o.select_set(True)
        arm.select_set(True)
        bpy.context.view_layer.objects.active = arm
        t0 = time.time()
        res = bpy.ops.object.parent_set(type="ARMATURE_AUTO", keep_transform=True)
        seconds += time.time() - t0
        if res != {"FINISHED"}:
            raise SystemExit(f"{src}: parent_set on {o.name} returned {res}")
        names = [g.name for g in o.vertex_groups]
        weighted = set()
        for v in o.data.vertices:
            row = []
            for g in v.groups:
                if g.weight > 0:
                    row += [bid(names[g.group]), round(g.weight, 7)]
                    weighted.add(names[g.group])
            auto.append(row)
        # The mesh must not have moved (positions are matched on).
        mw = o.matrix_world
        moved = max((abs(a - b) for i, v in enumerate(o.data.vertices)
                     for a, b in zip(positions[first + i], ((mw @ v.co).x, (mw @ v.co).z, -(mw @ v.co).y))),
                    default=0.0)
        if moved > 1e-4:
            raise SystemExit(f"{src}: {o.name} moved by {moved} during parent_set")
        objects.append({"name": o.name, "armature": arm.name, "vertices": len(o.data.vertices),
                        "unweighted_vertices": sum(1 for i in range(first, len(positions)) if not auto[i])})
    doc = {"source": os.path.abspath(src), "blender": bpy.app.version_string, "bones": bones, "heads": heads,
           "objects": objects, "positions": [c for p in positions for c in p], "artist": artist,
           "auto": auto, "seconds": seconds, "merge_vertices": merge}
    tmp = out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(doc, f)
    os.replace(tmp, out)
    print(f"auto_weights: {src}: {len(positions)} vertices, {len(objects)} objects, {len(bones)} bones, "
          f"{seconds:.1f} s")


main()
