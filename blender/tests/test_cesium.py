"""CesiumMan (shared test data) imported with Blender's glTF importer: knee articulations picked
from its bones, its walk baked to a point cache; the self-intersecting faces at the knees are
counted with the exact test of `squish info` before and after."""

from __future__ import annotations

import json

import bpy
import demo_scenes
import numpy as np
import pytest
import squish
from conftest import SHARED_DATA, clear_scene, positions, triangles
from demo_scenes import KNEES

CESIUM_MAN = SHARED_DATA / "rigged" / "CesiumMan.glb"


def _knee_faces(obj, tris: np.ndarray) -> np.ndarray:
    """The faces of the knees' regions, by the add-on's rule (docs/blender.md): region 1 the
    thigh's skinning weight ≥ 0.05, region 2 the summed weights of the shin and the bones below
    it ≥ 0.05; where the articulations act, as `squish run`'s report counts them."""
    weights = {g.name: np.zeros(len(obj.data.vertices)) for g in obj.vertex_groups}
    names = {g.index: g.name for g in obj.vertex_groups}
    for vertex in obj.data.vertices:
        for element in vertex.groups:
            weights[names[element.group]][vertex.index] = element.weight
    armature = obj.find_armature()
    inside = np.zeros(len(obj.data.vertices), dtype=bool)
    for parent, child in KNEES.values():
        bone = armature.data.bones[child]
        below = sum(weights[b.name] for b in [bone, *bone.children_recursive] if b.name in weights)
        inside |= (weights[parent] >= 0.05) | (below >= 0.05)
    return tris[inside[tris].all(axis=1)]


def _self_intersecting(local: np.ndarray, faces: np.ndarray) -> int:
    return squish.Mesh(local, faces).self_intersecting_faces()


@pytest.fixture
def cesium_man(addon):
    """CesiumMan imported, welded, with both knees set from its bones; returns the mesh object."""
    if not CESIUM_MAN.is_file():
        pytest.skip(f"{CESIUM_MAN} is absent (shared test data)")
    clear_scene(addon)
    man = demo_scenes.cesium_man(CESIUM_MAN)
    assert len(man.data.vertices) == 2338
    assert all(a.source == "BONES" and a.armature.type == "ARMATURE" for a in man.squish.articulations)
    return man


def test_cesium_man_knees_baked_over_the_walk(cesium_man, tmp_path):
    man = cesium_man
    scene = bpy.context.scene
    scene.squish.bake_start, scene.squish.bake_end = 1, 48
    scene.squish.bake_target = "POINT_CACHE"
    scene.squish.bake_directory = str(tmp_path)
    tris = triangles(man)
    knee_faces = _knee_faces(man, tris)
    before = []
    for frame in range(1, 49):
        scene.frame_set(frame)
        before.append(_self_intersecting(positions(man, evaluated=True), knee_faces))
    assert bpy.ops.squish.bake() == {"FINISHED"}
    report = json.loads(bpy.data.texts["Squish bake report"].as_string())
    assert report["failed_frames"] == {}
    after = []
    for frame in range(1, 49):
        scene.frame_set(frame)
        after.append(_self_intersecting(positions(man, evaluated=True), knee_faces))
    print(f"CesiumMan knees, self-intersecting faces over 48 frames: {sum(before)} before, {sum(after)} after; "
          f"per frame before {before}, after {after}")
    assert sum(before) > 0
    assert sum(after) == 0
    # The deformer's own count over the articulations' regions agrees.
    for entry in report["per_frame"]:
        for name, (_, faces_after) in entry["self_intersecting_faces"].items():
            assert faces_after == 0, (entry["frame"], name)


def test_cesium_man_live_after_the_armature(addon, cesium_man):
    """Live mode on a skinned mesh: the result is shown after the armature (not deformed again),
    and switching it off gives back the armature's pose exactly."""
    man = cesium_man
    scene = bpy.context.scene
    scene.frame_set(9)  # the left knee folds furthest
    posed = positions(man, evaluated=True)
    knee_faces = _knee_faces(man, triangles(man))
    assert _self_intersecting(posed, knee_faces) > 0
    assert bpy.ops.squish.live(enable=True) == {"FINISHED"}
    result = addon.live.last_result[scene.name].local_positions[man.name]
    shown = positions(man, evaluated=True)
    assert np.abs(shown - result).max() < 1e-5
    assert _self_intersecting(shown, knee_faces) == 0
    assert bpy.ops.squish.live(enable=False) == {"FINISHED"}
    assert np.array_equal(positions(man, evaluated=True), posed)


def test_cesium_man_bad_articulations_are_reported(addon, cesium_man):
    articulation = cesium_man.squish.articulations[0]
    articulation.child_bone = "leg_joint_L_3"
    with pytest.raises(RuntimeError, match='"leg_joint_L_3" is not a child of "leg_joint_L_1"; pick one of its '
                                           "children \\(leg_joint_L_2\\)"):
        bpy.ops.squish.live(enable=True)
    articulation.child_bone = "leg_joint_L_2"
    articulation.source = "GROUPS"
    articulation.group_1, articulation.group_2 = "leg_joint_L_1", "knee pads"
    with pytest.raises(RuntimeError, match='vertex group "knee pads" \\(region 2\\) does not exist'):
        bpy.ops.squish.live(enable=True)
    assert not bpy.context.scene.squish.live
