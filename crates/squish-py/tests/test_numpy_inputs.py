"""What NumPy users hold goes wherever a mesh or a vector goes; frames follow Python's ranges; a
parameter given twice is an error; the namespace holds only the API."""

import types

import numpy as np
import pytest
from conftest import ball_and_slab, write_scene

import squish


def test_meshes_and_vectors_from_lists_tuples_and_arrays(tmp_path):
    reference = squish.Mesh.cuboid((2.0, 2.0, 0.5), 12)
    for size in ([2.0, 2.0, 0.5], np.array([2.0, 2.0, 0.5]), (2, 2, 0.5), np.array([2, 2, 0.5], dtype=np.float32)):
        assert np.array_equal(squish.Mesh.cuboid(size, 12).vertices, reference.vertices), size
    for size in ([2.0, 2.0], "big", [[2.0, 2.0, 0.5]]):
        with pytest.raises(squish.InputError, match="size"):
            squish.Mesh.cuboid(size, 12)

    ball, slab = ball_and_slab(depth=0.25, subdivisions=2, cells=8)
    (ball_ref, slab_ref), _ = squish.deform(ball, slab, b_stiffness=2.0)
    as_arrays = (ball.vertices, ball.faces)
    as_lists = (ball.vertices.tolist(), ball.faces.tolist())
    trimesh_like = types.SimpleNamespace(vertices=slab.vertices, faces=slab.faces.astype(np.int32))
    for a, b in [(as_arrays, (slab.vertices, slab.faces)), (as_lists, trimesh_like), ([*as_arrays], slab)]:
        (ball_out, slab_out), _ = squish.deform(a, b, b_stiffness=2.0)
        assert np.array_equal(ball_out, ball_ref) and np.array_equal(slab_out, slab_ref)
    result = squish.contact(as_arrays, trimesh_like)
    assert result["labels"][0].shape == (ball.num_vertices,)
    with pytest.raises(squish.InputError, match="a: cannot read int as a mesh"):
        squish.deform(3, slab)
    with pytest.raises(squish.InputError, match="b: faces: face 0 has vertex index"):
        squish.deform(ball, (slab.vertices[:3], slab.faces))

    # write_mesh takes plain arrays and lists.
    squish.write_mesh(tmp_path / "ball.ply", as_arrays)
    squish.write_mesh(tmp_path / "ball.obj", as_lists)
    for path in ("ball.ply", "ball.obj"):
        back = squish.read_mesh(tmp_path / path)
        assert np.array_equal(back.faces, ball.faces)
        assert np.allclose(back.vertices, ball.vertices, atol=1e-12)

    frame = squish.Frame()
    frame.add_object("ball", as_lists)
    frame.add_object("slab", trimesh_like, stiffness=2.0)
    frame.add_pair("ball", "slab")
    vertices, _ = frame.deform(threads=1)
    assert np.array_equal(vertices[0], ball_ref) and np.array_equal(vertices[1], slab_ref)


def test_frames_follow_pythons_ranges_and_refuse_the_ambiguous(tmp_path):
    scene = squish.Scene.load(write_scene(tmp_path, frames=6))
    assert scene.frames == range(1, 7) and scene.frame_range == (1, 6)
    for frames, expected in [
        ([1, 2], [1, 2]),
        (range(1, 3), [1, 2]),
        (np.array([3, 4, 5]), [3, 4, 5]),
        ((2, 3), [2, 3]),
        ("1:2", [1, 2]),
        (4, [4]),
        (scene.frames[-2:], [5, 6]),
    ]:
        result = scene.run(tmp_path / "out", frames=frames, threads=1)
        assert result.frames == expected, frames
    # A tuple (1, 3) once meant frames 1 to 3: as a list of frames it skips 2, so it is refused
    # with the spellings of what was meant.
    with pytest.raises(squish.InputError, match=r"range\(1, 4\) or \"1:3\""):
        scene.run(tmp_path / "out", frames=(1, 3))
    for frames, message in [
        ([1, 3, 4], "do not follow each other"),
        (range(1, 6, 2), "step 1"),
        (range(3, 3), "empty"),
        ([], "no frame"),
        (True, "boolean"),
        (2.5, "not a frame selection"),
        (range(5, 9), "frames 5:8"),
    ]:
        with pytest.raises(squish.InputError, match=message):
            scene.run(tmp_path / "out", frames=frames)


def test_a_parameter_given_twice_is_an_error():
    ball, slab = ball_and_slab(depth=0.25, subdivisions=1, cells=4)
    with pytest.raises(squish.ParameterError, match=r"a\.stiffness: given twice: a_params\['stiffness'\] = 2 and a_stiffness = 3"):
        squish.deform(ball, slab, a_params={"stiffness": 2}, a_stiffness=3)
    with pytest.raises(squish.ParameterError, match=r"pair\.contact_tau: given twice"):
        squish.contact(ball, slab, pair={"contact_tau": 0.5}, pair_contact_tau=0.5)
    frame = squish.Frame()
    with pytest.raises(squish.ParameterError, match=r"ball\.bulge: given twice: params\['bulge'\] = 1.5 and bulge = 2"):
        frame.add_object("ball", ball, {"bulge": 1.5}, bulge=2)
    frame.add_object("ball", ball)
    frame.add_object("slab", slab)
    with pytest.raises(squish.ParameterError, match="given twice"):
        frame.add_pair("ball", "slab", {"contact_tau": 1}, contact_tau=1)
    # Different keys in the dict and the keywords are fine.
    squish.deform(ball, slab, a_params={"stiffness": 2}, a_bulge=1.5, b_params={"bulge": 1.2})


def test_the_namespace_holds_the_api_only():
    public = {name for name in dir(squish) if not name.startswith("_")}
    assert "annotations" not in public
    submodules = {name for name in public if isinstance(getattr(squish, name), types.ModuleType)}
    assert public - submodules == set(squish.__all__), public - submodules ^ set(squish.__all__)


def test_uvs_from_arrays_and_files(tmp_path):
    grid = squish.Mesh.cuboid((1.0, 1.0, 1.0), 2)
    uv = grid.vertices[:, :2]
    mesh = squish.Mesh(grid.vertices, grid.faces, uvs=uv)
    assert np.array_equal(mesh.uvs, uv) and np.array_equal(mesh.with_vertices(mesh.vertices).uvs, uv)
    corners = uv[grid.faces]
    assert squish.Mesh(grid.vertices, grid.faces, uvs=corners).uvs.shape == (grid.num_faces, 3, 2)
    with pytest.raises(squish.InputError, match=r"uvs: shape \[3, 2\]"):
        squish.Mesh(grid.vertices, grid.faces, uvs=uv[:3])
    assert grid.uvs is None
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 9 9\nf 1/1 2/2 3/3\nf 2/4 4/4 3/4\n")
    read = squish.read_mesh(tmp_path / "tri.obj")
    assert read.uvs.shape == (2, 3, 2) and read.uvs[1, 0].tolist() == [9.0, 9.0]
    # The shared parametrization needs them, and says so.
    ball, slab = ball_and_slab(depth=0.25, subdivisions=2, cells=8)
    with pytest.raises(squish.ParameterError, match=r"a\.uvs: .*has none"):
        squish.deform(ball, slab, pair_mapping="shared_parametrization")
    frame = squish.Frame()
    frame.add_object("ball", ball)
    frame.add_object("slab", slab)
    with pytest.raises(squish.ParameterError, match='object "ball" has no UVs'):
        frame.add_pair("ball", "slab", mapping="shared_parametrization")
