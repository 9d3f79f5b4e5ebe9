"""Issue 38 in the add-on: live mode switched from a script, the shared-parametrization mapping
from an object's UV map (seams included), and self-contact "Auto" on CesiumMan imported with
Blender's glTF importer, live and baked."""

from __future__ import annotations

import json

import bpy
import demo_scenes
import numpy as np
import pytest
import squish
from conftest import SHARED_DATA, clear_scene, positions, sphere, subdivided_cube, triangles, world

CESIUM_MAN = SHARED_DATA / "rigged" / "CesiumMan.glb"
# The UVs project the surface along this direction: the shared parametrization matches along it.
SLANT = np.array([0.45, 0.0, 1.0]) / np.linalg.norm([0.45, 0.0, 1.0])


def _projection(points: np.ndarray) -> np.ndarray:
    e1 = np.cross(SLANT, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(SLANT, e1)
    return np.stack([points @ e1, points @ e2], axis=1)


def _set_uvs(obj, chart=None) -> np.ndarray:
    """A UV map "Projected" on `obj`: each loop's world position projected along SLANT; the faces
    `chart` selects (by world centroid) in another chart (rotated, scaled, moved: a seam). Returns
    the corner UVs per loop triangle, (m, 3, 2)."""
    mesh = obj.data
    layer = mesh.uv_layers.new(name="Projected")
    loop_vertices = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", loop_vertices)
    points = world(obj, positions(obj))
    uv = _projection(points[loop_vertices])
    if chart is not None:
        for polygon in mesh.polygons:
            loops = list(polygon.loop_indices)
            if chart(points[loop_vertices[loops]].mean(axis=0)):
                c, s = np.cos(1.1), np.sin(1.1)
                uv[loops] = uv[loops] @ np.array([[c, s], [-s, c]]) * 0.6 + [4.0, 2.0]
    layer.uv.foreach_set("vector", uv.astype(np.float32).ravel())
    mesh.calc_loop_triangles()
    tri_loops = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", tri_loops)
    stored = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    layer.uv.foreach_get("vector", stored)
    return stored.reshape(-1, 2).astype(np.float64)[tri_loops].reshape(-1, 3, 2)


@pytest.fixture
def pressed(addon):
    """A rigid ball pressed into a subdivided slab, one pair."""
    clear_scene(addon)
    ball = sphere("Ball", 0.6, (0.0, 0.0, 1.3), subdivisions=4)
    slab = subdivided_cube("Slab", 2.0, (0.0, 0.0, 0.0), cuts=20)
    ball.squish.rigid = True
    pair = bpy.context.scene.squish.pairs.add()
    pair.object_a, pair.object_b = ball, slab
    return bpy.context.scene


def test_live_mode_is_switched_by_setting_the_property(addon, pressed):
    scene = pressed
    scene.squish.live = True  # what a script does, no operator
    assert all(o.modifiers.get(addon.evaluate.LIVE_MODIFIER) for o in scene.objects)
    result = addon.live.last_result[scene.name]
    assert result.report["pairs"][0]["in_contact"]
    slab = scene.objects["Slab"]
    assert np.abs(positions(slab, evaluated=True) - result.local_positions["Slab"]).max() < 1e-5
    scene.squish.live = False
    assert not any(o.modifiers.get(addon.evaluate.LIVE_MODIFIER) for o in scene.objects)
    assert scene.name not in addon.live.last_result
    # A setup that cannot be evaluated leaves it off, with the reason in the status line.
    scene.squish.pairs[0].object_b = None
    scene.squish.live = True
    assert not scene.squish.live
    assert "has no second object" in addon.live.status[scene.name]


def test_the_shared_parametrization_reads_the_uv_maps(addon, pressed):
    """The pair matched through the objects' UV maps (a seam through the contact on the slab):
    the add-on's result is squish.deform's on the same meshes and corner UVs, and the slab's
    deepest point is pushed along the UVs' projection direction, not along its normal."""
    scene = pressed
    ball, slab = scene.objects["Ball"], scene.objects["Slab"]
    uvs = {"Ball": _set_uvs(ball), "Slab": _set_uvs(slab, chart=lambda c: c[0] > 0.1)}
    pair = scene.squish.pairs[0]
    pair.mapping = "shared_parametrization"
    # No contact gap: the contact zone lands on the matched points (the gap would step back along
    # the normals).
    pair.use_contact_gap, pair.contact_gap = True, 0.0
    for obj in (ball, slab):
        obj.squish.uv_map = "Projected"
    assert bpy.ops.squish.live(enable=True) == {"FINISHED"}
    result = addon.live.last_result[scene.name]
    meshes = {o.name: squish.Mesh(world(o, positions(o)), triangles(o), uvs=uvs[o.name]) for o in (ball, slab)}
    (_, slab_out), report = squish.deform(meshes["Ball"], meshes["Slab"], a_rigid=True,
                                          pair_mapping="shared_parametrization", pair_contact_gap=0.0)
    assert report["frame"]["pairs"][0]["in_contact"]
    assert np.array_equal(result.world_positions["Slab"], slab_out)
    moved = slab_out - meshes["Slab"].vertices
    deepest = np.argmax(np.linalg.norm(moved, axis=1))
    angle = np.degrees(np.arcsin(min(1.0, np.linalg.norm(np.cross(moved[deepest] / np.linalg.norm(moved[deepest]), SLANT)))))
    print(f"slab's deepest point moved {np.linalg.norm(moved[deepest]):.3f}, {angle:.2e}° from the UVs' direction")
    # Blender stores UVs in float32: the projection holds to ~1e-7, the direction to ~1e-4°; the
    # slab's normal is 24° away.
    assert angle < 1e-2
    assert bpy.ops.squish.live(enable=False) == {"FINISHED"}
    # A UV map the object does not have is a one-line report naming it.
    slab.squish.uv_map = "Missing"
    with pytest.raises(RuntimeError, match='Slab: has no UV map "Missing".*pick one of its UV maps \\(.*Projected'):
        bpy.ops.squish.live(enable=True)


@pytest.fixture
def auto_man(addon):
    if not CESIUM_MAN.is_file():
        pytest.skip(f"{CESIUM_MAN} is absent (shared test data)")
    clear_scene(addon)
    man = demo_scenes.cesium_man(CESIUM_MAN)
    man.squish.articulations.clear()
    man.squish.self_contact = "AUTO"
    return man


def _crossing(man, tris, rest_faces: int) -> int:
    """Faces crossing another face of the shown mesh, beyond the rest pose's own."""
    return squish.Mesh(positions(man, evaluated=True), tris).self_intersecting_faces() - rest_faces


def test_cesium_man_with_self_contact_auto_live_and_baked(addon, auto_man, tmp_path):
    man, scene = auto_man, bpy.context.scene
    tris = triangles(man)
    rest_faces = squish.Mesh(positions(man), tris).self_intersecting_faces()
    scene.frame_set(9)
    before = _crossing(man, tris, rest_faces)
    assert bpy.ops.squish.live(enable=True) == {"FINISHED"}
    report = addon.live.last_result[scene.name].report
    names = {a["name"] for a in report["articulations"]}
    after = _crossing(man, tris, rest_faces)
    print(f"CesiumMan frame 9, self-contact Auto live: {len(names)} articulations, "
          f"{len(report['part_pairs'])} touching part pairs; crossing faces {before} → {after}")
    assert {"leg_joint_L_1 / leg_joint_L_2", "leg_joint_R_1 / leg_joint_R_2"} <= names
    assert before > 20 and after <= 0.25 * before
    assert bpy.ops.squish.live(enable=False) == {"FINISHED"}

    scene.squish.bake_start, scene.squish.bake_end = 7, 12
    scene.squish.bake_target = "POINT_CACHE"
    scene.squish.bake_directory = str(tmp_path)
    assert bpy.ops.squish.bake() == {"FINISHED"}
    baked = json.loads(bpy.data.texts["Squish bake report"].as_string())
    assert baked["failed_frames"] == {}
    totals = [0, 0]
    for frame in range(7, 13):
        scene.frame_set(frame)
        totals[1] += _crossing(man, tris, rest_faces)
    assert bpy.ops.squish.bake_clear() == {"FINISHED"}
    for frame in range(7, 13):
        scene.frame_set(frame)
        totals[0] += _crossing(man, tris, rest_faces)
    print(f"CesiumMan frames 7–12 baked with self-contact Auto: crossing faces {totals[0]} → {totals[1]}")
    assert totals[0] > 0 and totals[1] <= 0.25 * totals[0]


def test_self_contact_auto_needs_an_armature(addon, pressed):
    slab = pressed.objects["Slab"]
    slab.squish.self_contact = "AUTO"
    with pytest.raises(RuntimeError, match='Slab: self-contact "Auto" reads the skeleton from an Armature modifier'):
        bpy.ops.squish.live(enable=True)
