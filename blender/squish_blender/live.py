"""Live mode: the current frame's deformation shown while scrubbing or editing.

Why a Geometry Nodes modifier and not a shape key: the input is the evaluated mesh (armature and
other modifiers applied), and shape keys act before the modifiers, so a shape key holding the
result would be moved again by the armature. The add-on appends one modifier ("Squish live") at
the end of each object's stack, running a node group that (1) stores the stack's positions in
the attribute `squish_input`, which the add-on reads as its input, then (2) sets the positions
to the attribute `squish_position` when the mesh has it. The result is written to that attribute
on the mesh; the mesh's own positions are never written. Turning live mode off removes the
modifier, the attribute and the node group, which gives back the original exactly.

Evaluated once per change: each evaluation is fingerprinted (frame inputs, parameters), so the
depsgraph update that writing the result causes, and any update that changes nothing the
deformer reads, is skipped.
"""

from __future__ import annotations

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import evaluate
from .evaluate import INPUT_ATTRIBUTE, LIVE_MODIFIER, SetupError

RESULT_ATTRIBUTE = "squish_position"
NODE_GROUP = "Squish live"

# Per scene (by name): the last fingerprint evaluated and the status line the panel shows.
# Module state, not Blender data: writing Blender data here would itself be an undo step and a
# depsgraph update.
_last_fingerprint: dict[str, int] = {}
status: dict[str, str] = {}
# The last result per scene, float64 (what the mesh shows at 32-bit precision): for scripts and tests.
last_result: dict[str, "evaluate.FrameResult"] = {}
_running = False
# True while enable/disable set `scene.squish.live` themselves (its update callback then does nothing).
_switching = False


def _set_live(scene, value: bool) -> None:
    global _switching
    _switching = True
    try:
        scene.squish.live = value
    finally:
        _switching = False


def _node_group() -> bpy.types.NodeTree:
    group = bpy.data.node_groups.get(NODE_GROUP)
    if group is not None and group.bl_idname == "GeometryNodeTree":
        return group
    group = bpy.data.node_groups.new(NODE_GROUP, "GeometryNodeTree")
    group.interface.new_socket(name="Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket(name="Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = group.nodes, group.links
    group_in, group_out = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    store = nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type, store.domain = "FLOAT_VECTOR", "POINT"
    store.inputs["Name"].default_value = INPUT_ATTRIBUTE
    position = nodes.new("GeometryNodeInputPosition")
    result = nodes.new("GeometryNodeInputNamedAttribute")
    result.data_type = "FLOAT_VECTOR"
    result.inputs["Name"].default_value = RESULT_ATTRIBUTE
    set_position = nodes.new("GeometryNodeSetPosition")
    links.new(group_in.outputs["Geometry"], store.inputs["Geometry"])
    links.new(position.outputs["Position"], store.inputs["Value"])
    links.new(store.outputs["Geometry"], set_position.inputs["Geometry"])
    links.new(result.outputs["Exists"], set_position.inputs["Selection"])
    links.new(result.outputs["Attribute"], set_position.inputs["Position"])
    links.new(set_position.outputs["Geometry"], group_out.inputs["Geometry"])
    for x, node in enumerate((group_in, position, store, result, set_position, group_out)):
        node.location = (200 * x, 0)
    return group


def _has_live_modifier(obj) -> bool:
    modifier = obj.modifiers.get(LIVE_MODIFIER)
    return modifier is not None and modifier.type == "NODES"


def enable(scene) -> list[bpy.types.Object]:
    """Adds the live modifier to every object of the setup (raises SetupError)."""
    objects = evaluate.check_setup(scene)
    for obj in objects:
        if evaluate.baked_by_squish(obj):
            raise SetupError(f"{obj.name}: shows a Squish bake, which live mode would deform again; press Clear "
                             "Bake first")
    group = _node_group()
    for obj in objects:
        if not _has_live_modifier(obj):
            modifier = obj.modifiers.new(LIVE_MODIFIER, "NODES")
            modifier.node_group = group
    _set_live(scene, True)
    _last_fingerprint.pop(scene.name, None)
    return objects


def _clear_object(obj) -> None:
    modifier = obj.modifiers.get(LIVE_MODIFIER)
    if modifier is not None and modifier.type == "NODES":
        obj.modifiers.remove(modifier)
    if obj.type == "MESH":
        attribute = obj.data.attributes.get(RESULT_ATTRIBUTE)
        if attribute is not None:
            obj.data.attributes.remove(attribute)


def disable(scene) -> None:
    """Removes every trace of live mode: modifiers, result attributes, the node group."""
    for obj in scene.objects:
        _clear_object(obj)
    group = bpy.data.node_groups.get(NODE_GROUP)
    if group is not None and group.users == 0:
        bpy.data.node_groups.remove(group)
    _set_live(scene, False)
    _last_fingerprint.pop(scene.name, None)
    status.pop(scene.name, None)
    last_result.pop(scene.name, None)


def _write_result(obj, positions: np.ndarray) -> None:
    mesh = obj.data
    attribute = mesh.attributes.get(RESULT_ATTRIBUTE)
    if attribute is None or attribute.domain != "POINT" or attribute.data_type != "FLOAT_VECTOR":
        if attribute is not None:
            mesh.attributes.remove(attribute)
        attribute = mesh.attributes.new(RESULT_ATTRIBUTE, "FLOAT_VECTOR", "POINT")
    attribute.data.foreach_set("vector", positions.astype(np.float32).ravel())
    mesh.update()


def _clear_results(scene) -> None:
    for obj in scene.objects:
        if obj.type == "MESH" and _has_live_modifier(obj):
            attribute = obj.data.attributes.get(RESULT_ATTRIBUTE)
            if attribute is not None:
                obj.data.attributes.remove(attribute)
                obj.data.update()


def refresh(scene, depsgraph, force: bool = False) -> evaluate.FrameResult | None:
    """Evaluates the current frame if anything the deformer reads changed; returns the result
    (None when skipped or failed; the failure is in `status`)."""
    global _running
    if _running or not scene.squish.live:
        return None
    _running = True
    try:
        try:
            frame_input = evaluate.gather(scene, depsgraph)
            for obj in evaluate.participants(scene):
                if not _has_live_modifier(obj):
                    raise SetupError(f"{obj.name}: joined the setup while live mode was on; switch live mode "
                                     "off and on again")
            if not force and _last_fingerprint.get(scene.name) == frame_input.fingerprint:
                return None
            _last_fingerprint[scene.name] = frame_input.fingerprint
            result = evaluate.deform(frame_input)
        except SetupError as error:
            # Shown in the panel; the meshes show their input until the setup is fixed.
            status[scene.name] = f"Error: {error}"
            _last_fingerprint.pop(scene.name, None)
            _clear_results(scene)
            return None
        for name, positions in result.local_positions.items():
            _write_result(scene.objects[name], positions)
        status[scene.name] = f"Frame {result.frame}: {result.seconds * 1000:.0f} ms"
        if result.warnings:
            count = len(result.warnings)
            status[scene.name] += f"; {count} warning{'s' if count > 1 else ''}: {result.warnings[0]}"
        last_result[scene.name] = result
        return result
    finally:
        _running = False


def _refresh_from_handler(scene, depsgraph) -> None:
    # A handler has no operator to report through: anything unexpected goes to the panel's
    # status line (and the console) instead of stopping Blender's handler chain.
    try:
        refresh(scene, depsgraph)
    except Exception as error:  # noqa: BLE001 - shown to the user, never swallowed
        status[scene.name] = f"Error: {type(error).__name__}: {error}"
        print(f"Squish live mode: {status[scene.name]}")


def setting_changed(_settings, context) -> None:
    """Update callback of every Squish setting: Blender runs no depsgraph update when an add-on's
    property is edited, so the frame is evaluated again here if live mode is on."""
    scene = context.scene
    if scene is not None and scene.squish.live:
        _refresh_from_handler(scene, context.evaluated_depsgraph_get())


def live_switched(settings, context) -> None:
    """Update callback of `Scene.squish.live`: setting it (the Live button, or a script's
    `scene.squish.live = True`) switches live mode on or off. A setup that cannot be evaluated
    leaves it off, with the reason in the status line (and the console: a script has no report)."""
    if _switching:
        return
    scene = settings.id_data
    if not settings.live:
        disable(scene)
        return
    try:
        enable(scene)
    except SetupError as error:
        status[scene.name] = f"Error: {error}"
        print(f"Squish live mode: {status[scene.name]}")
        _set_live(scene, False)
        return
    depsgraph = context.evaluated_depsgraph_get()
    depsgraph.update()
    last_result.pop(scene.name, None)
    refresh(scene, depsgraph, force=True)
    if scene.name not in last_result:
        message = status.get(scene.name, "Error: live mode could not evaluate the frame")
        disable(scene)
        status[scene.name] = message
        print(f"Squish live mode: {message}")


@persistent
def on_frame_change(scene, depsgraph) -> None:
    if scene.squish.live:
        _refresh_from_handler(scene, depsgraph)


@persistent
def on_depsgraph_update(scene, depsgraph) -> None:
    if scene.squish.live:
        _refresh_from_handler(scene, depsgraph)


@persistent
def on_data_replaced(*_args) -> None:
    # Undo, redo and file loads put back data whose result attribute may belong to other
    # inputs than the fingerprint remembers: the next update evaluates again.
    _last_fingerprint.clear()


_HANDLERS = (
    ("frame_change_post", on_frame_change),
    ("depsgraph_update_post", on_depsgraph_update),
    ("undo_post", on_data_replaced),
    ("redo_post", on_data_replaced),
    ("load_post", on_data_replaced),
)


def register() -> None:
    for name, handler in _HANDLERS:
        getattr(bpy.app.handlers, name).append(handler)


def unregister() -> None:
    for name, handler in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if handler in handlers:
            handlers.remove(handler)
