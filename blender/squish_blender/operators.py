"""Operators: pairs and articulations, live mode, bake. Every problem the user can fix is a
one-line report (object, problem, fix); every operator is undoable."""

from __future__ import annotations

import functools

import bpy

from . import bake, evaluate, live, profile_curve
from .evaluate import SetupError

UNDOABLE = {"REGISTER", "UNDO"}


def _report_failure(operator, call) -> set[str]:
    try:
        return call()
    except SetupError as error:
        operator.report({"ERROR"}, str(error))
    except Exception as error:  # noqa: BLE001 - reported to the user, never swallowed
        operator.report({"ERROR"}, f"Squish: unexpected {type(error).__name__}: {error}; please report it "
                        "with the .blend file")
    return {"CANCELLED"}


def reported(method):
    """Wraps an operator's execute or invoke: an unexpected exception becomes a one-line error
    report (the operator is cancelled) instead of a traceback in Blender's interface. Blender
    checks the number of arguments of these methods, so each arity has its own wrapper."""
    if method.__code__.co_argcount == 2:

        def execute(self, context):
            return _report_failure(self, lambda: method(self, context))

        return functools.wraps(method)(execute)

    def invoke(self, context, event):
        return _report_failure(self, lambda: method(self, context, event))

    return functools.wraps(method)(invoke)


class SQUISH_OT_pair_add(bpy.types.Operator):
    """Add a contact pair: the two selected mesh objects (the active one second), or an empty pair"""

    bl_idname = "squish.pair_add"
    bl_label = "Add Pair"
    bl_options = UNDOABLE

    @reported
    def execute(self, context):
        pair = context.scene.squish.pairs.add()
        selected = [o for o in context.selected_objects if o.type == "MESH"]
        active = context.active_object
        if len(selected) == 2 and active in selected:
            pair.object_a = next(o for o in selected if o != active)
            pair.object_b = active
        context.scene.squish.active_pair = len(context.scene.squish.pairs) - 1
        return {"FINISHED"}


class SQUISH_OT_pair_remove(bpy.types.Operator):
    """Remove a contact pair"""

    bl_idname = "squish.pair_remove"
    bl_label = "Remove Pair"
    bl_options = UNDOABLE

    index: bpy.props.IntProperty(name="Index", min=0)

    @reported
    def execute(self, context):
        pairs = context.scene.squish.pairs
        if self.index >= len(pairs):
            self.report({"ERROR"}, f"Pair {self.index + 1}: there are {len(pairs)} pairs; pick an existing one")
            return {"CANCELLED"}
        pairs.remove(self.index)
        return {"FINISHED"}


class SQUISH_OT_articulation_add(bpy.types.Operator):
    """Add a self-contact articulation to the active mesh object"""

    bl_idname = "squish.articulation_add"
    bl_label = "Add Articulation"
    bl_options = UNDOABLE

    @reported
    def execute(self, context):
        obj = context.active_object
        if obj is None or obj.type != "MESH":
            name = obj.name if obj is not None else "No active object"
            self.report({"ERROR"}, f"{name}: articulations belong to mesh objects; make a mesh object active")
            return {"CANCELLED"}
        articulation = obj.squish.articulations.add()
        articulation.name = f"Articulation {len(obj.squish.articulations)}"
        armature = evaluate.object_armature(obj)
        if armature is not None:
            articulation.armature = armature
        else:
            articulation.source = "GROUPS"
        obj.squish.active_articulation = len(obj.squish.articulations) - 1
        return {"FINISHED"}


class SQUISH_OT_articulation_remove(bpy.types.Operator):
    """Remove an articulation of the active object"""

    bl_idname = "squish.articulation_remove"
    bl_label = "Remove Articulation"
    bl_options = UNDOABLE

    index: bpy.props.IntProperty(name="Index", min=0)

    @reported
    def execute(self, context):
        obj = context.active_object
        if obj is None or obj.type != "MESH" or self.index >= len(obj.squish.articulations):
            self.report({"ERROR"}, "Articulation: no such articulation on the active object; pick an existing one")
            return {"CANCELLED"}
        obj.squish.articulations.remove(self.index)
        return {"FINISHED"}


class SQUISH_OT_live(bpy.types.Operator):
    """Switch live mode: show the current frame's contact deformation while scrubbing and editing"""

    bl_idname = "squish.live"
    bl_label = "Live Mode"
    bl_options = UNDOABLE

    enable: bpy.props.BoolProperty(name="Enable", default=True)

    @reported
    def execute(self, context):
        scene = context.scene
        if not self.enable:
            live.disable(scene)
            return {"FINISHED"}
        try:
            live.enable(scene)
        except SetupError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        depsgraph = context.evaluated_depsgraph_get()
        # Evaluating the new modifiers may already run the update handler, which evaluates the
        # frame; refresh then finds nothing changed and the result is the handler's.
        depsgraph.update()
        live.refresh(scene, depsgraph)
        if scene.name not in live.last_result:
            message = live.status.get(scene.name, "")
            live.disable(scene)
            self.report({"ERROR"}, message.removeprefix("Error: ") or "Squish: live mode could not evaluate the frame")
            return {"CANCELLED"}
        warned = bool(live.last_result[scene.name].warnings)
        self.report({"WARNING"} if warned else {"INFO"}, f"Squish live: {live.status[scene.name]}")
        return {"FINISHED"}


class SQUISH_OT_bake(bpy.types.Operator):
    """Bake the contact deformation over the frame range (Esc cancels)"""

    bl_idname = "squish.bake"
    bl_label = "Bake"
    bl_options = UNDOABLE

    _bake = None
    _timer = None

    def _start(self, context) -> bool:
        try:
            self._bake = bake.Bake(context)
        except SetupError as error:
            self.report({"ERROR"}, str(error))
            return False
        return True

    def _finish(self, context):
        report = self._bake.finish()
        warned = report["failed_frames"] or any(entry["warnings"] for entry in report["per_frame"])
        level = {"WARNING"} if warned else {"INFO"}
        self.report(level, self._bake.summary())
        return {"FINISHED"}

    @reported
    def execute(self, context):
        # Whole bake at once: scripts, tests, and Blender run in the background.
        if not self._start(context):
            return {"CANCELLED"}
        self._bake.run()
        return self._finish(context)

    @reported
    def invoke(self, context, event):
        if not self._start(context):
            return {"CANCELLED"}
        window_manager = context.window_manager
        self._timer = window_manager.event_timer_add(0.001, window=context.window)
        window_manager.progress_begin(0, len(self._bake.frames))
        window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        try:
            return self._modal_step(context, event)
        except Exception as error:  # noqa: BLE001 - reported to the user, never swallowed
            # The timer and progress bar go with the bake; nothing was written.
            self._stop(context)
            self._bake.cancel()
            self.report({"ERROR"}, f"Squish: bake stopped by an unexpected {type(error).__name__}: {error}; "
                        "nothing was written; please report it with the .blend file")
            return {"CANCELLED"}

    def _modal_step(self, context, event):
        window_manager = context.window_manager
        if event.type == "ESC":
            self._stop(context)
            self._bake.cancel()
            self.report({"WARNING"}, f"Squish: bake cancelled after {self._bake.done} of "
                        f"{len(self._bake.frames)} frames; nothing was written")
            return {"CANCELLED"}
        if event.type == "TIMER":
            done = self._bake.step()
            window_manager.progress_update(self._bake.done)
            if context.area is not None:
                context.area.header_text_set(f"Squish bake: {self._bake.done}/{len(self._bake.frames)} frames "
                                             "(Esc to cancel)")
            if done:
                self._stop(context)
                return self._finish(context)
        return {"RUNNING_MODAL"}

    def _stop(self, context):
        window_manager = context.window_manager
        if self._timer is not None:
            window_manager.event_timer_remove(self._timer)
            self._timer = None
        window_manager.progress_end()
        if context.area is not None:
            context.area.header_text_set(None)


class SQUISH_OT_bake_clear(bpy.types.Operator):
    """Remove the baked shape keys and point cache modifiers of the setup's objects"""

    bl_idname = "squish.bake_clear"
    bl_label = "Clear Bake"
    bl_options = UNDOABLE

    @reported
    def execute(self, context):
        for obj in evaluate.participants(context.scene):
            if obj.type == "MESH":
                bake.remove_bake(obj)
        return {"FINISHED"}


CLASSES = (
    SQUISH_OT_pair_add,
    SQUISH_OT_pair_remove,
    SQUISH_OT_articulation_add,
    SQUISH_OT_articulation_remove,
    SQUISH_OT_live,
    SQUISH_OT_bake,
    SQUISH_OT_bake_clear,
    *profile_curve.OPERATORS,
)
