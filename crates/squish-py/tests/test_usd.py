"""squish.usd.write_shot: a stage read back with Pixar's pxr."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import write_scene

import squish
import squish.usd

pxr = pytest.importorskip("pxr", reason="usd-core is not installed (pip install 'squish[usd]')")


def test_a_shot_round_trips_through_usd(tmp_path):
    scene_path = write_scene(tmp_path, frames=4)
    # The ball as an OBJ with texture coordinates and a quad, to check topology and UVs.
    ball = squish.read_mesh(tmp_path / "ball.obj")
    lines = (tmp_path / "ball.obj").read_text().splitlines()
    uv_lines = [f"vt {x * 0.5 + 0.5:.6f} {y * 0.5 + 0.5:.6f}" for x, y, _ in ball.vertices]
    faces = [line for line in lines if line.startswith("f ")]
    corners = [[int(c) for c in line.split()[1:]] for line in faces]
    with_uv = [line for line in lines if not line.startswith("f ")] + uv_lines
    with_uv += ["f " + " ".join(f"{c}/{c}" for c in face) for face in corners]
    (tmp_path / "ball.obj").write_text("\n".join(with_uv) + "\n")

    scene = squish.Scene.load(scene_path)
    result = scene.run(tmp_path / "out", threads=2, keep_points=True)
    stage_path = squish.usd.write_shot(tmp_path / "shot.usda", result)

    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(stage_path))
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (1, 4)
    assert stage.GetTimeCodesPerSecond() == 24 and UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    for i, name in enumerate(result.objects):
        mesh = UsdGeom.Mesh(stage.GetPrimAtPath(f"/squish/{name}"))
        assert mesh, name
        triangles = result.faces(i)
        assert list(mesh.GetFaceVertexCountsAttr().Get()) == [3] * len(triangles)
        assert np.array_equal(np.array(mesh.GetFaceVertexIndicesAttr().Get()), triangles.ravel())
        assert list(mesh.GetPointsAttr().GetTimeSamples()) == [1.0, 2.0, 3.0, 4.0]
        for frame in result.frames:
            points = np.array(mesh.GetPointsAttr().Get(frame))
            expected = squish.read_mesh(tmp_path / "out" / name / f"{frame:04}.obj").vertices
            assert np.array_equal(points, expected.astype(np.float32))
            assert np.array_equal(points, result.points(frame)[i].astype(np.float32))
            normals = np.array(mesh.GetNormalsAttr().Get(frame))
            assert normals.shape == points.shape and np.allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-5)
            extent = np.array(mesh.GetExtentAttr().Get(frame))
            assert np.allclose(extent, [points.min(axis=0), points.max(axis=0)])
    # The ball's UVs: face-varying, indexed as the file's corners.
    ball_prim = UsdGeom.Mesh(stage.GetPrimAtPath("/squish/ball"))
    st = UsdGeom.PrimvarsAPI(ball_prim).GetPrimvar("st")
    assert st and st.GetInterpolation() == UsdGeom.Tokens.faceVarying
    assert np.array_equal(np.array(st.GetIndices()), np.array(corners).ravel() - 1)
    values = np.array(st.Get())
    assert np.allclose(values, [[float(v) for v in line.split()[1:]] for line in uv_lines])
    assert not UsdGeom.PrimvarsAPI(UsdGeom.Mesh(stage.GetPrimAtPath("/squish/slab"))).GetPrimvar("st")


def test_write_shot_needs_the_kept_points(tmp_path):
    scene = squish.Scene.load(write_scene(tmp_path, frames=2))
    result = scene.run(tmp_path / "out", threads=1)
    with pytest.raises(squish.InputError, match="keep_points=True"):
        squish.usd.write_shot(tmp_path / "shot.usda", result)
