"""Scenes built with bpy for the add-on's tests and the README's pictures: closed meshes from
bmesh, and CesiumMan imported with Blender's glTF importer and its knees set from its bones."""

from __future__ import annotations

from pathlib import Path

import bpy  # first: bmesh comes with it
import bmesh

KNEES = {"left knee": ("leg_joint_L_1", "leg_joint_L_2"), "right knee": ("leg_joint_R_1", "leg_joint_R_2")}


def mesh_object(name: str, build, location) -> bpy.types.Object:
    """A mesh object built by `build(bmesh)`, linked to the scene at `location`."""
    mesh = bpy.data.meshes.new(name)
    built = bmesh.new()
    build(built)
    built.to_mesh(mesh)
    built.free()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = location
    return obj


def sphere(name: str, radius: float, location, subdivisions: int = 3) -> bpy.types.Object:
    return mesh_object(name, lambda b: bmesh.ops.create_icosphere(b, subdivisions=subdivisions, radius=radius),
                       location)


def subdivided_cube(name: str, size: float, location, cuts: int = 6) -> bpy.types.Object:
    def build(b):
        bmesh.ops.create_cube(b, size=size)
        bmesh.ops.subdivide_edges(b, edges=b.edges[:], cuts=cuts, use_grid_fill=True)

    return mesh_object(name, build, location)


def cesium_man(path: Path) -> bpy.types.Object:
    """CesiumMan imported, its skin welded, both knees set from its bones; the mesh object."""
    assert bpy.ops.import_scene.gltf(filepath=str(path)) == {"FINISHED"}
    man = next(o for o in bpy.data.objects if o.type == "MESH")
    # glTF splits vertices along UV seams: "Merge by Distance" makes the skin one closed surface
    # (as `squish run` welds it).
    built = bmesh.new()
    built.from_mesh(man.data)
    bmesh.ops.remove_doubles(built, verts=built.verts[:], dist=1e-6)
    built.to_mesh(man.data)
    built.free()
    bpy.context.view_layer.objects.active = man
    for name, (parent, child) in KNEES.items():
        assert bpy.ops.squish.articulation_add() == {"FINISHED"}
        articulation = man.squish.articulations[-1]
        articulation.name, articulation.parent_bone, articulation.child_bone = name, parent, child
    return man
