"""The panels' draw code, run against a recording layout (Blender draws no panel without a
window): every property drawn exists on its data, every operator button is a registered
operator, and every schema key of each level is drawn."""

from __future__ import annotations

import bpy
import squish
from conftest import clear_scene, sphere, subdivided_cube


class _Button:
    """What `layout.operator` returns: operator properties are set on it."""

    def __init__(self, idname: str):
        self.idname = idname


class RecordingLayout:
    """Stands in for bpy.types.UILayout: records the properties and operators drawn, checking
    each against Blender's RNA."""

    def __init__(self, record=None):
        self.record = record if record is not None else {"props": [], "operators": []}
        self.active = True

    def _child(self, *_args, **_kwargs):
        return RecordingLayout(self.record)

    row = column = box = split = _child

    def prop(self, data, name, **_kwargs):
        assert name in data.bl_rna.properties, f"{data.bl_rna.identifier} has no property {name!r}"
        self.record["props"].append((data.bl_rna.identifier, name))

    def prop_search(self, data, name, search_data, search_name, **_kwargs):
        self.prop(data, name)
        assert search_name in search_data.bl_rna.properties, search_name

    def operator(self, idname, **_kwargs):
        group, name = idname.split(".")
        assert hasattr(getattr(bpy.ops, group), name), idname
        self.record["operators"].append(idname)
        return _Button(idname)

    def label(self, **_kwargs):
        pass

    def template_curve_mapping(self, data, name, **_kwargs):
        assert name in data.bl_rna.properties, name


class _Context:
    def __init__(self, **values):
        self.__dict__.update(values)


def _draw(panel_type, context) -> dict:
    # A Panel cannot be made outside Blender's drawing; its draw only needs `self.layout`.
    layout = RecordingLayout()
    panel_type.draw(_Context(layout=layout), context)
    return layout.record


def _keys(level: str) -> set[str]:
    return {row["key"] for row in squish.params_schema() if row["level"] == level}


def test_panels_draw_every_schema_key(addon):
    clear_scene(addon)
    ball = sphere("Ball", 0.6, (0.0, 0.0, 1.35))
    box = subdivided_cube("Box", 2.0, (0.0, 0.0, 0.0))
    scene = bpy.context.scene
    pair = scene.squish.pairs.add()
    pair.object_a, pair.object_b = ball, box
    pair.use_direction = True
    bpy.context.view_layer.objects.active = ball
    bpy.ops.squish.articulation_add()
    bpy.ops.squish.profile_curve_reset()
    context = _Context(scene=scene, object=ball, active_object=ball)
    drawn = _draw(bpy.types.SQUISH_PT_scene, context)
    assert _keys("pair") <= {name for owner, name in drawn["props"] if owner == "SquishPair"}
    assert {"squish.live", "squish.pair_add", "squish.pair_remove"} <= set(drawn["operators"])
    drawn = _draw(bpy.types.SQUISH_PT_bake, context)
    assert {"squish.bake", "squish.bake_clear"} <= set(drawn["operators"])
    drawn = _draw(bpy.types.SQUISH_PT_object, context)
    assert _keys("object") <= {name for owner, name in drawn["props"] if owner == "SquishObject"}
    assert {"squish.profile_curve_reset", "squish.profile_curve_apply"} <= set(drawn["operators"])
    for source in ("BONES", "GROUPS"):
        ball.squish.articulations[0].source = source
        drawn = _draw(bpy.types.SQUISH_PT_articulations, context)
        assert _keys("articulation") <= {name for owner, name in drawn["props"] if owner == "SquishArticulation"}
