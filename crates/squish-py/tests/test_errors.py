"""Bad parameters, malformed meshes and files: one-line exceptions naming the key or the file,
never a crash (the inputs of the command line's tests among them)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ball_and_slab

import squish


@pytest.fixture(scope="module")
def meshes():
    return ball_and_slab(subdivisions=2, cells=8)


@pytest.mark.parametrize(
    ("kwargs", "cli_set", "message"),
    [
        ({"a_params": {"stiffness": -1}}, "a.stiffness=-1", "a.stiffness = -1: must be > 0 (k, default 1)"),
        ({"b_extent": 0}, "b.extent=0", "b.extent = 0: must be > 0"),
        ({"a_params": {"stifness": 2}}, "a.stifness=2", 'a.stifness: unknown object parameter (did you mean "a.stiffness"?)'),
        ({"pair": {"safeguard_angle_degrees": 70}}, "pair.safeguard_angle_degrees=70", 'renamed (did you mean "pair.safeguard_angle"?)'),
        ({"pair_contact_method": "bal"}, "pair.contact_method=bal", 'did you mean "ball"'),
        ({"pair_safeguard_angle": 195}, "pair.safeguard_angle=195", "pair.safeguard_angle = 195: must be in [0, 180]"),
        ({"pair_contact_method": "ball"}, "pair.contact_method=ball", "pair.ball_radius"),
        ({"a_profile_v2": 0.9, "a_profile_v3": 0.5}, "a.profile_v2=0.9", "a.profile_v"),
    ],
)
def test_parameter_errors_carry_the_command_lines_message(meshes, cli, tmp_path, kwargs, cli_set, message):
    ball, slab = meshes
    with pytest.raises(squish.ParameterError) as caught:
        squish.deform(ball, slab, **kwargs)
    assert isinstance(caught.value, ValueError) and isinstance(caught.value, squish.SquishError)
    assert message in str(caught.value) and "\n" not in str(caught.value)
    # The command prints the same message after the argument it comes from.
    squish.write_mesh(tmp_path / "a.ply", ball)
    squish.write_mesh(tmp_path / "b.ply", slab)
    sets = ["--set", cli_set] + (["--set", "a.profile_v3=0.5"] if "profile_v3" in str(kwargs) else [])
    process = cli("deform", tmp_path / "a.ply", tmp_path / "b.ply", "-o", tmp_path / "out", *sets, check=False)
    assert process.returncode == 2
    if "profile" not in cli_set:
        assert str(caught.value) in process.stderr, process.stderr


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ({"rigid": "maybe"}, "a.rigid"),
        ({"direction": [1, 0]}, "a.direction"),
        ({"stiffness": object()}, "cannot read"),
        ({"bulge_map": [1.0, 2.0]}, "a.bulge_map: has 2 values but the mesh has"),
        ({"extent": float("nan")}, "a.extent = NaN"),
    ],
)
def test_wrong_kinds_and_lengths_are_parameter_errors(meshes, value, message):
    ball, slab = meshes
    with pytest.raises(squish.ParameterError) as caught:
        squish.deform(ball, slab, a_params=value)
    assert message in str(caught.value), str(caught.value)


def test_per_vertex_values_from_numpy(meshes):
    ball, slab = meshes
    weights = np.linspace(0.5, 1.5, ball.num_vertices)
    (a, _), report = squish.deform(ball, slab, a_params={"bulge_map": weights})
    (b, _), _ = squish.deform(ball, slab)
    assert not np.array_equal(a, b) and len(report["parameters"]["a"]["bulge_map"]) == ball.num_vertices


def test_frame_and_keyword_errors(meshes):
    ball, slab = meshes
    frame = squish.Frame()
    frame.add_object("ball", ball)
    with pytest.raises(squish.InputError, match='already named "ball"'):
        frame.add_object("ball", slab)
    with pytest.raises(squish.ParameterError, match=r"slab\.stiffness = 0"):
        frame.add_object("slab", slab, stiffness=0)
    frame.add_object("slab", slab)
    with pytest.raises(squish.InputError, match='no object named "ground"'):
        frame.add_pair("ball", "ground")
    with pytest.raises(squish.ParameterError, match="ball/slab.contact_tau"):
        frame.add_pair("ball", "slab", contact_tau="high")
    with pytest.raises(squish.ParameterError, match="a_KEY, b_KEY or pair_KEY"):
        squish.deform(ball, slab, stiffness=2)
    with pytest.raises(squish.InputError, match="region vertex 100000"):
        frame.add_articulation("ball", "elbow", ([0, 1], [100000]), direction=[0, 0, 1])
    with pytest.raises(squish.ParameterError, match="direction"):
        frame.add_articulation("ball", "elbow", ([0, 1], [1, 2]))
    with pytest.raises(squish.InputError, match="ball: rest positions: 3 rows, but the mesh has"):
        frame.set_rest_positions("ball", np.zeros((3, 3)))
    frame.set_rest_positions("ball", ball.vertices)


BAD_ARRAYS = [
    (np.zeros((4, 2)), [[0, 1, 2]], "shape (n, 3)"),
    (np.zeros(12), [[0, 1, 2]], "2-D array"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, np.nan]], [[0, 1, 2]], "non-finite"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, np.inf]], [[0, 1, 2]], "non-finite"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]], "vertex index 3"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, -1]], "vertex index -1"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2**40]], "vertex index"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1.5, 2]], "integer vertex indices"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.zeros((0, 3), dtype=int), "empty"),
    ([["a", "b", "c"]], [[0, 0, 0]], "expected numbers"),
    ("not an array", [[0, 1, 2]], "vertices"),
]


@pytest.mark.parametrize(("vertices", "faces", "message"), BAD_ARRAYS)
def test_malformed_arrays_are_input_errors(vertices, faces, message):
    with pytest.raises(squish.InputError) as caught:
        squish.Mesh(vertices, faces)
    assert message in str(caught.value).lower() or message in str(caught.value), str(caught.value)


def test_meshes_the_deformer_cannot_use_are_input_errors(meshes):
    ball, slab = meshes
    # A triangle with two equal corners, and a non-manifold edge (three faces on one edge).
    degenerate = squish.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 1], [0, 1, 2], [0, 2, 3], [0, 3, 1]])
    fan = squish.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], [[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    for bad in (degenerate, fan):
        with pytest.raises(squish.InputError):
            squish.deform(bad, slab)
        with pytest.raises(squish.InputError):
            squish.contact(ball, bad)
        frame = squish.Frame()
        frame.add_object("bad", bad)
        frame.add_object("slab", slab)
        frame.add_pair(0, 1)
        with pytest.raises(squish.InputError):
            frame.deform()


def test_malformed_files_are_input_errors_naming_the_file(tmp_path):
    # The files of the command line's tests (cli_info.rs, the readers' tests), and others.
    files = {
        "missing.obj": None,
        "bad_index.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n",
        "bad_number.obj": "v 0 0 zero\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "no_faces.obj": "v 0 0 0\nv 1 0 0\n",
        "truncated.ply": "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n",
        "garbage.glb": "glTF but not really",
        "mesh.stl": "solid nothing\n",
    }
    for name, text in files.items():
        path = tmp_path / name
        if text is not None:
            path.write_text(text)
        with pytest.raises(squish.InputError) as caught:
            squish.read_mesh(path)
        assert name in str(caught.value), str(caught.value)
    assert "bad_index.obj:4" in str(pytest.raises(squish.InputError, squish.read_mesh, tmp_path / "bad_index.obj").value)
    ball, _ = ball_and_slab(subdivisions=1)
    squish.write_mesh(tmp_path / "other.ply", ball_and_slab(subdivisions=2)[0])
    with pytest.raises(squish.InputError, match="the file has 162 vertices but the mesh has 42"):
        squish.write_mesh(tmp_path / "out.obj", ball, like=tmp_path / "other.ply")
    with pytest.raises(squish.InputError):
        squish.write_mesh(tmp_path / "out.stl", ball)


def test_scene_errors_are_input_errors(example_scene, tmp_path):
    with pytest.raises(squish.InputError, match="missing.toml"):
        squish.Scene.load(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text(example_scene.read_text().replace("stiffness = 3.0", "stifness = 3.0"))
    (tmp_path / "ball.obj").write_bytes((example_scene.parent / "ball.obj").read_bytes())
    (tmp_path / "ground.obj").write_bytes((example_scene.parent / "ground.obj").read_bytes())
    with pytest.raises(squish.InputError, match='did you mean "stiffness"'):
        squish.Scene.load(bad)
    scene = squish.Scene.load(example_scene)
    for frames in (range(40, 61), (40, 60), "a:b", (5, 2), 3.5):
        with pytest.raises(squish.InputError, match="frames") as caught:
            scene.run(tmp_path / "out", frames=frames)
        assert "--frames" not in str(caught.value), caught.value
    with pytest.raises(squish.InputError, match='"stl"'):
        scene.run(tmp_path / "out", frames=1, format="stl")
    with pytest.raises(squish.InputError, match="threads=0: give at least 1") as caught:
        scene.run(tmp_path / "out", frames=1, threads=0)
    assert "--threads" not in str(caught.value)


def test_a_corrupt_frame_fails_the_run_after_the_other_frames(tmp_path):
    # As `squish run`: the corrupt frame is recorded, the other frames are written, then the
    # run raises SquishError (exit 1 on the command line) with the frames to re-run.
    from conftest import write_scene

    scene_path = write_scene(tmp_path, frames=4)
    for frame in (1, 2, 4):
        (tmp_path / f"ball_{frame:04}.obj").write_bytes((tmp_path / "ball.obj").read_bytes())
    (tmp_path / "ball_0003.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 3\n")
    scene_path.write_text(scene_path.read_text().replace('mesh = "ball.obj"', 'mesh = "ball_{frame:04}.obj"'))
    # The frames to re-run are named as Python's argument, not the command line's flag.
    with pytest.raises(squish.SquishError, match=r"1 of 4 frames failed.*run the frames left: frames=\(3, 3\)") as caught:
        squish.Scene.load(scene_path).run(tmp_path / "out")
    assert not isinstance(caught.value, squish.InputError) and "--frames" not in str(caught.value)
    assert sorted(p.name for p in (tmp_path / "out" / "ball").iterdir()) == ["0001.obj", "0002.obj", "0004.obj"]
