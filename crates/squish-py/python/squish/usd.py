"""A shot's deformed meshes as a USD stage (extra ``squish[usd]``, Pixar's ``usd-core``).

``write_shot(stage_path, result)`` writes one ``UsdGeom.Mesh`` per object of a ``squish.Scene.run``
result (run with ``keep_points=True``) under ``/squish``: the source file's topology (an OBJ
file's polygons as written, triangles for other formats) and vertex order, its texture
coordinates as the ``st`` primvar (face-varying, indexed, for OBJ files with ``vt``), and per frame
time-sampled ``points``, vertex ``normals`` (area-weighted) and ``extent``. Time codes are the
scene's frames at its frames per second; the up axis is Y when a source is glTF (y-up by
definition), else Z (squish's convention for OBJ and PLY). The file is written to a temporary
name and renamed, so an existing stage is replaced whole or not at all.
"""

from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path

import numpy as np

from . import InputError, _squish

__all__ = ["write_shot", "vertex_normals"]


def vertex_normals(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (unit length; zero for a vertex without area)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    face = np.cross(b - a, c - a)  # twice the area, along the normal
    normals = np.zeros_like(points)
    for k in range(3):
        np.add.at(normals, triangles[:, k], face)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


def _prim_name(name: str, taken: set[str]) -> str:
    """A valid, unique USD prim name for an object name."""
    base = re.sub(r"[^A-Za-z0-9_]", "_", name) or "object"
    if base[0].isdigit():
        base = "_" + base
    candidate, k = base, 1
    while candidate in taken:
        k += 1
        candidate = f"{base}_{k}"
    taken.add(candidate)
    return candidate


def write_shot(stage_path: str | os.PathLike, result) -> Path:
    """Writes ``result`` (a ``squish.ShotResult`` of ``Scene.run(..., keep_points=True)``) as a USD
    stage at ``stage_path`` (``.usda``, ``.usdc`` or ``.usd``); returns its path."""
    try:
        from pxr import Sdf, Usd, UsdGeom, Vt
    except ImportError as error:
        raise InputError(f"squish.usd needs Pixar's usd-core: pip install 'squish[usd]' ({error})") from None
    stage_path = Path(stage_path)
    frames = list(result.frames)
    if not frames:
        raise InputError("the shot computed no frame: nothing to write")
    samples = {frame: result.points(frame) for frame in frames}  # raises without keep_points

    stage = Usd.Stage.CreateInMemory()
    root = UsdGeom.Xform.Define(stage, "/squish")
    stage.SetDefaultPrim(root.GetPrim())
    stage.SetStartTimeCode(frames[0])
    stage.SetEndTimeCode(frames[-1])
    stage.SetTimeCodesPerSecond(result.fps)
    stage.SetFramesPerSecond(result.fps)
    sources = [result.source(i) for i in range(len(result.objects))]
    gltf = any(str(path).lower().endswith((".gltf", ".glb")) for path, _ in sources)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y if gltf else UsdGeom.Tokens.z)

    taken: set[str] = set()
    for i, name in enumerate(result.objects):
        path, sequence = sources[i]
        triangles = result.faces(i)
        if sequence:
            # A sequence's files share one topology; the frame's own file is not needed for it.
            topology = {"face_vertex_counts": np.full(len(triangles), 3), "face_vertex_indices": triangles.ravel(), "uv": None}
        else:
            topology = _squish.source_topology(path)
        mesh = UsdGeom.Mesh.Define(stage, f"/squish/{_prim_name(name, taken)}")
        mesh.GetPrim().SetMetadata("comment", f"squish object {name!r} from {path}")
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(topology["face_vertex_counts"].astype(np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(topology["face_vertex_indices"].astype(np.int32)))
        if topology["uv"] is not None:
            values, indices = topology["uv"]
            st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
                "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying
            )
            st.Set(Vt.Vec2fArray.FromNumpy(values.astype(np.float32)))
            st.SetIndices(Vt.IntArray.FromNumpy(indices.astype(np.int32)))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        points_attr, normals_attr, extent_attr = (
            mesh.CreatePointsAttr(),
            mesh.CreateNormalsAttr(),
            mesh.CreateExtentAttr(),
        )
        for frame in frames:
            points = samples[frame][i]
            time = Usd.TimeCode(frame)
            points_attr.Set(Vt.Vec3fArray.FromNumpy(points.astype(np.float32)), time)
            normals = vertex_normals(points, triangles)
            normals_attr.Set(Vt.Vec3fArray.FromNumpy(normals.astype(np.float32)), time)
            bounds = np.stack([points.min(axis=0), points.max(axis=0)]).astype(np.float32)
            extent_attr.Set(Vt.Vec3fArray.FromNumpy(bounds), time)

    stage_path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f".{stage_path.stem}.", suffix=stage_path.suffix, dir=stage_path.parent)
    os.close(handle)
    try:
        if not stage.GetRootLayer().Export(temporary):
            raise InputError(f"{stage_path}: USD could not write the stage")
        os.replace(temporary, stage_path)
    finally:
        if os.path.exists(temporary):
            os.remove(temporary)
    return stage_path
