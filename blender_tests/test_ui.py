"""The menus and panels: every operator, property, enum value and icon they name exists (Blender
finds a wrong one only when the panel is drawn, and then the panel stops drawing there), and
the add-on sits in the menus where riggers look for it.

Panels cannot be drawn without a window, so the names are read from the source of each area's
installed ``ui.py`` and looked up in this Blender's own operator and icon tables."""

from __future__ import annotations

import ast
import importlib
import inspect

import bpy

AREAS = ("weights", "skeleton", "motion", "puppet")
UIS = [importlib.import_module(f"bl_ext.user_default.miniskeleton.{area}.ui") for area in AREAS]
UI_MODULES = {ui.__name__ for ui in UIS}
ICONS = set(bpy.types.UILayout.bl_rna.functions["operator"].parameters["icon"].enum_items.keys())
LAYOUT_CALLS = ("operator", "operator_menu_enum")


def op_rna(idname: str):
    """The RNA type of operator ``idname`` ("object.foo"), or None when there is none."""
    category, name = idname.split(".")
    try:
        return getattr(getattr(bpy.ops, category), name).get_rna_type()
    except (AttributeError, KeyError):
        return None


def constants(tree: ast.Module) -> dict[str, list]:
    """Module-level ``NAME = "literal"``."""
    out = {}
    for node in tree.body:
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant):
            for target in node.targets:
                if isinstance(target, ast.Name):
                    out[target.id] = [node.value.value]
    return out


def loop_values(func: ast.AST) -> dict[str, list]:
    """``for a, b in (("x", "y"), ...)`` in ``func``: {"a": ["x", ...], "b": ["y", ...]}."""
    out: dict[str, list] = {}
    for node in ast.walk(func):
        if isinstance(node, ast.For) and isinstance(node.target, ast.Tuple) and isinstance(node.iter, ast.Tuple):
            names = [t.id for t in node.target.elts]
            for row in node.iter.elts:
                for name, value in zip(names, row.elts):
                    if isinstance(value, ast.Constant):
                        out.setdefault(name, []).append(value.value)
    return out


def values(node: ast.AST, env: dict[str, list]) -> list | None:
    """The literal values ``node`` can have, or None when it is not a literal or a known name."""
    if isinstance(node, ast.Constant):
        return [node.value]
    if isinstance(node, ast.Name):
        return env.get(node.id)
    return None


def layout_call(node: ast.AST) -> ast.Call | None:
    """``node`` when it is ``<layout>.operator(...)`` or ``<layout>.operator_menu_enum(...)``."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in LAYOUT_CALLS:
        return node
    return None


def ui_references() -> tuple[list[tuple], list[tuple], list[str]]:
    """From the areas' ui.py draw functions: (operator idname, enum property of
    operator_menu_enum or None, where), (operator idname, property set on its button, possible
    values, where), icons; where is "area/ui.py:line"."""
    calls, settings, icons = [], [], []
    for area, ui in zip(AREAS, UIS):
        found = area_references(area, ast.parse(inspect.getsource(ui)))
        for total, part in zip((calls, settings, icons), found):
            total += part
    return calls, settings, icons


def area_references(area: str, tree: ast.Module) -> tuple[list[tuple], list[tuple], list[str]]:
    """``ui_references`` of one area's ui.py (parsed as ``tree``)."""
    consts = constants(tree)
    calls, settings, icons = [], [], []
    for func in (n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)):
        env = {**consts, **loop_values(func)}
        button_of: dict[str, ast.Call] = {}  # op = col.operator(...)
        for node in ast.walk(func):
            if isinstance(node, ast.Assign) and len(node.targets) == 1:
                target = node.targets[0]
                if isinstance(target, ast.Name) and layout_call(node.value):
                    button_of[target.id] = node.value
                elif isinstance(target, ast.Attribute):
                    owner = target.value
                    call = layout_call(owner) or (button_of.get(owner.id) if isinstance(owner, ast.Name) else None)
                    if call is not None:
                        for idname in values(call.args[0], env) or [None]:
                            where = f"{area}/ui.py:{node.lineno}"
                            settings.append((idname, target.attr, values(node.value, env), where))
            call = layout_call(node)
            if call is None:
                continue
            for idname in values(call.args[0], env) or [None]:
                prop = call.args[1].value if call.func.attr == "operator_menu_enum" else None
                calls.append((idname, prop, f"{area}/ui.py:{call.lineno}"))
            for kw in call.keywords:
                if kw.arg == "icon":
                    icons += values(kw.value, env) or []
    return calls, settings, icons


def test_panels_and_menus_name_operators_properties_and_icons_that_exist():
    calls, settings, icons = ui_references()
    # Enough found that the checks below are not vacuous: the weights, skeleton, motion and
    # puppet panels and their menus.
    assert len(calls) >= 20 and len(settings) >= 5 and len(icons) >= 12, (len(calls), len(settings), len(icons))
    for idname, prop, where in calls:
        assert idname is not None, f"{where}: operator name is not a literal"
        rna = op_rna(idname)
        assert rna is not None, f"{where}: no operator {idname}"
        if prop is not None:
            assert prop in rna.properties and rna.properties[prop].type == "ENUM", (where, idname, prop)
    for idname, attr, vals, where in settings:
        assert idname is not None, f"{where}: operator name is not a literal"
        rna = op_rna(idname)
        assert attr in rna.properties, f"{where}: {idname} has no property {attr}"
        p = rna.properties[attr]
        if p.type == "ENUM" and vals is not None:
            items = set(p.enum_items.keys())
            assert set(vals) <= items, f"{where}: {idname}.{attr} = {vals}, not in {sorted(items)}"
    unknown = sorted(set(icons) - ICONS)
    assert not unknown, f"icons Blender does not have: {unknown}"


def test_each_method_and_motion_gets_its_own_button():
    """The panels' buttons set different methods / motions / symmetries, covering every one
    the operator offers (a button that forgot its setting would run the default)."""
    _, settings, _ = ui_references()
    by_target: dict[tuple[str, str], list] = {}
    for idname, attr, vals, _line in settings:
        by_target.setdefault((idname, attr), []).extend(vals or [])
    for idname, attr in (("object.miniskeleton_auto_weights", "method"), ("pose.miniskeleton_add_motion", "motion")):
        items = set(op_rna(idname).properties[attr].enum_items.keys())
        got = by_target.get((idname, attr), [])
        assert sorted(got) == sorted(items), (idname, attr, got, items)
    assert sorted(by_target[("armature.miniskeleton_fit_skeleton", "symmetry")]) == ["NONE", "X"]


def test_add_on_is_in_the_menus_riggers_use():
    """Ctrl+P (Object > Parent) and Weight Paint > Weights: weights; Add > Armature: Auto Rig and
    puppets; Armature (Edit Mode) and Pose: fit / restore / keep and motions; File > Import /
    Export: the rig bundle; Render: the video. Each menu draws at least one function of the areas' ui.py,
    and each panel is registered in the MiniSkeleton sidebar tab."""
    wanted = {
        "VIEW3D_MT_object_parent": {"draw_parent_menu"},
        "VIEW3D_MT_paint_weight": {"draw_parent_menu"},
        "VIEW3D_MT_armature_add": {"draw_auto_rig_add_menu", "draw_puppet_add_menu"},
        "VIEW3D_MT_edit_armature": {"draw_armature_menu"},
        "VIEW3D_MT_pose": {"draw_armature_menu", "draw_pose_motion_menu"},
        "TOPBAR_MT_file_export": {"draw_export_menu"},
        "TOPBAR_MT_file_import": {"draw_import_menu"},
        "TOPBAR_MT_render": {"draw_render_video_menu"},
    }
    for menu, draws in wanted.items():
        funcs = getattr(bpy.types, menu)._dyn_ui_initialize()
        ours = {f.__name__ for f in funcs if getattr(f, "__module__", "") in UI_MODULES}
        assert ours == draws, (menu, ours)
    for cls in (cls for ui in UIS for cls in ui.classes):
        registered = getattr(bpy.types, cls.__name__, None)
        assert registered is not None and registered.bl_category == "MiniSkeleton", cls.__name__
