"""Panels: the "Squish" tab of the 3D view's sidebar (pairs, live mode, bake) and the object
properties (the object's parameters, profile curve, articulations)."""

from __future__ import annotations

import bpy

from . import evaluate, live, profile_curve, schema_props

# Drawn by hand beside the generic schema rows: the object pickers and the vertex-group keys.
_PER_VERTEX = ("bulge_map", "region_mask")


class _Sidebar:
    """Where the scene's panels live: the 3D view's sidebar, tab "Squish"."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Squish"


class _ObjectProperties:
    """Where the object's panels live: the Properties editor's Object tab."""

    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"


class SQUISH_PT_scene(_Sidebar, bpy.types.Panel):
    bl_label = "Squish"
    bl_idname = "SQUISH_PT_scene"

    def draw(self, context):
        layout = self.layout
        scene = context.scene
        settings = scene.squish
        row = layout.row(align=True)
        if settings.live:
            row.operator("squish.live", text="Live", icon="PAUSE", depress=True).enable = False
        else:
            row.operator("squish.live", text="Live", icon="PLAY").enable = True
        line = live.status.get(scene.name)
        if settings.live and line:
            layout.label(text=line, icon="ERROR" if line.startswith("Error") else "TIME")
        layout.operator("squish.pair_add", icon="ADD")
        for index, pair in enumerate(settings.pairs):
            box = layout.box()
            header = box.row(align=True)
            header.prop(pair, "show_expanded", text="", emboss=False,
                        icon="TRIA_DOWN" if pair.show_expanded else "TRIA_RIGHT")
            names = [o.name if o is not None else "?" for o in (pair.object_a, pair.object_b)]
            header.label(text=f"{names[0]} / {names[1]}")
            header.operator("squish.pair_remove", text="", icon="X").index = index
            if pair.show_expanded:
                box.prop(pair, "object_a")
                box.prop(pair, "object_b")
                schema_props.draw_level(box, pair, "pair")
                if pair.use_direction:
                    axis = box.row(align=True)
                    axis.prop(pair, "direction_object")
                    axis.prop(pair, "direction_axis", text="")


class SQUISH_PT_bake(_Sidebar, bpy.types.Panel):
    bl_label = "Bake"
    bl_idname = "SQUISH_PT_bake"
    bl_parent_id = "SQUISH_PT_scene"

    def draw(self, context):
        layout = self.layout
        settings = context.scene.squish
        row = layout.row(align=True)
        row.prop(settings, "bake_start")
        row.prop(settings, "bake_end")
        layout.prop(settings, "bake_target")
        if settings.bake_target == "POINT_CACHE":
            layout.prop(settings, "bake_directory")
        layout.prop(settings, "bake_threads")
        row = layout.row(align=True)
        row.operator("squish.bake", icon="RENDER_ANIMATION")
        row.operator("squish.bake_clear", icon="TRASH")


class SQUISH_PT_object(_ObjectProperties, bpy.types.Panel):
    bl_label = "Squish"
    bl_idname = "SQUISH_PT_object"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def draw(self, context):
        layout = self.layout
        obj = context.object
        settings = obj.squish
        schema_props.draw_level(layout, settings, "object", skip=_PER_VERTEX)
        for key in _PER_VERTEX:
            layout.prop_search(settings, key, obj, "vertex_groups")
        layout.prop_search(settings, "uv_map", obj.data, "uv_layers")
        box = layout.box()
        box.label(text="Profile curve (x of v2, v3, v4)")
        node = profile_curve.curve_node(obj)
        if node is not None:
            box.template_curve_mapping(node, "mapping")
        row = box.row(align=True)
        row.operator("squish.profile_curve_reset", text="Reset" if node is not None else "Edit Profile Curve")
        if node is not None:
            row.operator("squish.profile_curve_apply", text="Apply")


class SQUISH_PT_articulations(_ObjectProperties, bpy.types.Panel):
    bl_label = "Articulations (self-contact)"
    bl_idname = "SQUISH_PT_articulations"
    bl_parent_id = "SQUISH_PT_object"

    def draw(self, context):
        layout = self.layout
        obj = context.object
        layout.prop(obj.squish, "self_contact")
        if obj.squish.self_contact == "AUTO":
            armature = evaluate.object_armature(obj)
            layout.label(text=f"Skeleton of {armature.name}" if armature is not None else "No Armature modifier",
                         icon="ARMATURE_DATA" if armature is not None else "ERROR")
        layout.operator("squish.articulation_add", icon="ADD")
        for index, articulation in enumerate(obj.squish.articulations):
            box = layout.box()
            header = box.row(align=True)
            header.prop(articulation, "name", text="")
            header.operator("squish.articulation_remove", text="", icon="X").index = index
            box.prop(articulation, "source")
            if articulation.source == "BONES":
                box.prop(articulation, "armature")
                armature = articulation.armature or evaluate.object_armature(obj)
                if armature is not None and armature.type == "ARMATURE":
                    box.prop_search(articulation, "parent_bone", armature.data, "bones")
                    box.prop_search(articulation, "child_bone", armature.data, "bones")
            else:
                box.prop_search(articulation, "group_1", obj, "vertex_groups")
                box.prop_search(articulation, "group_2", obj, "vertex_groups")
            schema_props.draw_level(box, articulation, "articulation")


CLASSES = (SQUISH_PT_scene, SQUISH_PT_bake, SQUISH_PT_object, SQUISH_PT_articulations)
