"""Extract Spot the cow's mesh, without its skeleton, from ../shared/models/spot_rig.glb into
assets/spot/spot.glb: the mesh alone (no armature, no vertex groups or weights, no UVs or
materials), welded along the glTF's split seams, +Z up, standing on z = 0 where the file puts it.
`make demo` rigs it with Auto Rig. Spot is public domain (CC0), by Keenan Crane: see
assets/spot/LICENSE.txt.

    python -m scripts.extract_spot [--source ../shared/models/spot_rig.glb] [--out assets/spot/spot.glb]

Needs only Blender's ``bpy`` module (the project's .venv), not the extension.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from testkit import MODELS_DIR, ROOT


def extract(source: Path, out: Path) -> None:
    import bpy
    import bmesh  # importable once bpy is

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(source))
    for arm in [ob for ob in bpy.data.objects if ob.type == "ARMATURE"]:
        arm.data.pose_position = "REST"
    bpy.context.view_layer.update()
    shapes = {pb.custom_shape for arm in bpy.data.objects if arm.type == "ARMATURE" for pb in arm.pose.bones}
    meshes = [ob for ob in bpy.data.objects if ob.type == "MESH" and len(ob.data.polygons) and ob not in shapes]
    if len(meshes) != 1:
        raise SystemExit(f"{source}: expected one mesh, found {len(meshes)}")
    ob = meshes[0]
    world = ob.matrix_world.copy()
    ob.parent = None
    me = ob.data
    me.transform(world)  # vertices in world space, the object at the origin
    ob.matrix_world.identity()
    ob.vertex_groups.clear()
    ob.modifiers.clear()
    ob.shape_key_clear()
    for uv in list(me.uv_layers):
        me.uv_layers.remove(uv)
    me.materials.clear()
    bm = bmesh.new()
    bm.from_mesh(me)
    size = max(max(v.co[i] for v in bm.verts) - min(v.co[i] for v in bm.verts) for i in range(3))
    bmesh.ops.remove_doubles(bm, verts=bm.verts[:], dist=1e-6 * size)  # the glTF's split seams
    bm.to_mesh(me)
    bm.free()
    for poly in me.polygons:
        poly.use_smooth = True
    ob.name = me.name = "Spot"
    for other in [o for o in bpy.data.objects if o != ob]:
        bpy.data.objects.remove(other)
    out.parent.mkdir(parents=True, exist_ok=True)
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.export_scene.gltf(filepath=str(out), export_format="GLB", use_selection=True, export_materials="NONE",
                              export_texcoords=False, export_normals=True, export_skins=False,
                              export_animations=False, export_yup=True)
    print(f"{out}: {len(me.vertices)} vertices, {len(me.polygons)} faces, {out.stat().st_size // 1024} KiB")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--source", type=Path, default=MODELS_DIR / "spot_rig.glb")
    ap.add_argument("--out", type=Path, default=ROOT / "assets" / "spot" / "spot.glb")
    args = ap.parse_args(argv)
    extract(args.source, args.out)


if __name__ == "__main__":
    main()
