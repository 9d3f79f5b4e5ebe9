"""Squish for Blender: contact deformation of mesh objects (Brunel et al.), live and baked.

A thin layer over the `squish` Python package (bundled as a wheel): the scene's pairs,
articulations and per-object settings become a `squish.Frame` at each frame. See docs/blender.md.
"""

from __future__ import annotations

import bpy

from . import live, operators, properties, ui


def register() -> None:
    properties.register()
    for cls in (*operators.CLASSES, *ui.CLASSES):
        bpy.utils.register_class(cls)
    live.register()


def unregister() -> None:
    live.unregister()
    for cls in reversed((*operators.CLASSES, *ui.CLASSES)):
        bpy.utils.unregister_class(cls)
    properties.unregister()
