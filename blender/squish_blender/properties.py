"""The add-on's data: per-object settings (`Object.squish`), contact pairs, articulations and
the bake settings (`Scene.squish`). Deformer parameters come from the schema (schema_props);
what is declared here is only how Blender picks objects, bones and files."""

from __future__ import annotations

import bpy

from . import live, schema_props


def _is_mesh(_self, obj) -> bool:
    return obj.type == "MESH"


def _is_armature(_self, obj) -> bool:
    return obj.type == "ARMATURE"


def _with_schema(name: str, level: str, own: dict) -> type:
    """A PropertyGroup class whose annotations are the schema's keys of `level` plus `own`."""
    generated = schema_props.properties_of(level, live.setting_changed)
    annotations = {**own, **generated}
    clash = set(own) & set(generated)
    if clash:
        raise TypeError(f"{name}: the add-on's own properties {sorted(clash)} clash with schema keys")
    return type(name, (bpy.types.PropertyGroup,), {"__annotations__": annotations})


_AXES = [(axis, axis, f"The object's {axis} axis (world space, at each frame)")
         for axis in ("X", "Y", "Z", "-X", "-Y", "-Z")]

SquishPair = _with_schema("SquishPair", "pair", {
    "object_a": bpy.props.PointerProperty(
        name="Object A", update=live.setting_changed, type=bpy.types.Object, poll=_is_mesh,
        description="First mesh object of the pair (pushed along the mapping direction)"),
    "object_b": bpy.props.PointerProperty(
        name="Object B", update=live.setting_changed, type=bpy.types.Object, poll=_is_mesh,
        description="Second mesh object of the pair; the mapping direction is oriented along its normals"),
    "direction_object": bpy.props.PointerProperty(
        name="Axis of", update=live.setting_changed, type=bpy.types.Object,
        description="With Set Direction on: take the direction from this object's axis (empty: the vector)"),
    "direction_axis": bpy.props.EnumProperty(name="Axis", items=_AXES, default="Z",
                                             update=live.setting_changed,
                                             description="Which axis of the object gives the mapping direction"),
    "show_expanded": bpy.props.BoolProperty(name="Show settings", default=True),
})

SquishArticulation = _with_schema("SquishArticulation", "articulation", {
    "name": bpy.props.StringProperty(name="Name", default="Articulation",
                                     description="Names the articulation in reports"),
    "source": bpy.props.EnumProperty(
        name="Regions from", default="BONES", update=live.setting_changed,
        items=[("BONES", "Bones", "Region 1: the parent bone's vertex group; region 2: the child bone's and its "
                "descendants' groups (skinning weights ≥ Min weight); direction from the posed bones"),
               ("GROUPS", "Vertex groups", "Regions from two vertex groups (weights ≥ 0.5); needs a direction")]),
    "armature": bpy.props.PointerProperty(
        name="Armature", update=live.setting_changed, type=bpy.types.Object, poll=_is_armature,
        description="The armature whose bones bend here (empty: the object's Armature modifier's)"),
    "parent_bone": bpy.props.StringProperty(name="Parent bone", update=live.setting_changed,
                                          description="The bone before the joint (thigh)"),
    "child_bone": bpy.props.StringProperty(name="Child bone", update=live.setting_changed,
                                         description="The bone after the joint (shin)"),
    "group_1": bpy.props.StringProperty(name="Region 1 group", update=live.setting_changed,
                                      description="Vertex group of the parent side"),
    "group_2": bpy.props.StringProperty(name="Region 2 group", update=live.setting_changed,
                                      description="Vertex group of the child side"),
})

SquishObject = _with_schema("SquishObject", "object", {
    "articulations": bpy.props.CollectionProperty(type=SquishArticulation),
    "active_articulation": bpy.props.IntProperty(name="Active articulation", default=0, min=0),
    "self_contact": bpy.props.EnumProperty(
        name="Self-contact", default="OFF", update=live.setting_changed,
        items=[("OFF", "Off", "Only the articulations listed below"),
               ("AUTO", "Auto", "Every articulation of the armature's skeleton and the contacts between the skin's "
                "parts (a scene file's self_contact = \"auto\", thesis ch. 6): the skin is read from the Armature "
                "modifier's armature and the bones' vertex groups")]),
    "uv_map": bpy.props.StringProperty(
        name="UV map", default="", update=live.setting_changed,
        description="The UV map a pair with the shared-parametrization mapping (method A, thesis §4.2.1) matches "
                    "the meshes in; empty: the active render UV map"),
})


class SquishScene(bpy.types.PropertyGroup):
    pairs: bpy.props.CollectionProperty(type=SquishPair)
    active_pair: bpy.props.IntProperty(name="Active pair", default=0, min=0)
    live: bpy.props.BoolProperty(
        name="Live", default=False, options=set(), update=live.live_switched,
        description="Live mode: show the current frame's deformation while scrubbing and editing (the Live "
                    "button, or set from a script)")
    bake_start: bpy.props.IntProperty(name="Start", default=1, description="First frame to bake")
    bake_end: bpy.props.IntProperty(name="End", default=250, description="Last frame to bake")
    bake_target: bpy.props.EnumProperty(
        name="Bake to", default="SHAPE_KEYS",
        items=[("SHAPE_KEYS", "Shape keys", "One shape key per frame, keyed to show at its frame (objects "
                "without modifiers)"),
               ("POINT_CACHE", "Point cache", "One .pc2 file per object read by a Mesh Cache modifier (any "
                "object, e.g. skinned characters)")])
    bake_directory: bpy.props.StringProperty(
        name="Cache folder", subtype="DIR_PATH", default="//squish_cache/",
        description="Where the .pc2 files are written (// is the .blend file's folder)")
    bake_threads: bpy.props.IntProperty(
        name="Parallel frames", default=2, min=1, max=64,
        description="Frames deformed at the same time (each on one thread)")


CLASSES = (SquishPair, SquishArticulation, SquishObject, SquishScene)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Object.squish = bpy.props.PointerProperty(type=SquishObject)
    bpy.types.Scene.squish = bpy.props.PointerProperty(type=SquishScene)


def unregister() -> None:
    del bpy.types.Scene.squish
    del bpy.types.Object.squish
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
