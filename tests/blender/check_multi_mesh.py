"""Blender's view of `gat deform` on a multi-mesh character (ctest
gat_blender_import; run by tests/blender/run.sh):

  blender -b --factory-startup --python-exit-code 1 -P check_multi_mesh.py -- \
      CHARACTER.glb DEFORMED.glb CACHE_STEM FIRST_FRAME OBJECT...

`gat deform CHARACTER.glb ... -o DEFORMED.glb --point-cache CACHE_STEM.pc2`
writes one cache per object, CACHE_STEM_<object>.pc2. The user's workflow:
import CHARACTER.glb, give each OBJECT a Mesh Cache modifier with its own
cache (the README's settings). Checked per object: the modifier takes the
cache without a vertex count mismatch and gives its positions, the cache
moves (not the bind pose), and the object's shape keys in DEFORMED.glb equal
the same cache. (Blender 3.4 names an imported object with shape keys after
its mesh, not its node: DEFORMED.glb's objects are matched through the
file's node -> mesh table.)
Prints 'blender-multi-ok' at the end; any failure raises (exit code 1)."""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gat_files import check_mesh_cache, check_shape_keys, glb, import_glb, read_pc2  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
character_glb, deformed_glb, stem, first_frame, names = argv[0], argv[1], argv[2], int(argv[3]), argv[4:]

caches = {}
for name in names:
    path = f"{stem}_{name}.pc2"
    start, caches[name] = read_pc2(path)
    assert start == first_frame, f"{path}: starts at frame {start}, expected {first_frame}"

# The character as the user has it in the scene, a Mesh Cache per object.
objs = {o.name: o for o in import_glb(character_glb)}
assert sorted(objs) == sorted(names), f"{character_glb}: mesh objects {sorted(objs)}, expected {sorted(names)}"
for name in names:
    obj, cache, path = objs[name], caches[name], f"{stem}_{name}.pc2"
    rest = np.array([v.co[:] for v in obj.data.vertices])
    assert cache.shape[1] == len(rest), f"{path}: {cache.shape[1]} points, object {name} has {len(rest)} vertices"
    moved = np.abs(cache - rest[None]).max()
    assert moved > 1e-3, f"{path}: the cache stays in the bind pose (moves {moved})"
    mc = check_mesh_cache(obj, path, cache, first_frame, path)
    print(f"object {name}: {len(rest)} vertices, {cache.shape[0]} frames, moves up to {moved:.3f}; "
          f"max |Mesh Cache - cache| {mc:.2e}")

# The deformed file's shape keys, per object, against the same caches.
doc, _ = glb(deformed_glb)
node_of_mesh = {doc["meshes"][n["mesh"]].get("name"): n.get("name") for n in doc["nodes"] if "mesh" in n}
deformed = {node_of_mesh.get(o.data.name, o.name): o for o in import_glb(deformed_glb)}
assert sorted(deformed) == sorted(names), f"{deformed_glb}: mesh objects {sorted(deformed)}, expected {sorted(names)}"
for name in names:
    keys = check_shape_keys(deformed[name], caches[name], f"{deformed_glb} object {name}")
    print(f"object {name}: max |shape key - cache| {keys:.2e}")
print("blender-multi-ok")
