"""A multi-mesh character as users' files have them, made by Blender itself
(tests/blender/run.sh):

  blender -b --factory-startup --python-exit-code 1 -P make_multi_mesh.py -- IN.glb OUT.glb

Imports a single-mesh skinned character, separates the faces above the
median height into their own object ("Upper"; the rest is "Lower"), both
still skinned to the armature, and exports the two-object glTF with
Blender's exporter."""
import os
import sys

import bmesh

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gat_files import bpy, import_glb  # noqa: E402

src, dst = sys.argv[sys.argv.index("--") + 1:][:2]
(obj,) = import_glb(src)
bpy.context.view_layer.objects.active = obj
obj.select_set(True)
bpy.ops.object.mode_set(mode="EDIT")
bm = bmesh.from_edit_mesh(obj.data)
heights = sorted(v.co.z for v in bm.verts)
median = heights[len(heights) // 2]
for f in bm.faces:
    f.select_set(all(v.co.z > median for v in f.verts))
bmesh.update_edit_mesh(obj.data)
bpy.ops.mesh.separate(type="SELECTED")
bpy.ops.object.mode_set(mode="OBJECT")
meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
assert len(meshes) == 2, f"separating gave {[o.name for o in meshes]}"
upper = next(o for o in meshes if o is not obj)
obj.name, upper.name = "Lower", "Upper"
assert all(any(m.type == "ARMATURE" for m in o.modifiers) for o in meshes), "a part lost its Armature modifier"
bpy.ops.export_scene.gltf(filepath=dst, export_format="GLB", export_skins=True, export_animations=False,
                          export_morph=False)
print(f"multi-mesh: {[(o.name, len(o.data.vertices)) for o in meshes]} -> {dst}")
