"""The profile curve (thesis §5.4.1, Fig. 5.4) edited with Blender's curve widget.

Blender's curve widget edits a CurveMapping, which only some data own; the add-on keeps one
Float Curve node per object in a node group of its own ("Squish profiles") and draws that
node's curve. The widget shows the profile's control points in a unit box: v0 = (0, 0) the
contact depth, v2 = (x2, 1) the bulge's peak, v3, v4 and v5 = (1, ½) the rest surface. Only the
abscissas of v2, v3 and v4 are the user's (`profile_v2..4`, keyframable properties); the
ordinates are solved by the deformer, so "Apply" reads the three abscissas back and "Reset"
redraws the curve from the properties.
"""

from __future__ import annotations

import bpy

NODE_GROUP = "Squish profiles"
_PEAK, _REST = 1.0, 0.5
# The schema's bounds of the three abscissas (in (0.2, 1), strictly increasing).
_LOW, _HIGH = 0.2, 1.0


def _group():
    group = bpy.data.node_groups.get(NODE_GROUP)
    if group is None or group.bl_idname != "ShaderNodeTree":
        group = bpy.data.node_groups.new(NODE_GROUP, "ShaderNodeTree")
    return group


def curve_node(obj, create: bool = False):
    """The Float Curve node holding an object's profile widget (None if not created yet)."""
    group = bpy.data.node_groups.get(NODE_GROUP)
    if group is None and not create:
        return None
    group = group if group is not None else _group()
    node = group.nodes.get(obj.name)
    if node is None and create:
        node = group.nodes.new("ShaderNodeFloatCurve")
        node.name = obj.name
    return node


def _points_of(settings) -> list[tuple[float, float]]:
    return [(0.0, 0.0), (settings.profile_v2, _PEAK), (settings.profile_v3, _REST),
            (settings.profile_v4, _REST), (1.0, _REST)]


def reset(obj) -> None:
    """Redraws an object's widget from its profile properties."""
    node = curve_node(obj, create=True)
    curve = node.mapping.curves[0]
    wanted = _points_of(obj.squish)
    while len(curve.points) > len(wanted):
        curve.points.remove(curve.points[-1])
    while len(curve.points) < len(wanted):
        curve.points.new(1.0, _REST)
    for point, (x, y) in zip(curve.points, wanted):
        point.location = (x, y)
    node.mapping.clip_min_x, node.mapping.clip_max_x = 0.0, 1.0
    node.mapping.update()


def abscissas(obj) -> tuple[float, float, float]:
    """The abscissas of v2, v3, v4 as drawn in the widget (raises ValueError with the fix)."""
    node = curve_node(obj)
    if node is None:
        raise ValueError(f"{obj.name}: has no profile curve yet; press Edit Profile Curve first")
    points = sorted(p.location[0] for p in node.mapping.curves[0].points)
    if len(points) != 5:
        raise ValueError(f"{obj.name}: the profile curve has {len(points)} points, the profile has 5 (v0, v2, v3, "
                         "v4, v5); press Reset and move the three middle points")
    middle = points[1:4]
    if not (_LOW < middle[0] < middle[1] < middle[2] < _HIGH):
        shown = ", ".join(f"{x:.3f}" for x in middle)
        raise ValueError(f"{obj.name}: the profile's middle points are at x = {shown}; keep them apart and "
                         f"within ({_LOW}, {_HIGH})")
    return middle[0], middle[1], middle[2]


def _active_mesh(operator, context):
    """The active object if it is a mesh; else reports the problem and returns None."""
    obj = context.active_object
    if obj is None or obj.type != "MESH":
        operator.report({"ERROR"}, "Profile curve: the active object is not a mesh; select a mesh object")
        return None
    return obj


class SQUISH_OT_profile_curve_reset(bpy.types.Operator):
    """Show the active object's profile control points in the curve widget"""

    bl_idname = "squish.profile_curve_reset"
    bl_label = "Edit Profile Curve"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj = _active_mesh(self, context)
        if obj is None:
            return {"CANCELLED"}
        reset(obj)
        return {"FINISHED"}


class SQUISH_OT_profile_curve_apply(bpy.types.Operator):
    """Set the profile's abscissas v2, v3, v4 from the curve widget's middle points"""

    bl_idname = "squish.profile_curve_apply"
    bl_label = "Apply Profile Curve"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj = _active_mesh(self, context)
        if obj is None:
            return {"CANCELLED"}
        try:
            v2, v3, v4 = abscissas(obj)
        except ValueError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        obj.squish.profile_v2, obj.squish.profile_v3, obj.squish.profile_v4 = v2, v3, v4
        reset(obj)
        return {"FINISHED"}


OPERATORS = (SQUISH_OT_profile_curve_reset, SQUISH_OT_profile_curve_apply)
