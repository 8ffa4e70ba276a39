"""The Shadow Theatre scene preset: a glowing screen behind the puppets, a warm backlight and
an orthographic camera on the audience side, with render settings for the shadow-play look."""

from __future__ import annotations

import math

import bpy
import numpy as np
from mathutils import Vector

from .build import polygon_mesh
from .rig import THEATRE_KEY, puppet_rig, scene_puppets

SCREEN = (1.0, 0.62, 0.28, 1.0)


# ---------------------------------------------------------------------------- shadow theatre


def _puppet_bounds(scene):
    """(min, max) of the puppets' parts and props in world (x, z); a default box if none."""
    pts = []
    dg = bpy.context.evaluated_depsgraph_get()
    for rig in scene_puppets(scene):
        for ob in [o for o in scene.objects if puppet_rig(o) == rig and o.type == "MESH"]:
            ev = ob.evaluated_get(dg)
            pts += [ev.matrix_world @ Vector(c) for c in ev.bound_box]
    if not pts:
        return np.array([-1.0, 0.0]), np.array([1.0, 2.0])
    xz = np.array([(p.x, p.z) for p in pts])
    return xz.min(0), xz.max(0)


def _theatre_object(scene, name, make_data):
    """The scene's theatre object in the role ``name`` (made by an earlier run: found by its
    role, whatever it is called now), or a new one with the data ``make_data()``, linked to the
    scene. Another scene's theatre is its own (refitting it here would move it there), and an
    object or data-block of the rigger's that has the name is never taken over (the new one is
    called ``name.001``)."""
    ob = next((o for o in scene.objects if o.get(THEATRE_KEY) == name), None)
    if ob is None:
        ob = bpy.data.objects.new(name, make_data())
        scene.collection.objects.link(ob)
        ob[THEATRE_KEY] = name
    return ob


def build_shadow_theatre(context: bpy.types.Context, engine: str = "WORKBENCH", margin: float = 0.1
                         ) -> tuple[bpy.types.Object, bpy.types.Object, bpy.types.Object]:
    """Screen behind the puppets (XZ plane, +Y), a warm area light behind the screen facing
    the audience, an orthographic camera on the audience side (-Y); render settings for the
    shadow-play look. Running it again refits the same objects."""
    scene = context.scene
    lo, hi = _puppet_bounds(scene)
    centre = (lo + hi) / 2
    aspect = scene.render.resolution_x / max(scene.render.resolution_y, 1)
    span = (hi - lo) * (1 + 2 * margin)
    height = max(span[1], span[0] / aspect, 1e-3) * 1.1     # a little room to walk and wave
    width = height * aspect

    me = polygon_mesh("ShadowScreen", [(-width / 2, 0, -height / 2), (width / 2, 0, -height / 2),
                                       (width / 2, 0, height / 2), (-width / 2, 0, height / 2)])
    screen = _theatre_object(scene, "ShadowScreen", lambda: me)
    if screen.data != me:
        old = screen.data
        screen.data = me
        if old.users == 0:
            bpy.data.meshes.remove(old)
    screen.location = (centre[0], 0.25 * height / 2, centre[1])
    mat = bpy.data.materials.get("MiniSkeleton Shadow Screen")
    if mat is None:
        mat = bpy.data.materials.new("MiniSkeleton Shadow Screen")
        mat.diffuse_color = SCREEN
        if mat.node_tree is None:
            mat.use_nodes = True
        nt = mat.node_tree
        for n in list(nt.nodes):
            if n.type != "OUTPUT_MATERIAL":
                nt.nodes.remove(n)
        out = next(n for n in nt.nodes if n.type == "OUTPUT_MATERIAL")
        trans = nt.nodes.new("ShaderNodeBsdfTranslucent")
        trans.inputs["Color"].default_value = SCREEN
        emit = nt.nodes.new("ShaderNodeEmission")
        emit.inputs["Color"].default_value = SCREEN
        emit.inputs["Strength"].default_value = 1.2
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(trans.outputs[0], add.inputs[0])
        nt.links.new(emit.outputs[0], add.inputs[1])
        nt.links.new(add.outputs[0], out.inputs["Surface"])
    screen.data.materials.append(mat)

    light = _theatre_object(scene, "ShadowBacklight", lambda: bpy.data.lights.new("ShadowBacklight", "AREA"))
    light_data = light.data
    light_data.color = (1.0, 0.7, 0.4)
    light_data.energy = 300.0 * height * height
    if light_data.type == "AREA":
        light_data.shape = "RECTANGLE"
        light_data.size, light_data.size_y = width, height
    light.location = (centre[0], height, centre[1])
    light.rotation_euler = (-math.pi / 2, 0.0, 0.0)       # shines along -Y, through the screen

    cam = _theatre_object(scene, "ShadowCamera", lambda: bpy.data.cameras.new("ShadowCamera"))
    cam_data = cam.data
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = max(width, height)
    cam_data.clip_end = 10 * height + 100
    cam.location = (centre[0], -4.0 * height, centre[1])
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)          # looks along +Y at the screen
    scene.camera = cam

    if scene.world is None:
        scene.world = bpy.data.worlds.new("ShadowTheatre")
    scene.world.color = (0.02, 0.012, 0.008)
    if engine == "EEVEE":
        items = {i.identifier for i in bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items}
        scene.render.engine = "BLENDER_EEVEE_NEXT" if "BLENDER_EEVEE_NEXT" in items else "BLENDER_EEVEE"
    else:
        scene.render.engine = "BLENDER_WORKBENCH"
    shading = scene.display.shading
    shading.light = "FLAT"
    shading.color_type = "TEXTURE"      # image parts show their picture, the rest their colour
    shading.show_shadows = False
    shading.show_cavity = False
    scene.view_settings.view_transform = "Standard"
    return screen, light, cam
