"""Headless tests of the Blender add-on with `bpy` from PyPI (see blender/test.sh).

The add-on is installed the way a user installs it: the extension zip (SQUISH_BLENDER_ZIP,
built by blender/build.py) through Blender's own extension installer, which installs the bundled
squish wheel into the extension's site-packages. Without a zip, the tests register the add-on
from the source folder (the squish package must then be importable).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import bpy
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SHARED_DATA = ROOT.parent / "shared" / "data"
sys.path.insert(0, str(ROOT / "blender"))

from demo_scenes import sphere, subdivided_cube  # noqa: E402,F401 - the tests' scene builders


def _install(zip_path: str):
    result = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
    assert result == {"FINISHED"}, f"installing {zip_path}: {result}"
    module = sys.modules.get("bl_ext.user_default.squish")
    assert module is not None, "the extension was installed but is not enabled"
    return module


@pytest.fixture(scope="session")
def addon():
    zip_path = os.environ.get("SQUISH_BLENDER_ZIP")
    if zip_path:
        module = _install(zip_path)
    else:
        import squish_blender as module

        module.register()
    yield module


def clear_scene(addon) -> None:
    """An empty scene (the add-on stays registered, unlike after a factory reset)."""
    scene = bpy.context.scene
    if scene.squish.live:
        addon.live.disable(scene)
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for collection in (bpy.data.meshes, bpy.data.armatures, bpy.data.actions, bpy.data.texts, bpy.data.node_groups):
        for item in list(collection):
            collection.remove(item)
    scene.squish.pairs.clear()
    scene.frame_start, scene.frame_end = 1, 250
    scene.frame_set(1)


def positions(obj, evaluated: bool = False) -> np.ndarray:
    """Object-space positions, float64 (n, 3): the mesh's own, or the evaluated ones."""
    if evaluated:
        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()
        source = obj.evaluated_get(depsgraph)
        mesh = source.to_mesh()
        out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", out)
        source.to_mesh_clear()
    else:
        out = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
        obj.data.vertices.foreach_get("co", out)
    return out.reshape(-1, 3).astype(np.float64)


def triangles(obj) -> np.ndarray:
    mesh = obj.data
    mesh.calc_loop_triangles()
    out = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("vertices", out)
    return out.reshape(-1, 3)


def world(obj, local: np.ndarray) -> np.ndarray:
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    return local @ matrix[:3, :3].T + matrix[:3, 3]
