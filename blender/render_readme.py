"""Renders the README's before/after pictures of the Blender add-on with bpy (Workbench, headless).

    python blender/render_readme.py [OUT_DIR]     # default docs/images; needs bpy and squish

A ball pressed into a subdivided box and two intersecting balls, the add-on's live mode off
(before) and on (after), seen from the same camera; and, when the shared test data is next to
the repository, CesiumMan's left knee at the walk's deepest bend with its knee articulations.
"""

from __future__ import annotations

import sys
from pathlib import Path

import bpy

ROOT = Path(__file__).resolve().parent.parent
CESIUM_MAN = ROOT.parent / "shared" / "data" / "rigged" / "CesiumMan.glb"
sys.path.insert(0, str(ROOT / "blender"))

import demo_scenes  # noqa: E402 - after the path is set
import squish_blender  # noqa: E402


def build_scene() -> bpy.types.Scene:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    squish_blender.register()
    scene = bpy.context.scene
    ball = demo_scenes.sphere("Ball", 0.6, (0.0, 0.0, 1.3), subdivisions=5)
    box = demo_scenes.subdivided_cube("Box", 2.0, (0.0, 0.0, 0.0), cuts=16)
    left = demo_scenes.sphere("Left", 0.5, (2.6, 0.0, 0.2), subdivisions=5)
    right = demo_scenes.sphere("Right", 0.5, (3.35, 0.0, 0.2), subdivisions=5)
    for obj in (ball, box, left, right):
        for polygon in obj.data.polygons:
            polygon.use_smooth = True
    box.squish.stiffness = 1.0
    ball.squish.stiffness = 3.0
    for a, b in ((ball, box), (left, right)):
        pair = scene.squish.pairs.add()
        pair.object_a, pair.object_b = a, b
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    camera.location = (1.4, -8.0, 3.0)
    camera.rotation_euler = (1.24, 0.0, 0.0)
    scene.camera = camera
    scene.world = bpy.data.worlds.new("Backdrop")
    scene.world.color = (0.05, 0.055, 0.06)
    for obj, colour in ((ball, (0.9, 0.45, 0.2, 1.0)), (box, (0.35, 0.55, 0.8, 1.0)),
                        (left, (0.5, 0.75, 0.4, 1.0)), (right, (0.85, 0.75, 0.35, 1.0))):
        obj.color = colour
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.light = "STUDIO"
    scene.display.shading.show_cavity = True
    scene.display.shading.color_type = "OBJECT"
    scene.render.resolution_x, scene.render.resolution_y = 800, 450
    scene.render.film_transparent = False
    return scene


def cesium_man_scene() -> bpy.types.Scene:
    """CesiumMan at frame 9 (left knee bent furthest), both knees set from the bones, the camera
    on the inside of the bend."""
    # A factory reset keeps registered classes (the add-on is not enabled as an add-on here).
    squish_blender.unregister()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    squish_blender.register()
    scene = bpy.context.scene
    man = demo_scenes.cesium_man(CESIUM_MAN)
    scene.frame_set(9)
    armature = man.find_armature()
    knee = armature.matrix_world @ armature.pose.bones["leg_joint_L_2"].head
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    camera.location = (knee.x + 0.55, knee.y - 0.1, knee.z + 0.05)
    direction = knee - camera.location
    camera.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    scene.camera = camera
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.light = "STUDIO"
    scene.display.shading.show_cavity = True
    scene.world = bpy.data.worlds.new("Backdrop")
    scene.world.color = (0.05, 0.055, 0.06)
    scene.render.resolution_x, scene.render.resolution_y = 600, 450
    return scene


def render(scene, path: Path) -> None:
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    scene = build_scene()
    render(scene, out / "blender_before.png")
    if bpy.ops.squish.live(enable=True) != {"FINISHED"}:
        sys.exit("render_readme.py: live mode failed (see the report above)")
    render(scene, out / "blender_after.png")
    bpy.ops.squish.live(enable=False)
    if CESIUM_MAN.is_file():
        scene = cesium_man_scene()
        render(scene, out / "blender_knee_before.png")
        if bpy.ops.squish.live(enable=True) != {"FINISHED"}:
            sys.exit("render_readme.py: live mode failed on CesiumMan (see the report above)")
        render(scene, out / "blender_knee_after.png")


if __name__ == "__main__":
    main()
